# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""``cg_offset`` (SPEC section 10): the CG moves, what is given from it stays on the geometry."""

from cfem_ros import Simulator
from cfem_ros.core.scenario.parse import parse_scenario
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

RPY = [10.0, -20.0, 30.0]
OFFSET = np.array([0.3, -0.1, 0.05])


def scenario(offset):
    return {'gravity': [0, 0, 9.80665],
            'bodies': {'pylon': {'fixed': True},
                       'store': {'mass': 230, 'inertia': [4.1, 95, 95],
                                 'position': [1.0, 2.0, 3.0], 'orientation_rpy_deg': RPY,
                                 'cg_offset': list(offset),
                                 'shape': {'parts': [{'box': [1, 0.2, 0.2], 'at': [0.5, 0, 0]},
                                                     {'sphere': 0.1, 'at': [-0.4, 0, 0]}]}}},
            'joints': {'hook': {'type': 'hinge', 'parent': 'pylon', 'child': 'store',
                                'anchor': [1.2, 2.0, 2.8], 'axis': [0, 1, 0]}},
            'wrenches': [{'name': 'push', 'body': 'store', 'point': [0.2, 0.0, -0.1],
                          'force': [0, 0, 100.0]}],
            'sway_braces': [{'body': 'store', 'carrier': 'pylon', 'point': [0.5, 0.0, -0.1],
                             'direction': [0, 0, 1], 'preload': 10.0, 'stiffness': 1e3}],
            'aero': {'store': {'area': 0.03, 'length': 0.2, 'density': 1.2,
                               'alpha_deg': [-180, 180], 'reference_point': [0.05, 0, 0],
                               'zero': ['CX', 'CY', 'CZ', 'Cl', 'Cm', 'Cn']}}}


def world_points(model):
    """Return the store's CG, its shape parts, wrench, brace and aero points in world axes."""
    store = model.bodies[1]
    turn = Rotation.from_quat(store.orientation_xyzw)
    local = [p.offset for p in store.shape.parts] + [model.wrenches[0].point]
    local += [b.point for b in model.braces]
    local += [model.aero[0].reference_from_cg]
    return store.position, store.position + turn.apply(np.array(local, dtype=float))


def test_the_cg_moves_and_the_geometry_stays():
    nominal, moved = parse_scenario(scenario([0, 0, 0])), parse_scenario(scenario(OFFSET))
    cg0, points0 = world_points(nominal)
    cg1, points1 = world_points(moved)
    turn = Rotation.from_euler('ZYX', RPY[::-1], degrees=True)
    np.testing.assert_allclose(cg1 - cg0, turn.apply(OFFSET), rtol=0, atol=1e-14)
    np.testing.assert_allclose(points1, points0, rtol=0, atol=1e-14)
    # mass properties are the actual CG's, as given
    np.testing.assert_array_equal(moved.bodies[1].inertia, nominal.bodies[1].inertia)
    # the hook's anchor is a world point: the joint holds at t = 0 in both
    for model in (nominal, moved):
        sim = Simulator(model)
        assert sim.constraint_violation() < 1e-12
    assert moved.aero[0].reference_point == pytest.approx([0.05, 0, 0])
