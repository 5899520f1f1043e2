# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""End-of-stroke figures: velocity and rates relative to the rack (SPEC section 7)."""

import math

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.engine.strokes import relative_motion
from cfem_ros.core.scenario.parse import parse_scenario
import numpy as np
import pytest
from reference import normalized_error
from test_loads import INERTIA, MASS, reference

G = 9.80665


def strokes_of(sim):
    return {e['wrench']: e for e in sim.events if e['event'] == 'stroke_end'}


@pytest.mark.parametrize('carrier_velocity', [0.0, 250.0])
def test_a_slug_ejected_at_its_cg_leaves_at_the_closed_form_velocity(carrier_velocity):
    # constant force F at the CG over the stroke d, gravity along it, from rest relative
    # to the rack: a = F / m + g, t = sqrt(2 d / a), v = a t, no rotation
    force, stroke = 42703.0, 0.1006
    rack = ({'fixed': True} if carrier_velocity == 0.0 else
            {'motion': {'velocity': [carrier_velocity, 0, 0]}})
    doc = {'gravity': [0, 0, G], 'dt': 0.001,
           'bodies': {'rack': rack,
                      'slug': {'mass': MASS, 'inertia': INERTIA,
                               'velocity': [carrier_velocity, 0, 0]}},
           'wrenches': [{'name': 'ejector', 'body': 'slug', 'force': [0, 0, force],
                         'frame': 'rack', 'stroke': stroke, 'reacts_on': 'rack'}]}
    sim = Simulator(parse_scenario(doc, source='slug.yaml'))
    assert sim.advance_to(0.1), sim.message
    event = strokes_of(sim)['ejector']
    acceleration = force / MASS + G
    t_end = math.sqrt(2.0 * stroke / acceleration)
    assert abs(event['time'] - t_end) < 1e-12
    assert normalized_error(event['velocity'], [0, 0, acceleration * t_end],
                            acceleration * t_end) < 1e-12
    assert normalized_error(event['rates'], [0, 0, 0], 1.0) < 1e-15
    assert event['reacts_on'] == 'rack' and event['body'] == 'slug'


def test_off_the_cg_the_figures_match_dop853_in_the_body_axes():
    # the aft ejector alone, off the CG: the store pitches while it is pushed
    force, point, stroke = np.array([0.0, 0.0, 42703.0]), np.array([-0.3292, 0.05, -0.25]), 0.1006
    doc = {'gravity': [0, 0, 0], 'dt': 0.001,
           'bodies': {'pylon': {'fixed': True},
                      'store': {'mass': MASS, 'inertia': INERTIA}},
           'wrenches': [{'name': 'aft_ejector', 'body': 'store', 'point': point.tolist(),
                         'force': force.tolist(), 'frame': 'pylon', 'stroke': stroke,
                         'reacts_on': 'pylon'}]}
    sim = Simulator(parse_scenario(doc, source='store.yaml'))
    assert sim.advance_to(0.2), sim.message
    event = strokes_of(sim)['aft_ejector']
    _, v, rot, w_body, t_end = reference(force, point, 1.0, stroke=stroke, rates0=(0, 0, 0))
    assert abs(event['time'] - t_end) < 1e-9
    v_body = rot.T @ v
    assert abs(w_body[1]) > 1.0   # pitching, rad/s
    assert normalized_error(event['velocity'], v_body, np.linalg.norm(v_body)) < 1e-8
    assert normalized_error(event['rates'], w_body, np.linalg.norm(w_body)) < 1e-8


def test_relative_motion_removes_the_racks_velocity_and_rotation():
    # a body at rest in world seen from a rack spinning about z through its CG at 1 m
    y = np.zeros(26)
    y[0:3] = [0.0, 0.0, 0.0]          # rack CG
    y[3:6] = [1.0, 0.0, 0.0]          # body CG
    y[12:16] = [0, 0, 0, 1]
    y[16:20] = [0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4)]   # body yawed 90 deg
    y[20:23] = [0, 0, 2.0]            # the rack turns at 2 rad/s about z
    velocity, rates = relative_motion(y, 2, 1, 0)
    # seen from the rack the body moves at -w x r = -(0, 2, 0); in its axes (yawed 90 deg)
    np.testing.assert_allclose(velocity, [-2.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(rates, [0.0, 0.0, -2.0], atol=1e-15)
    world_velocity, world_rates = relative_motion(y, 2, 1, -1)
    np.testing.assert_allclose(world_velocity, 0.0, atol=1e-15)
    np.testing.assert_allclose(world_rates, 0.0, atol=1e-15)
