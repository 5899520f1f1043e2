# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Recordings carry /tf, /tf_static and markers that place each body where its pose says.

Read back with rosbags (types built from the file's schemas, an independent
CDR decoder): every /tf transform equals the body's pose at that stamp, the
fixed bodies are on /tf_static, and each body's marker, composed with its
frame, lands on the body's CG (plus the shape's offset turned with the body).
"""

import math
import pathlib
import urllib.parse

from cfem_ros import cli, load_scenario, parse_scenario
from cfem_ros.core import rotations
from cfem_ros.core.model.shapes import equivalent_box
from cfem_ros.recording import analysis, visuals
import numpy as np
import pytest
from recordings import read_rosbags
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'


@pytest.fixture(scope='module')
def store_file(tmp_path_factory):
    out = tmp_path_factory.mktemp('visuals') / 'store.mcap'
    assert cli.main(['run', str(CONFIG / 'store_separation.yaml'), '-o', str(out)]) == 0
    return out


@pytest.fixture(scope='module')
def store(store_file):
    messages, _ = read_rosbags(store_file)
    return messages


def _apply(translation, rotation, point):
    matrix = rotations.matrices(np.array([rotation]))[0]
    return np.asarray(translation) + matrix @ np.asarray(point)


def test_tf_carries_every_pose_and_static_the_fixed_bodies(store):
    poses = {t: m for topic, t, m in store if topic == '/cfem/bodies/store/pose'}
    tfs = [(t, m) for topic, t, m in store if topic == '/tf']
    assert len(tfs) == len(poses) == 151
    for t, message in tfs:
        transform, chase = message.transforms   # the store, its chase frame (test_view_frames)
        assert (transform.header.frame_id, transform.child_frame_id) == ('world', 'store')
        assert chase.child_frame_id == 'store_chase'
        pose = poses[t].pose
        a, b = transform.transform.translation, transform.transform.rotation
        assert (a.x, a.y, a.z) == (pose.position.x, pose.position.y, pose.position.z)
        assert (b.x, b.y, b.z, b.w) == (pose.orientation.x, pose.orientation.y,
                                        pose.orientation.z, pose.orientation.w)
    (static,) = [m for topic, _, m in store if topic == '/tf_static']
    # z-up root, the fixed pylon, and the joint's frame on its child
    assert [(t.header.frame_id, t.child_frame_id) for t in static.transforms] == [
        ('map', 'world'), ('world', 'pylon'), ('store', 'pivot')]


def test_markers_place_the_shapes_and_mark_the_release(store):
    arrays = [(t, m) for topic, t, m in store if topic == '/cfem/markers']
    # at t = 0, when the pivot lets go, and again each second for late viewers
    assert len(arrays) == 3
    (t0, first), (t1, second), (t2, third) = arrays
    release = next(m for topic, _, m in store if topic == '/cfem/events')
    assert t0 == 0 and t1 == round(yaml.safe_load(release.data)['time'] * 1e9)
    assert t2 == 1_000_000_000

    def drawn(array):
        return [(m.ns, m.id, m.type, m.header.frame_id, m.color.r, m.color.a)
                for m in array.markers]
    assert drawn(third) == drawn(second) != drawn(first)
    bodies = {m.text: m for m in first.markers if m.ns == '/cfem/bodies'}
    store_marker, pylon_marker = bodies['store'], bodies['pylon']
    assert store_marker.header.frame_id == 'store' and store_marker.frame_locked
    assert store_marker.type == visuals.CYLINDER
    assert (store_marker.scale.x, store_marker.scale.y, store_marker.scale.z) == (0.5, 0.5, 2.5)
    # a cylinder marker stands on z: turned so that its axis is the store's x axis
    q = store_marker.pose.orientation
    axis = rotations.matrices(np.array([[q.x, q.y, q.z, q.w]]))[0] @ [0, 0, 1]
    np.testing.assert_allclose(axis, [1, 0, 0], atol=1e-15)
    assert pylon_marker.type == visuals.CUBE and pylon_marker.header.frame_id == 'pylon'
    # the pylon's box sits 0.45 m above the store's CG (z down), through /tf_static
    (static,) = [m for topic, _, m in store if topic == '/tf_static']
    frame = static.transforms[1].transform
    p = pylon_marker.pose.position
    centre = _apply([frame.translation.x, frame.translation.y, frame.translation.z],
                    [frame.rotation.x, frame.rotation.y, frame.rotation.z, frame.rotation.w],
                    [p.x, p.y, p.z])
    np.testing.assert_allclose(centre, [0, 0, -0.45])
    # the joint's sphere, on its parent's frame, is at the anchor
    (joint,) = [m for m in first.markers if m.ns == '/cfem/joints']
    assert joint.header.frame_id == 'pylon' and joint.text == 'pivot'
    j = joint.pose.position
    anchor = _apply([frame.translation.x, frame.translation.y, frame.translation.z],
                    [frame.rotation.x, frame.rotation.y, frame.rotation.z, frame.rotation.w],
                    [j.x, j.y, j.z])
    np.testing.assert_allclose(anchor, [-0.3292, 0, -0.25], atol=1e-15)
    held = (joint.color.r, joint.color.g, joint.color.b, joint.color.a)
    (after,) = [m for m in second.markers if m.ns == '/cfem/joints']
    assert (after.color.r, after.color.g, after.color.b, after.color.a) != held
    assert after.color.a < held[3]


def test_a_marker_follows_its_body_with_its_offset(tmp_path):
    document = {
        'name': 'offset', 'gravity': [0, 0, 0], 'duration': 0.5,
        'bodies': {'box': {'mass': 2.0, 'inertia': [1.0, 2.0, 3.0], 'velocity': [1, 2, 3],
                           'angular_velocity_deg': [40, 30, 20],
                           'shape': {'sphere': 0.2, 'offset': [0.3, -0.1, 0.2]}}},
    }
    scenario = tmp_path / 'offset.yaml'
    scenario.write_text(yaml.safe_dump(document))
    out = tmp_path / 'offset.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out)]) == 0
    messages, _ = read_rosbags(out)
    (array,) = [m for topic, _, m in messages if topic == '/cfem/markers']
    (marker,) = array.markers
    assert marker.type == visuals.SPHERE and marker.scale.x == 0.4
    offset = [marker.pose.position.x, marker.pose.position.y, marker.pose.position.z]
    poses = {t: m.pose for topic, t, m in messages if topic == '/cfem/bodies/box/pose'}
    for t, message in [(t, m) for topic, t, m in messages if topic == '/tf']:
        transform = message.transforms[0].transform
        a, b = transform.translation, transform.rotation
        centre = _apply([a.x, a.y, a.z], [b.x, b.y, b.z, b.w], offset)
        pose = poses[t]
        expected = _apply([pose.position.x, pose.position.y, pose.position.z],
                          [pose.orientation.x, pose.orientation.y, pose.orientation.z,
                           pose.orientation.w], [0.3, -0.1, 0.2])
        np.testing.assert_allclose(centre, expected, atol=1e-15)


def test_the_default_shape_is_the_box_of_the_inertia():
    mass, inertia = 3.0, np.diag([1.0, 2.0, 2.5])
    box = equivalent_box(mass, inertia)
    a, b, c = sorted(box.size, reverse=True)
    # a uniform box of these edges has the given principal moments
    moments = sorted([mass * (b * b + c * c) / 12, mass * (a * a + c * c) / 12,
                      mass * (a * a + b * b) / 12])
    np.testing.assert_allclose(moments, [1.0, 2.0, 2.5])
    # products of inertia turn the box to the principal axes
    turned = rotations.matrices(np.array([rotations.from_rpy_deg([0, 0, 30])]))[0]
    box = equivalent_box(mass, turned @ inertia @ turned.T)
    axes = rotations.matrices(np.array([box.orientation_xyzw]))[0]
    inertia_back = axes @ np.diag([mass * (box.size[1] ** 2 + box.size[2] ** 2) / 12,
                                   mass * (box.size[0] ** 2 + box.size[2] ** 2) / 12,
                                   mass * (box.size[0] ** 2 + box.size[1] ** 2) / 12]) @ axes.T
    np.testing.assert_allclose(inertia_back, turned @ inertia @ turned.T, atol=1e-12)
    model = load_scenario(str(CONFIG / 'double_pendulum.yaml'))
    assert all(visuals.body_shape(b).given is False for b in model.bodies)
    assert math.isclose(visuals.body_shape(model.bodies[0]).size[0], 0.1) or \
        not model.bodies[0].fixed


@pytest.mark.parametrize('shape, fragment', [
    ({'box': [1, 2]}, 'bodies.b.shape.box'),
    ({'cone': 1}, 'bodies.b.shape.cone'),
    ({'box': [1, 1, 1], 'sphere': 1}, 'exactly one'),
    ({'sphere': -1}, 'bodies.b.shape.sphere'),
    ({'cylinder': [0.1, 0]}, 'sizes > 0'),
    ({'mesh': ''}, 'mesh file or URL'),
    ({'box': [1, 1, 1], 'scale': [1, 1, 1]}, 'scale only with mesh'),
])
def test_bad_shapes_are_refused_with_the_key_path(shape, fragment):
    document = {'bodies': {'b': {'mass': 1.0, 'inertia': [1, 1, 1], 'shape': shape}}}
    with pytest.raises(Exception) as err:
        parse_scenario(document)
    assert type(err.value).__name__ == 'ScenarioError' and fragment in str(err.value)


def test_mesh_paths_are_percent_encoded_urls_and_a_missing_mesh_is_refused(tmp_path):
    folder = tmp_path / 'mesh test'
    folder.mkdir()
    corners = ['0 0 0', '1 0 0', '0 1 0', '0 0 1']   # a tetrahedron: its hull is the shape
    facets = ''.join('facet normal 0 0 0\nouter loop\n' + ''.join(
        f'vertex {corners[i]}\n' for i in face) + 'endloop\nendfacet\n'
        for face in [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)])
    (folder / 'store mesh.stl').write_text(f'solid store\n{facets}endsolid store\n')
    scenario = folder / 'scenario.yaml'
    document = {'bodies': {'store': {'mass': 1.0, 'inertia': [1, 1, 1],
                                     'shape': {'mesh': 'store mesh.stl'}}}}
    scenario.write_text(yaml.safe_dump(document))
    (marker,) = [m for m in visuals.markers(load_scenario(str(scenario)),
                                            {'sec': 0, 'nanosec': 0}, '/cfem')['markers']
                 if m.get('mesh_resource')]
    url = marker['mesh_resource']
    assert url == 'file://' + str(folder).replace(' ', '%20') + '/store%20mesh.stl'
    assert ' ' not in url and pathlib.Path(urllib.parse.unquote(url[7:])).is_file()
    document['bodies']['store']['shape']['mesh'] = 'missing mesh.stl'
    scenario.write_text(yaml.safe_dump(document))
    with pytest.raises(Exception) as err:
        load_scenario(str(scenario))
    message = str(err.value)
    assert 'bodies.store.shape.mesh' in message and 'missing mesh.stl' in message
    assert 'not a file' in message and 'existing mesh file' in message
    # a URL is taken as it is (package:// is resolved by the viewer)
    document['bodies']['store']['shape']['mesh'] = 'package://my_pkg/meshes/store.stl'
    scenario.write_text(yaml.safe_dump(document))
    assert load_scenario(str(scenario)).bodies[0].shape.mesh.startswith('package://my_pkg')


def test_a_joint_cannot_take_a_frame_name():
    document = {'bodies': {'b': {'mass': 1.0, 'inertia': [1, 1, 1]}, 'c': {'fixed': True}},
                'joints': {'c': {'type': 'ball', 'parent': 'c', 'child': 'b',
                                 'anchor': [0, 0, 0]}}}
    with pytest.raises(Exception) as err:
        parse_scenario(document)
    assert 'joints.c' in str(err.value) and 'tf frame' in str(err.value)


def _compose(statics, moving, frame):
    """Return (translation, rotation) of frame in the root of the tf tree, and the root."""
    translation, rotation = np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0])
    while frame in statics or frame in moving:
        parent, t, q = statics[frame] if frame in statics else moving[frame]
        matrix = rotations.matrices(np.array([q]))[0]
        translation = np.asarray(t) + matrix @ translation
        rotation = rotations.multiply(np.array(q), rotation)
        frame = parent
    return translation, rotation, frame


def _transforms(message):
    return {t.child_frame_id: (t.header.frame_id,
                               [t.transform.translation.x, t.transform.translation.y,
                                t.transform.translation.z],
                               [t.transform.rotation.x, t.transform.rotation.y,
                                t.transform.rotation.z, t.transform.rotation.w])
            for t in message.transforms}


def test_viewers_see_the_store_fall_below_the_pylon(store):
    """Composed as a viewer composes /tf: z up, the store under the pylon and falling."""
    (static,) = [m for topic, _, m in store if topic == '/tf_static']
    statics = _transforms(static)
    heights = []
    for _, message in [(t, m) for topic, t, m in store if topic == '/tf']:
        position, _, root = _compose(statics, _transforms(message), 'store')
        assert root == 'map'
        heights.append(position[2])
    heights = np.array(heights)
    assert np.all(np.diff(heights) < 0)            # falling all the way, as gravity pulls
    assert heights[0] - heights[-1] > 5.0          # 7.77 m down in 1.5 s (z down in world)
    # the pylon's shape (its marker, on its frame) is above the store
    (array, *_) = [m for topic, _, m in store if topic == '/cfem/markers']
    (shape,) = [m.pose.position for m in array.markers if m.text == 'pylon']
    pylon, pylon_turn, _ = _compose(statics, {}, 'pylon')
    centre = pylon + rotations.matrices(np.array([pylon_turn]))[0] @ [shape.x, shape.y, shape.z]
    assert centre[2] - heights[0] == pytest.approx(0.45)
    # the root's -z is the scenario's gravity (0, 0, +g in z-down axes)
    _, up, _ = _compose(statics, {}, 'world')
    np.testing.assert_allclose(rotations.matrices(np.array([up]))[0] @ [0, 0, 9.80665],
                               [0, 0, -9.80665], atol=1e-12)
    # the joint's frame is at the anchor on the store, in the store's axes
    (first,) = [m for topic, t, m in store if topic == '/tf' and t == 0]
    moving = _transforms(first)
    pivot, turn, _ = _compose(statics, moving, 'pivot')
    store_at, store_turn, _ = _compose(statics, moving, 'store')
    anchor, _, _ = _compose(statics, {}, 'world')
    world_turn = rotations.matrices(np.array([up]))[0]
    np.testing.assert_allclose(pivot, world_turn @ [-0.3292, 0, -0.25], atol=1e-12)
    np.testing.assert_allclose(turn, store_turn, atol=1e-15)


def test_loads_are_stamped_where_they_act(store):
    """joints/pivot/wrench in the pivot's frame (store axes); wrench_world in world axes."""
    poses = {t: m.pose.orientation for topic, t, m in store if topic == '/cfem/bodies/store/pose'}
    world = {t: m for topic, t, m in store if topic == '/cfem/joints/pivot/wrench_world'}
    local = [(t, m) for topic, t, m in store if topic == '/cfem/joints/pivot/wrench']
    assert len(local) == len(world) > 10
    for t, message in local:
        assert message.header.frame_id == 'pivot' and world[t].header.frame_id == 'world'
        if t == local[-1][0]:
            continue   # the zero at the release (test_a_released_joint_s_load_ends_at_zero)
        q = poses[t]
        turn = rotations.matrices(np.array([[q.x, q.y, q.z, q.w]]))[0]
        for kind in ('force', 'torque'):
            v, w = getattr(message.wrench, kind), getattr(world[t].wrench, kind)
            np.testing.assert_allclose(turn @ [v.x, v.y, v.z], [w.x, w.y, w.z], rtol=0,
                                       atol=1e-9 * max(1.0, abs(w.x), abs(w.z)))


def test_a_released_joint_s_load_ends_at_zero(store, store_file):
    """Once, at the release, so that a viewer's plot ends at zero; the reader keeps the rest."""
    release = next(yaml.safe_load(m.data)['time'] for topic, _, m in store
                   if topic == '/cfem/events')
    for topic in ('/cfem/joints/pivot/wrench', '/cfem/joints/pivot/wrench_world'):
        loads = [(t, m.wrench) for name, t, m in store if name == topic]
        (t, last), (before, held) = loads[-1], loads[-2]
        assert t == round(release * 1e9) and before < t
        assert [last.force.x, last.force.y, last.force.z, last.torque.x, last.torque.y,
                last.torque.z] == [0.0] * 6
        assert abs(held.force.z) > 1000.0   # it held the store until then
    run = analysis.open_run(str(store_file))
    pivot = run.joints['pivot']
    assert pivot.time[-1] < release and len(pivot.time) == len(loads) - 1
    assert np.all(np.linalg.norm(pivot.force, axis=1) > 1000.0)


def _corners(body):
    """Return the 8 corners of each part of a body's shape's bounding boxes at t = 0, world, m."""
    return np.concatenate([_piece_corners(body, piece)
                           for piece in visuals.body_shape(body).pieces()])


def _piece_corners(body, shape):
    if shape.kind == 'box':
        half = np.array(shape.size) / 2
    elif shape.kind == 'cylinder':
        half = np.array([shape.size[1] / 2, shape.size[0], shape.size[0]])
    else:
        half = np.full(3, shape.size[0])
    local = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    turn = rotations.matrices(np.array([shape.orientation_xyzw]))[0]
    body_turn = rotations.matrices(np.array([body.orientation_xyzw]))[0]
    return body.position + (body_turn @ (np.asarray(shape.offset) + local @ turn.T).T).T


def _inside(points, body):
    """Tell whether the points all lie in the bounding box of one part of body's shape."""
    return any(_inside_box(points, _piece_corners(body, piece))
               for piece in visuals.body_shape(body).pieces())


def _inside_box(points, shape_box):
    centre = shape_box.mean(axis=0)
    axes = [shape_box[4] - shape_box[0], shape_box[2] - shape_box[0], shape_box[1] - shape_box[0]]
    for axis in axes:
        length = np.linalg.norm(axis)
        along = (points - centre) @ (axis / length)
        if np.any(np.abs(along) > length / 2 + 1e-9):
            return False
    return True


@pytest.mark.parametrize('name', sorted(p.name for p in CONFIG.glob('*.yaml')
                                        if 'ros__parameters' not in p.read_text()))
def test_no_body_is_hidden_inside_another_in_the_examples(name):
    model = load_scenario(str(CONFIG / name))
    for a in model.bodies:
        for b in model.bodies:
            if a is not b:
                assert not _inside(_corners(a), b), f'{name}: {a.name} hidden in {b.name}'
    if name.startswith('store_'):   # the carrier is drawn as given, not as a stand-in cube
        assert all(b.shape is not None for b in model.bodies), name


def test_joint_load_arrows_at_the_joint_every_sample(store):
    """What Foxglove's 3D panel draws of the loads (it draws no WrenchStamped): arrows."""
    local = {t: m.wrench.force for topic, t, m in store if topic == '/cfem/joints/pivot/wrench'}
    arrays = [(t, m) for topic, t, m in store if topic == '/cfem/load_markers']
    release = next(yaml.safe_load(m.data)['time'] for topic, _, m in store
                   if topic == '/cfem/events')
    samples = sorted({t for topic, t, _ in store if topic == '/cfem/bodies/store/pose'})
    # every sample, and the release (stamped at it, showing the joint gone)
    assert sorted(t for t, _ in arrays) == sorted(samples + [round(release * 1e9)])
    size = 2.5   # the store's length: the largest force is drawn about as long
    for t, array in arrays:
        first, *arrows = array.markers
        assert first.action == 3    # DELETEALL: a released joint's arrow goes
        if t / 1e9 > release or t not in local:
            assert arrows == []
            continue
        (arrow,) = arrows
        assert arrow.header.frame_id == 'pivot' and arrow.type == 0 and arrow.frame_locked
        start, end = arrow.points
        assert (start.x, start.y, start.z) == (0, 0, 0)
        f = np.array([local[t].x, local[t].y, local[t].z])
        per_metre = float(arrow.text.rsplit('= ', 1)[1].split()[0])   # the text states it
        assert arrow.text.startswith(f'pivot joint: {np.linalg.norm(f):.3e} N, 1 m = ')
        assert per_metre in [m * 10.0 ** e for m in (1, 2, 5) for e in range(-3, 9)]
        np.testing.assert_allclose([end.x, end.y, end.z], f / per_metre, rtol=1e-12, atol=1e-12)
        assert 0.3 * size <= np.linalg.norm(f) / per_metre <= size


def test_open_run_reads_world_axes_loads_old_and_new(tmp_path, store, store_file):
    from cfem_ros.recording.container import Recorder
    from cfem_ros.recording.schema import POSE_TYPE, WRENCH_TYPE

    def header(frame):
        return {'stamp': {'sec': 0, 'nanosec': 0}, 'frame_id': frame}
    pose = {'header': header('world'), 'pose': {'orientation': {'w': 1.0}}}
    old = tmp_path / 'old.mcap'   # before the _world topics: world axes on wrench
    with Recorder(str(old)) as recorder:
        recorder.write('/cfem/bodies/store/pose', POSE_TYPE, pose, 0)
        recorder.write('/cfem/joints/pivot/wrench', WRENCH_TYPE, {
            'header': header('world'), 'wrench': {'force': {'z': -5.0}}}, 0)
        recorder.write('/cfem/joints/other/wrench', WRENCH_TYPE, {   # in its own axes only
            'header': header('other'), 'wrench': {'force': {'z': -7.0}}}, 0)
    run = analysis.open_run(str(old))
    assert list(run.joints) == ['pivot'] and run.joints['pivot'].force[0, 2] == -5.0
    # a new recording: the world-axes numbers of wrench_world, whatever wrench holds
    new = analysis.open_run(str(store_file))
    world = [m.wrench.force for topic, _, m in store if topic == '/cfem/joints/pivot/wrench_world']
    # all but the zero at the release (test_a_released_joint_s_load_ends_at_zero)
    np.testing.assert_array_equal(new.joints['pivot'].force[:, 2], [f.z for f in world[:-1]])
