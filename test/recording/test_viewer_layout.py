# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The shipped viewer layouts (``config/viewer/``) fit the examples' recordings.

Every store example has one, and it is what ``cfem-sim run --layout`` writes
for it today; every topic path it names is in the run's recording, every
frame it follows in its ``/tf`` (the carrier's view and the store's chase
frame), and the frames it leaves visible start at distinct points (no two
labels printed over each other), composed from the recording's ``/tf`` and
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
EXAMPLES = sorted(p.stem for p in CONFIG.glob('store_*.yaml'))


def test_every_store_example_has_its_layout_of_today():
    assert len(EXAMPLES) >= 8
    assert sorted(p.stem for p in (CONFIG / 'viewer').glob('*.json')) == EXAMPLES
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
    out, written = tmp_path / f'{name}.mcap', tmp_path / 'layouts' / f'{name}.json'
    assert cli.main(['run', str(CONFIG / f'{name}.yaml'), '-o', str(out),
                     '--duration', '0.02', '--layout', str(written)]) == 0
    layout = json.loads(written.read_text())
    assert layout == json.loads((CONFIG / 'viewer' / f'{name}.json').read_text())
    messages, _ = read_rosbags(out)
    topics = {topic for topic, _, _ in messages}
    panels = layout['configById']
    plotted = [p['value'] for key, panel in panels.items()
               if key.startswith('Plot!') for p in panel['paths']]
    # no empty plot: every series is a message path of a topic the recording has
    assert all(len(panels[key]['paths']) >= 2 for key in panels if key.startswith('Plot!'))
    assert {p.split('.')[0] for p in plotted} <= topics
    position = [p['value'] for p in panels['Plot!position']['paths']]
    model = load_scenario(str(CONFIG / f'{name}.yaml'))
    fixed = all(b.fixed or b.dynamic for b in model.bodies)   # no carrier that moves
    kind = 'pose' if fixed else 'relative_pose'   # a moving carrier: in its axes
    assert position == [f'/cfem/bodies/store/{kind}.pose.position.{c}' for c in 'xz']
    assert panels['RawMessages!events']['topicPath'] == '/cfem/events'
    frames = _frames_at(messages, 0)
    cfem, chase = panels['3D!cfem'], panels['3D!chase']
    assert chase['followTf'] == 'store_chase'   # the store, z up, to the end
    assert cfem['followTf'].endswith('_view') != fixed   # a moving carrier: its view
    for three_d in (cfem, chase):
        assert set(three_d['topics']) == {'/cfem/markers', '/cfem/load_markers'} <= topics
        assert three_d['followTf'] in frames
        hidden = {key.removeprefix('frame:') for key in three_d['transforms']}
        assert hidden <= set(frames)
        shown = [frames[f] for f in frames if f not in hidden]
        gaps = [np.linalg.norm(a - b) for i, a in enumerate(shown) for b in shown[i + 1:]]
        assert not gaps or min(gaps) > 0.05   # no two labels at one point


def test_a_layout_is_refused_where_it_would_replace_a_file(tmp_path, capsys):
    scenario, out = str(CONFIG / 'store_separation.yaml'), tmp_path / 'run.mcap'
    existing = tmp_path / 'mine.json'
    existing.write_text('{}')
    assert cli.main(['run', scenario, '-o', str(out), '--layout', str(existing)]) == 2
    assert '--layout' in capsys.readouterr().err and existing.read_text() == '{}'
    assert cli.main(['run', scenario, '-o', str(out), '--layout', scenario]) == 2
    assert 'is the scenario' in capsys.readouterr().err and not out.exists()
