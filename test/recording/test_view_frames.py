# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A carrier's ``<body>_view`` and a free body's ``<body>_chase`` follow them right way up (SPEC 4).

A banked, pitched, turning carrier under a slanted gravity; the recording is
read back with rosbags and every frame composed to the root from ``/tf`` and
``/tf_static`` with scipy's rotations (not cfem_ros's): the view frame's
origin is the carrier's CG as its pose says, its z axis is -gravity, its x
axis the carrier's x projected on the level plane; the store's chase frame
is at the store's CG, z up, x the view frame's x.
"""

from cfem_ros import cli
import numpy as np
import pytest
from recordings import read_rosbags
from scipy.spatial.transform import Rotation
import yaml

GRAVITY = np.array([0.0, 3.0, 9.0])   # slanted: the root turns it to -z
SCENARIO = {
    'name': 'view_frames', 'frame_id': 'world', 'gravity': GRAVITY.tolist(),
    'duration': 0.3, 'dt': 0.001,
    'bodies': {
        'aircraft': {'position': [0, 0, 0], 'orientation_rpy_deg': [20, 40, 30],
                     'motion': {'velocity': [250, 10, 0], 'angular_velocity_deg': [5, 20, 40]},
                     'shape': {'box': [10, 8, 1]}},
        'store': {'mass': 100.0, 'inertia': [1, 5, 5], 'position': [0, 0, 1.0],
                  'velocity': [250, 10, 0]},
    },
}


@pytest.fixture(scope='module')
def frames(tmp_path_factory):
    folder = tmp_path_factory.mktemp('view_frames')
    (folder / 'view.yaml').write_text(yaml.safe_dump(SCENARIO))
    out = folder / 'view.mcap'
    assert cli.main(['run', str(folder / 'view.yaml'), '-o', str(out)]) == 0
    messages, _ = read_rosbags(out)
    return messages


def _tree(messages, stamp):
    """Return child -> (parent, translation, Rotation) at a stamp, static frames included."""
    tree = {}
    for topic, t, message in messages:
        if topic == '/tf_static' or (topic == '/tf' and t == stamp):
            for tf in message.transforms:
                v, q = tf.transform.translation, tf.transform.rotation
                tree[tf.child_frame_id] = (tf.header.frame_id, np.array([v.x, v.y, v.z]),
                                           Rotation.from_quat([q.x, q.y, q.z, q.w]))
    return tree


def _in_root(tree, frame):
    """Return (root, translation, Rotation) of a frame composed up to the tree's root."""
    translation, rotation = np.zeros(3), Rotation.identity()
    while frame in tree:
        parent, t, r = tree[frame]
        translation, rotation = t + r.apply(translation), r * rotation
        frame = parent
    return frame, translation, rotation


def test_view_frame_is_the_carrier_right_way_up(frames):
    poses = {t: m.pose for topic, t, m in frames if topic == '/cfem/bodies/aircraft/pose'}
    assert len(poses) == 31
    _, _, world_in_root = _in_root(_tree(frames, 0), 'world')
    down = world_in_root.apply(GRAVITY / np.linalg.norm(GRAVITY))
    np.testing.assert_allclose(down, [0, 0, -1], atol=1e-12)   # the root is z up
    headings, levels = [], []
    for stamp, pose in poses.items():
        tree = _tree(frames, stamp)
        root, origin, view = _in_root(tree, 'aircraft_view')
        assert root == 'map' and tree['aircraft_view'][0] == 'map'
        # the origin: the carrier's CG as its recorded pose puts it
        p, q = pose.position, pose.orientation
        cg = world_in_root.apply([p.x, p.y, p.z])
        np.testing.assert_allclose(origin, cg, atol=1e-9)
        np.testing.assert_allclose(_in_root(tree, 'aircraft')[1], cg, atol=1e-9)
        # z along -gravity, x along the carrier's x on the level plane
        x_view, z_view = view.apply([1, 0, 0]), view.apply([0, 0, 1])
        np.testing.assert_allclose(z_view, -down, atol=1e-12)
        x_body = (world_in_root * Rotation.from_quat([q.x, q.y, q.z, q.w])).apply([1, 0, 0])
        level = x_body - x_body.dot(z_view) * z_view
        np.testing.assert_allclose(x_view, level / np.linalg.norm(level), atol=1e-9)
        levels.append(np.linalg.norm(level))
        headings.append(np.degrees(np.arctan2(x_view[1], x_view[0])))
    assert np.ptp(headings) > 5.0   # it turns with the carrier
    assert min(levels) < 0.95   # the carrier pitches: the projection is a real one


def test_chase_frame_at_the_cg_right_way_up_along_the_view(frames):
    poses = {t: m.pose for topic, t, m in frames if topic == '/cfem/bodies/store/pose'}
    assert len(poses) == 31
    _, _, world_in_root = _in_root(_tree(frames, 0), 'world')
    up = world_in_root.apply(-GRAVITY / np.linalg.norm(GRAVITY))
    for stamp, pose in poses.items():
        tree = _tree(frames, stamp)
        root, origin, chase = _in_root(tree, 'store_chase')
        assert root == 'map' and tree['store_chase'][0] == 'map'
        p = pose.position
        np.testing.assert_allclose(origin, world_in_root.apply([p.x, p.y, p.z]), atol=1e-9)
        np.testing.assert_allclose(chase.apply([0, 0, 1]), up, atol=1e-12)
        x_chase = chase.apply([1, 0, 0])
        assert abs(x_chase @ up) < 1e-12   # horizontal
        np.testing.assert_allclose(x_chase, _in_root(tree, 'aircraft_view')[2].apply([1, 0, 0]),
                                   atol=1e-12)


def test_only_carriers_get_a_view_frame(frames):
    children = {tf.child_frame_id for topic, _, m in frames if topic in ('/tf', '/tf_static')
                for tf in m.transforms}
    assert children == {'world', 'aircraft', 'store', 'aircraft_view', 'store_chase'}
    # one /tf message per sample: a viewer that seeks shows the last one before the time
    stamps = [t for topic, t, _ in frames if topic == '/tf']
    assert len(stamps) == len(set(stamps)) == 31
