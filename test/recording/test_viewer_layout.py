# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The shipped viewer layouts (``config/viewer/``) fit the examples' recordings.

Each is what ``viewerlayout.layout`` makes of its example today; the frame
it follows, the topics it shows and plots are in a recording of the example,
and the frames it leaves visible start at distinct points (no two labels
printed over each other), composed from the recording's ``/tf`` and
``/tf_static``.
"""

import json
import pathlib

from cfem_ros import cli, load_scenario
from cfem_ros.recording import viewerlayout
import numpy as np
import pytest
from recordings import read_rosbags
from scipy.spatial.transform import Rotation

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
EXAMPLES = ['store_separation', 'store_release_near_pylon', 'store_release_two_hooks']


def test_every_shipped_layout_is_the_one_its_example_gets_today():
    shipped = sorted(p.stem for p in (CONFIG / 'viewer').glob('*.json'))
    assert shipped == sorted(EXAMPLES)
    for name in EXAMPLES:
        text = (CONFIG / 'viewer' / f'{name}.json').read_text()
        assert json.loads(text) == viewerlayout.layout(load_scenario(str(CONFIG / f'{name}.yaml')))


def _frames_at(messages, stamp):
    """Return every frame's position in the root, composed from /tf_static and /tf at stamp."""
    tree = {}
    for topic, t, message in messages:
        if topic == '/tf_static' or (topic == '/tf' and t == stamp):
            for tf in message.transforms:
                v, q = tf.transform.translation, tf.transform.rotation
                tree[tf.child_frame_id] = (tf.header.frame_id, np.array([v.x, v.y, v.z]),
                                           Rotation.from_quat([q.x, q.y, q.z, q.w]))
    out = {}
    for frame in set(tree) | {parent for parent, _, _ in tree.values()}:
        at, name = np.zeros(3), frame
        while name in tree:
            parent, t, r = tree[name]
            at, name = t + r.apply(at), parent
        out[frame] = at
    return out


@pytest.mark.parametrize('name', EXAMPLES)
def test_a_layout_shows_what_its_recording_holds(name, tmp_path):
    layout = json.loads((CONFIG / 'viewer' / f'{name}.json').read_text())
    out = tmp_path / f'{name}.mcap'
    assert cli.main(['run', str(CONFIG / f'{name}.yaml'), '-o', str(out),
                     '--duration', '0.02']) == 0
    messages, _ = read_rosbags(out)
    topics = {topic for topic, _, _ in messages}
    three_d = layout['configById']['3D!cfem']
    assert set(three_d['topics']) == {'/cfem/markers', '/cfem/load_markers'} <= topics
    plotted = [p['value'] for key, panel in layout['configById'].items()
               if key.startswith('Plot!') for p in panel['paths']]
    assert len(plotted) >= 4 and {p.split('.')[0] for p in plotted} <= topics
    position = [p['value'] for p in layout['configById']['Plot!position']['paths']]
    kind = 'pose' if name == 'store_separation' else 'relative_pose'   # in the carrier's axes
    assert position == [f'/cfem/bodies/store/{kind}.pose.position.{c}' for c in 'xz']
    assert layout['configById']['RawMessages!events']['topicPath'] == '/cfem/events'
    frames = _frames_at(messages, 0)
    assert three_d['followTf'] in frames
    if name != 'store_separation':   # a moving carrier: followed right way up
        assert three_d['followTf'].endswith('_view')
    hidden = {key.removeprefix('frame:') for key in three_d['transforms']}
    assert hidden <= set(frames)
    shown = [frames[f] for f in frames if f not in hidden]
    gaps = [np.linalg.norm(a - b) for i, a in enumerate(shown) for b in shown[i + 1:]]
    assert min(gaps) > 0.05   # no two labels at one point
