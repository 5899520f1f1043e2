# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Markers of collision shapes as used (capsules, mesh hulls) and of contact points."""

from cfem_ros.core.model.shapes import Shape, triangles
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.recording import visuals
import numpy as np

STAMP = {'sec': 0, 'nanosec': 0}


def test_a_capsule_is_drawn_as_its_surface():
    tri = triangles(Shape('capsule', (0.25, 2.0)))
    points = tri.reshape(-1, 3)
    # every vertex lies on the capsule: 0.25 m from its segment (x from -0.75 to 0.75)
    axis = np.clip(points[:, 0], -0.75, 0.75)
    gap = np.linalg.norm(points - np.column_stack([axis, 0 * axis, 0 * axis]), axis=1)
    np.testing.assert_allclose(gap, 0.25, atol=1e-12)
    assert points[:, 0].min() == -1.0 and points[:, 0].max() == 1.0   # tip to tip


def test_markers_show_hulls_capsules_and_contacts():
    cube = [[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    model = parse_scenario({
        'bodies': {'floor': {'fixed': True, 'shape': {'box': [4, 4, 0.2]}},
                   'store': {'mass': 1.0, 'inertia': [1, 1, 1],
                             'shape': {'capsule': [0.2, 1.0]}},
                   'rock': {'mass': 1.0, 'inertia': [1, 1, 1], 'position': [3, 0, 0],
                            'shape': {'sphere': 0.3}}}})
    rock = model.bodies[2]
    hull = Shape('mesh', (1.0, 1.0, 1.0), mesh='file:///rock.stl',
                 hull=tuple(map(tuple, np.array(cube) * 0.3)))
    model = type(model)(**{**model.__dict__, 'bodies': model.bodies[:2] + (
        type(rock)(**{**rock.__dict__, 'shape': hull}),)})
    contact = {'event': 'contact', 'bodies': ['store', 'floor'], 'time': 0.25,
               'point': [0.1, 0.2, 0.1]}
    out = visuals.markers(model, STAMP, '/cfem', contacts=[contact])['markers']
    store, = [m for m in out if m['ns'] == '/cfem/bodies' and m['text'] == 'store']
    assert store['type'] == visuals.TRIANGLE_LIST and len(store['points']) % 3 == 0
    collision, = [m for m in out if m['ns'] == '/cfem/collision']
    assert collision['header']['frame_id'] == 'rock' and len(collision['points']) == 36
    marker, = [m for m in out if m['ns'] == '/cfem/contacts']
    assert marker['type'] == visuals.SPHERE and marker['header']['frame_id'] == 'world'
    assert marker['pose']['position'] == {'x': 0.1, 'y': 0.2, 'z': 0.1}
