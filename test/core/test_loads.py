# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Applied loads: loads at points, scheduled wrenches, ejector strokes (loads.py)."""

import math
import os
import pathlib

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.native.atmosphere import isa_density
from cfem_ros.core.run import batch
from cfem_ros.core.run.inputs import wrench_input
from cfem_ros.core.run.session import Session
from cfem_ros.core.scenario.parse import load_scenario, parse_scenario
from crossings import assert_same_location, assert_same_runs, rk4, step_with_condition
import numpy as np
import pytest
from reference import quat_matrix, skew
from scipy.integrate import solve_ivp
from scipy.interpolate import RegularGridInterpolator
from scipy.optimize import brentq
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
MASS = 907.1848
INERTIA = [27.1164, 488.0944, 488.0944]   # the Eglin store's, as in config/
STORE = {'mass': MASS, 'inertia': INERTIA, 'angular_velocity': [0.3, -0.2, 0.5]}


def model(wrenches=None, *, gravity=(0, 0, 0), dt=0.001, bodies=None, **extra):
    """Build a model of one free body (or the given bodies) with scheduled wrenches."""
    doc = {'gravity': list(gravity), 'dt': dt,
           'bodies': bodies or {'store': dict(STORE)}, **extra}
    if wrenches is not None:
        doc['wrenches'] = wrenches
    return parse_scenario(doc, source='test.yaml')


def run(sim, t):
    """Advance sim to t and return it."""
    assert sim.advance_to(t), sim.message
    return sim


def momentum(sim, origin=np.zeros(3)):
    """Total linear momentum and angular momentum about origin (world)."""
    pos, vel, quat, rates = sim.position, sim.velocity, sim.orientation, sim.rates
    linear = np.zeros(3)
    angular = np.zeros(3)
    for i in np.flatnonzero(sim.free):
        rot = quat_matrix(quat[i])
        linear += sim.mass[i] * vel[i]
        angular += (np.cross(pos[i] - origin, sim.mass[i] * vel[i])
                    + rot @ (sim.inertia_body[i] @ rates[i]))
    return linear, angular


def reference(force_world, point_body, t_end, *, stroke=None, rates0=(0.3, -0.2, 0.5),
              after=None, gravity=np.zeros(3)):
    """
    DOP853 on Newton-Euler for one free body from rest at the origin, identity attitude.

    Each world force (a list, or one) acts at its body point until t_end or
    until the point has moved its ``stroke`` (a list, or one; None: no
    stroke) from where it started; then the body flies on until ``after``
    (if given). Returns (x, v, R, w_body, end of the last stroke).
    """
    inertia = np.diag(INERTIA)
    inverse = np.linalg.inv(inertia)
    forces = np.reshape(np.asarray(force_world, dtype=float), (-1, 3))
    points = np.reshape(np.asarray(point_body, dtype=float), (-1, 3))
    strokes = stroke if isinstance(stroke, (list, tuple)) else [stroke] * len(forces)

    def rhs(_, s, on):
        rot = s[6:15].reshape(3, 3)
        w = s[15:18]
        acc, moment = gravity.astype(float), np.zeros(3)
        for k in np.flatnonzero(on):
            acc = acc + forces[k] / MASS
            moment = moment + np.cross(rot @ points[k], forces[k])
        w_dot = inverse @ (rot.T @ moment - np.cross(w, inertia @ w))
        return np.concatenate([s[3:6], acc, (rot @ skew(w)).ravel(), w_dot])

    def travelled(k):
        def event(_, s, on):
            return np.linalg.norm(s[0:3] + s[6:15].reshape(3, 3) @ points[k] - points[k]) \
                - strokes[k]
        event.terminal = True
        return event

    s = np.concatenate([np.zeros(6), np.eye(3).ravel(), rates0])
    on = np.ones(len(forces), dtype=bool)
    t, t_stroke = 0.0, 0.0
    while t < t_end and on.any():
        watched = [k for k in np.flatnonzero(on) if strokes[k] is not None]
        part = solve_ivp(rhs, (t, t_end), s, method='DOP853', rtol=1e-13, atol=1e-14,
                         args=(on.copy(),), events=[travelled(k) for k in watched] or None)
        t, s = part.t[-1], part.y[:, -1]
        ended = [k for k, times in zip(watched, part.t_events or []) if len(times)]
        if not ended:
            break
        on[ended] = False
        t_stroke = t
    if after is not None:
        s = solve_ivp(rhs, (t, after), s, method='DOP853', rtol=1e-13, atol=1e-14,
                      args=(on & False,)).y[:, -1]
    return s[0:3], s[3:6], s[6:15].reshape(3, 3), s[15:18], t_stroke


# ------------------------------------------------------------ loads at points

def test_point_load_in_body_axes_equals_the_load_moved_to_the_cg():
    force, point = np.array([120.0, -40.0, 300.0]), np.array([0.5, 0.1, -0.2])
    at_point = Simulator(model(gravity=(0, 0, -9.80665)))
    at_point.set_wrench('store', force, [1.0, 2.0, 3.0], body_axes=True, point=point)
    at_cg = Simulator(model(gravity=(0, 0, -9.80665)))
    at_cg.set_wrench('store', force, np.array([1.0, 2.0, 3.0]) + np.cross(point, force),
                     body_axes=True)
    np.testing.assert_allclose(run(at_point, 1.0).y, run(at_cg, 1.0).y, rtol=0, atol=1e-12)
    assert np.abs(at_point.rates).max() > 0.6   # the point's moment turned it


def test_point_load_in_world_axes_turns_with_the_body_against_dop853():
    force, point = np.array([0.0, 0.0, 5000.0]), np.array([0.3, 0.05, 0.0])
    sim = Simulator(model())
    sim.set_wrench('store', force, [0, 0, 0], point=point)
    run(sim, 1.0)
    x, v, rot, w, _ = reference(force, point, 1.0)
    np.testing.assert_allclose(sim.position[0], x, rtol=0, atol=1e-10)
    np.testing.assert_allclose(sim.velocity[0], v, rtol=0, atol=1e-10)
    np.testing.assert_allclose(quat_matrix(sim.orientation[0]), rot, rtol=0, atol=1e-10)
    np.testing.assert_allclose(sim.rates[0], w, rtol=0, atol=1e-10)
    # the moment is not the one at t = 0 held: the world-fixed equivalent differs
    held = Simulator(model())
    held.set_wrench('store', force, np.cross(point, force))
    assert np.abs(run(held, 1.0).rates[0] - w).max() > 1e-3


def test_point_from_a_topic_frame_id_through_a_session():
    force, torque, point = [10.0, 0.0, 250.0], [0.0, 1.0, 0.0], [0.4, -0.1, 0.05]
    by_topic = Simulator(model())
    session = Session(by_topic, rate_hz=50.0, duration=1.0)
    session.submit(wrench_input('store', force, torque, 'store@0.4,-0.1,0.05', time=0.25))
    session.run()
    direct = Simulator(model())
    run(direct, 0.25)
    direct.set_wrench('store', force, np.array(torque) + np.cross(point, force),
                      body_axes=True)
    run(direct, 1.0)
    assert by_topic.t == direct.t == 1.0
    np.testing.assert_allclose(by_topic.y, direct.y, rtol=0, atol=1e-12)


@pytest.mark.parametrize('frame_id', ['store@1,2', 'store@a,b,c', 'store@1,2,nan', 'pylon@0,0,0'])
def test_bad_point_in_a_frame_id_is_refused_with_the_reason(frame_id):
    session = Session(Simulator(model()), rate_hz=50.0, duration=1.0)
    session.start()
    with pytest.raises(ValueError, match='frame_id'):
        session.submit(wrench_input('store', [0, 0, 1], [0, 0, 0], frame_id))


# ------------------------------------------------------------ scheduled wrenches

EJECTOR = {'body': 'store', 'point': [0.0, 0.0, 0.2], 'force': [0, 0, 10676.0],
           'stroke': 0.1006}


def test_constant_ejector_through_the_cg_ends_its_stroke_at_the_closed_form_time():
    sim = Simulator(model([EJECTOR], bodies={'store': {'mass': MASS, 'inertia': INERTIA}},
                          dt=0.01))
    run(sim, 1.0)
    t_end = math.sqrt(2 * MASS * 0.1006 / 10676.0)   # s = F t^2 / (2 m)
    v_end = 10676.0 / MASS * t_end
    # after the stroke the body flies at the impulse's velocity: z = s + v (t - t_end)
    np.testing.assert_allclose(sim.velocity[0], [0, 0, v_end], rtol=0, atol=1e-12)
    np.testing.assert_allclose(sim.position[0], [0, 0, 0.1006 + v_end * (1.0 - t_end)],
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(sim.rates[0], 0.0, atol=0)


def test_ejector_with_a_lever_arm_against_dop853_impulse_and_momentum():
    spec = {'body': 'store', 'point': [0.3292, 0.02, 0.2], 'force': [0, 0, 42703.0],
            'frame': 'world', 'stroke': 0.1006}
    sim = Simulator(model([spec], dt=0.0005))
    run(sim, 0.5)
    force = np.array([0, 0, 42703.0])
    x, v, rot, w, t_end = reference(force, spec['point'], 1.0, stroke=0.1006, after=0.5)
    assert 0.03 < t_end < 0.1
    # RK4's error at dt = 0.5 ms and rates of ~3 rad/s: ~1e-11
    np.testing.assert_allclose(sim.position[0], x, rtol=0, atol=1e-10)
    np.testing.assert_allclose(sim.velocity[0], v, rtol=0, atol=1e-10)
    np.testing.assert_allclose(quat_matrix(sim.orientation[0]), rot, rtol=0, atol=1e-10)
    np.testing.assert_allclose(sim.rates[0], w, rtol=0, atol=1e-10)
    # linear impulse F t_end exactly (world force)
    linear, _ = momentum(sim)
    np.testing.assert_allclose(linear, force * t_end, rtol=1e-12, atol=1e-8)


def test_stroke_end_is_located_inside_the_step():
    spec = {'body': 'store', 'point': [0.3292, 0.0, 0.2], 'force': [0, 0, 42703.0],
            'stroke': 0.1006}
    results = []
    for dt in (0.002, 0.0013, 0.0005):
        sim = Simulator(model([spec], dt=dt, bodies={'store': {'mass': MASS,
                                                               'inertia': INERTIA}}))
        run(sim, 0.3)
        results.append(sim.y.copy())
    # a step cut at the end of the stroke: RK4's error only (~2e-10 at 2 ms), not a
    # fraction of a step's worth of load (47 m/s^2 dt, ~1e-2 m/s)
    np.testing.assert_allclose(results[0], results[2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(results[1], results[2], rtol=0, atol=1e-9)


def test_stroke_end_is_located_in_compiled_code_as_in_python():
    spec = {'body': 'store', 'point': [0.3292, 0.02, 0.2], 'force': [0, 0, 42703.0],
            'frame': 'world', 'stroke': 0.1006}
    sim = Simulator(model([spec]))
    h = step_with_condition(sim, 0.5)
    crossing, (s, wrenches) = assert_same_location(sim, h)
    assert (crossing, wrenches) == (None, [0])
    assert 0.0 < s < h
    # scipy's brentq on the point's travel from where it started (at rest, identity
    # attitude: the point itself), on the step's RK4 map

    def excess(u):
        y = rk4(sim, sim.y, u)
        return np.linalg.norm(y[:3] + quat_matrix(y[6:10]) @ spec['point']
                              - spec['point']) - spec['stroke']
    # the travel's rounding, ~1e-17 m, at ~1 m/s, plus the 1e-15 s tolerance
    assert abs(brentq(excess, 0.0, h, xtol=1e-15) - s) < 1e-13
    assert_same_runs(sim.model, [0.05, 0.5])


def test_two_strokes_ending_at_the_same_time_end_in_one_step():
    half = dict(EJECTOR, force=[0, 0, 5338.0])
    sim = Simulator(model([dict(half, name='a'), dict(half, name='b')], dt=0.01))
    h = step_with_condition(sim, 1.0)
    crossing, (s, wrenches) = assert_same_location(sim, h)
    assert (crossing, wrenches) == (None, [0, 1])
    assert 0.0 < s < h
    sim = assert_same_runs(sim.model, [0.2, 1.0])
    assert sim._scheduled.done.all()


def test_reaction_on_a_free_parent_conserves_momentum():
    bodies = {'aircraft': {'mass': 9000.0, 'inertia': [20000.0, 60000.0, 75000.0, 0, -800, 0],
                           'angular_velocity': [0.05, 0.0, -0.02]},
              'store': {'mass': MASS, 'inertia': INERTIA, 'position': [0.5, 0.2, -1.0],
                        'angular_velocity': [0.1, 0.2, 0.0]}}
    wrenches = [{'name': 'fwd', 'body': 'store', 'point': [1.2, 0, 0.2],
                 'force': [0, 0, -10676.0], 'stroke': 0.1006, 'reacts_on': 'aircraft'},
                {'name': 'aft', 'body': 'store', 'point': [-0.3, 0, 0.2], 'moment': [50, 0, 0],
                 'force': [0, 0, -42703.0], 'stroke': 0.1006, 'reacts_on': 'aircraft',
                 'frame': 'aircraft'}]
    sim = Simulator(model(wrenches, bodies=bodies))
    origin = np.array([3.0, -1.0, 2.0])
    p0, l0 = momentum(sim, origin=origin)
    for t in (0.02, 0.05, 0.3):
        p1, l1 = momentum(run(sim, t), origin=origin)
        # rounding: 1e-12 of the momenta that cancel (each body's, ~1e4)
        scale = max(np.abs(sim.mass[:, None] * sim.velocity).max(), np.abs(l0).max())
        np.testing.assert_allclose(p1, p0, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(l1, l0, rtol=0, atol=1e-11 * scale * 4)
    assert np.linalg.norm(sim.velocity[1]) > 1.0   # the store was pushed away


def test_reaction_on_a_fixed_body_is_ignored():
    bodies = {'pylon': {'fixed': True}, 'store': {'mass': MASS, 'inertia': INERTIA}}
    with_pylon = Simulator(model([dict(EJECTOR, reacts_on='pylon')], bodies=bodies))
    alone = Simulator(model([EJECTOR], bodies={'store': {'mass': MASS, 'inertia': INERTIA}}))
    run(with_pylon, 0.5)
    run(alone, 0.5)
    for name in ('position', 'velocity', 'orientation', 'rates'):
        np.testing.assert_array_equal(getattr(with_pylon, name)[1], getattr(alone, name)[0])
    assert alone.velocity[0, 2] > 1.0


def test_force_against_stroke_table_against_the_closed_form():
    # F(d) = F0 - k d through the CG: m d'' = F0 - k d, d = F0/k (1 - cos wt)
    f0, k, stroke = 20000.0, 150000.0, 0.1
    table = {'against': 'stroke', 'table': [[0.0, 0, 0, f0], [0.2, 0, 0, f0 - 0.2 * k]]}
    sim = Simulator(model([{'body': 'store', 'force': table, 'stroke': stroke}],
                          bodies={'store': {'mass': MASS, 'inertia': INERTIA}}))
    omega = math.sqrt(k / MASS)
    t_end = math.acos(1 - stroke * k / f0) / omega
    run(sim, 0.5 * t_end)
    # RK4's error over 50 steps at omega dt = 0.013: ~1e-11
    assert abs(sim.position[0, 2] - f0 / k * (1 - math.cos(omega * 0.5 * t_end))) < 1e-10
    run(sim, 1.0)
    v_end = f0 / k * omega * math.sin(omega * t_end)
    assert abs(sim.velocity[0, 2] - v_end) < 1e-10
    assert abs(sim.position[0, 2] - (stroke + v_end * (1.0 - t_end))) < 1e-10


def test_time_window_and_time_table_cut_the_steps():
    # F(t) = 1000 (t - start) for start <= t < end, through the CG, in world axes
    start, end = 0.1234, 0.3456
    table = {'against': 'time', 'table': [[0.0, 0, 0, 0.0], [1.0, 0, 0, 1000.0]]}
    sim = Simulator(model([{'body': 'store', 'force': table, 'frame': 'world',
                            'start': start, 'end': end}],
                          bodies={'store': {'mass': MASS, 'inertia': INERTIA}}, dt=0.01))
    run(sim, 1.0)
    span = end - start
    v_end = 1000.0 * span ** 2 / 2 / MASS
    z_end = 1000.0 * span ** 3 / 6 / MASS
    assert abs(sim.velocity[0, 2] - v_end) < 1e-13
    assert abs(sim.position[0, 2] - (z_end + v_end * (1.0 - end))) < 1e-13


@pytest.mark.parametrize('spec, key', [
    ({'body': 'nobody', 'force': [0, 0, 1]}, 'wrenches[0].body'),
    ({'body': 'store', 'force': [0, 0]}, 'wrenches[0].force'),
    ({'body': 'store', 'force': [0, 0, 1], 'frame': 'moon'}, 'wrenches[0].frame'),
    ({'body': 'store', 'force': [0, 0, 1], 'start': 1.0, 'end': 0.5}, 'wrenches[0].end'),
    ({'body': 'store', 'force': [0, 0, 1], 'stroke': 0}, 'wrenches[0].stroke'),
    ({'body': 'store', 'force': [0, 0, 1], 'reacts_on': 'store'}, 'wrenches[0].reacts_on'),
    ({'body': 'store', 'force': [0, 0, 1], 'colour': 'red'}, 'wrenches[0].colour'),
    ({'body': 'store'}, 'wrenches[0].force'),
    ({'body': 'store', 'force': {'against': 'speed', 'table': [[0, 0, 0, 1], [1, 0, 0, 1]]}},
     'wrenches[0].force.against'),
    ({'body': 'store', 'force': {'against': 'time', 'table': [[0, 0, 0, 1], [0, 0, 0, 1]]}},
     'wrenches[0].force.table[1][0]'),
    ({'body': 'ground', 'force': [0, 0, 1]}, 'wrenches[0].body'),
])
def test_bad_wrenches_are_refused_with_the_key_path(spec, key):
    bodies = {'ground': {'fixed': True}, 'store': {'mass': MASS, 'inertia': INERTIA}}
    with pytest.raises(ScenarioError) as err:
        model([spec], bodies=bodies)
    assert err.value.key == key
    assert err.value.expected


def test_shipped_ejector_scenario_against_dop853():
    path = os.path.join(os.path.dirname(__file__), '..', '..', 'config',
                        'store_separation_ejectors.yaml')
    sim = Simulator(load_scenario(path))
    run(sim, 0.4)
    gravity = np.array([0, 0, 9.80665])
    x, v, rot, w, t_end = reference(
        [[0, 0, 10676.0], [0, 0, 42703.0]], [[0.1798, 0, -0.25], [-0.3292, 0, -0.25]], 0.4,
        stroke=0.1006, rates0=(0, 0, 0), gravity=gravity, after=0.4)
    assert 0.03 < t_end < 0.1 and sim._scheduled.done.all()
    np.testing.assert_allclose(sim.position[1], x, rtol=0, atol=1e-10)
    np.testing.assert_allclose(sim.velocity[1], v, rtol=0, atol=1e-10)
    np.testing.assert_allclose(quat_matrix(sim.orientation[1]), rot, rtol=0, atol=1e-10)
    np.testing.assert_allclose(sim.rates[1], w, rtol=0, atol=1e-9)
    assert w[1] > 1.0   # the stronger aft ejector leaves it nose up


# ------------------------------------------------------------ aerodynamic tables

AIR = {'area': 0.1642, 'length': 0.4572, 'density': 1.225, 'freestream': [-250.0, 0, 0]}


def test_isa_density():
    # ISA tables (ICAO Doc 7488): kg/m^3 at 0, 5000, 11000 and 20000 m
    for altitude, density in ((0, 1.2250), (5000, 0.73612), (11000, 0.36392),
                              (20000, 0.088035)):
        assert abs(isa_density(altitude) / density - 1) < 2e-4


def test_aerodynamic_pitch_oscillation_against_the_linearized_closed_form():
    # the store pivots freely about its CG (a ball joint there) in a 250 m/s stream;
    # alpha = theta exactly, so I theta'' = q S L (Cm_a theta + Cmq theta' L / 2V)
    cm_alpha, cmq, theta0 = -2.0, -40.0, math.radians(5.0)
    edge = cm_alpha * math.radians(30)
    aero = dict(AIR, alpha_deg=[-30, 30], Cm=[-edge, edge], CX=-0.3, CZ=[1.5, -1.5], Cmq=cmq,
                zero=['CY', 'Cl', 'Cn'])
    sim = Simulator(model(bodies={'ground': {'fixed': True},
                                  'store': {'mass': MASS, 'inertia': INERTIA,
                                            'orientation_rpy_deg': [0, 5, 0]}},
                          joints={'cg': {'type': 'ball', 'parent': 'ground', 'child': 'store',
                                         'anchor': [0, 0, 0]}},
                          aero={'store': aero}))
    qsl = 0.5 * 1.225 * 250.0 ** 2 * 0.1642 * 0.4572
    omega0 = math.sqrt(-qsl * cm_alpha / INERTIA[1])
    zeta = -qsl * cmq * 0.4572 / (2 * 250.0) / INERTIA[1] / (2 * omega0)
    omega_d = omega0 * math.sqrt(1 - zeta ** 2)
    assert 0.02 < zeta < 0.05   # lightly damped: the test sees both
    for t in np.linspace(0.1, 3.0, 12):
        run(sim, t)
        theta = 2 * math.atan2(sim.orientation[1, 1], sim.orientation[1, 3])
        expected = theta0 * math.exp(-zeta * omega0 * t) * (
            math.cos(omega_d * t) + zeta * omega0 / omega_d * math.sin(omega_d * t))
        assert abs(theta - expected) < 1e-9, t
    # the drag and normal force go to the pivot
    force, _ = sim.joint_wrenches()
    assert force[0, 0] > 0.0


def aero_reference(table, state0, t_end, gravity):
    """DOP853 on Newton-Euler of one free body with the aero model written with scipy."""
    alpha, beta = np.radians(table['alpha_deg']), np.radians(table['beta_deg'])
    grids = {c: RegularGridInterpolator((alpha, beta), np.array(table[c], dtype=float))
             for c in ('CX', 'CY', 'CZ', 'Cl', 'Cm', 'Cn')}
    inertia = np.diag(INERTIA)
    inverse = np.linalg.inv(inertia)
    wind = np.array(AIR['freestream'])
    qs_factor = 0.5 * AIR['density'] * AIR['area']
    length = AIR['length']

    def rhs(_, s):
        rot = s[6:15].reshape(3, 3)
        w = s[15:18]
        u, v, ww = rot.T @ (s[3:6] - wind)
        speed = math.sqrt(u * u + v * v + ww * ww)
        at = [[np.clip(math.atan2(ww, u), alpha[0], alpha[-1]),
               np.clip(math.asin(v / speed), beta[0], beta[-1])]]
        c = {k: float(g(at)[0]) for k, g in grids.items()}
        qs = qs_factor * speed ** 2
        force = qs * np.array([c['CX'], c['CY'], c['CZ']])
        moment = qs * length * (np.array([c['Cl'], c['Cm'], c['Cn']]) + np.array(
            [table['Clp'], table['Cmq'], table['Cnr']]) * w * length / (2 * speed))
        w_dot = inverse @ (moment - np.cross(w, inertia @ w))
        return np.concatenate([s[3:6], gravity + rot @ force / MASS,
                               (rot @ skew(w)).ravel(), w_dot])

    return solve_ivp(rhs, (0, t_end), state0, method='DOP853', rtol=1e-13,
                     atol=1e-14).y[:, -1]


def test_aerodynamic_free_flight_against_dop853():
    # nonlinear in alpha and beta (bilinear between nodes), damping on all axes
    table = {'alpha_deg': [-30, -12, -4, 0, 5, 15, 30], 'beta_deg': [-20, -5, 0, 8, 20],
             'Clp': -3.0, 'Cmq': -40.0, 'Cnr': -35.0}
    rng = np.random.default_rng(7)
    for c, scale in (('CX', 0.05), ('CY', 0.3), ('CZ', 0.3), ('Cl', 0.02), ('Cm', 0.2),
                     ('Cn', 0.2)):
        table[c] = (scale * rng.standard_normal((7, 5))).tolist()
    table['CX'] = (np.array(table['CX']) - 0.3).tolist()
    alpha, beta = np.meshgrid(np.radians(table['alpha_deg']), np.radians(table['beta_deg']),
                              indexing='ij')
    table['Cm'] = (np.array(table['Cm']) - 1.5 * alpha).tolist()   # stable
    table['Cn'] = (np.array(table['Cn']) + 1.5 * beta).tolist()
    gravity = np.array([0, 0, 9.80665])
    rates = [0.5, 1.0, -0.8]
    sim = Simulator(model(gravity=gravity, dt=0.0005, aero={'store': dict(AIR, **table)},
                          bodies={'store': {'mass': MASS, 'inertia': INERTIA,
                                            'velocity': [10.0, 5.0, -3.0],
                                            'angular_velocity': rates}}))
    run(sim, 1.0)
    state0 = np.concatenate([np.zeros(3), [10.0, 5.0, -3.0], np.eye(3).ravel(), rates])
    s = aero_reference(table, state0, 1.0, gravity)
    assert np.ptp(np.degrees(np.abs(sim.rates))) > 5   # it did move through the table
    # piecewise-linear tables: RK4 drops to second order where alpha or beta crosses a
    # node (measured 9e-7, 2e-7, 3e-8 at dt = 1, 0.5, 0.25 ms); a wrong term would be
    # off by orders of magnitude more
    np.testing.assert_allclose(sim.position[0], s[0:3], rtol=0, atol=5e-7)
    np.testing.assert_allclose(sim.velocity[0], s[3:6], rtol=0, atol=5e-7)
    np.testing.assert_allclose(quat_matrix(sim.orientation[0]), s[6:15].reshape(3, 3),
                               rtol=0, atol=5e-7)
    np.testing.assert_allclose(sim.rates[0], s[15:18], rtol=0, atol=5e-7)


@pytest.mark.parametrize('change, key', [
    ({'density': 1.0, 'altitude': 100.0}, 'aero.store.density'),
    ({'alpha_deg': [0, 0]}, 'aero.store.alpha_deg'),
    ({'Cm': [1, 2, 3]}, 'aero.store.Cm'),
    ({'Cm': [1, 'x']}, 'aero.store.Cm[1]'),
    ({'altitude': 30000.0, 'density': None}, 'aero.store.altitude'),
])
def test_bad_aero_is_refused_with_the_key_path(change, key):
    spec = {**AIR, 'alpha_deg': [-10, 10], 'Cm': [0.1, -0.1],
            'zero': ['CX', 'CY', 'CZ', 'Cl', 'Cn'], **change}
    spec = {k: v for k, v in spec.items() if v is not None}
    with pytest.raises(ScenarioError) as err:
        model(aero={'store': spec})
    assert err.value.key == key


def test_batch_copies_measure_strokes_from_their_own_start():
    m = model([EJECTOR], bodies={'store': {'mass': MASS, 'inertia': INERTIA}})
    y0 = Simulator(m).y.copy()
    y0[0:3] = [5.0, -2.0, 1.0]   # elsewhere: the stroke is still 0.1006 m from there
    moved, = batch.run(m, [{'y0': y0}], duration=0.5)
    here = run(Simulator(m), 0.5)
    np.testing.assert_allclose(moved.y[3:6], here.velocity[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(moved.y[0:3], here.position[0] + [5.0, -2.0, 1.0], atol=1e-12)


def test_an_aerodynamic_scale_multiplies_its_coefficient():
    # what a study varies: aero.<body>.scale.<coefficient>, here the pitching moment
    doc = yaml.safe_load((CONFIG / 'store_separation_aero.yaml').read_text())
    base = parse_scenario(doc).aero[0]
    doc['aero']['store']['scale'] = {'Cm': 2.0, 'Cmq': 0.5}
    scaled = parse_scenario(doc).aero[0]
    np.testing.assert_array_equal(scaled.coefficients[..., 4], 2.0 * base.coefficients[..., 4])
    np.testing.assert_array_equal(scaled.coefficients[..., :4], base.coefficients[..., :4])
    assert scaled.damping[1] == 0.5 * base.damping[1] and scaled.damping[0] == base.damping[0]
    doc['aero']['store']['scale'] = {'Cq': 1.0}
    with pytest.raises(ScenarioError, match=r'aero\.store\.scale\.Cq'):
        parse_scenario(doc)
