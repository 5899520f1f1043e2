# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Aerodynamics a clearance rests on (SPEC section 10), against independent references.

A free store under constant coefficients about a reference point off the CG,
with a CG offset and a hot day, against scipy's DOP853 integrating the
equations of the guide (docs/guide/loads-and-aero.md); the atmosphere against
the U.S. Standard Atmosphere 1976's own formulas; the time a store leaves a
table, against the closed form of its fall.
"""

import math

from cfem_ros import Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.native import atmosphere
from cfem_ros.core.scenario.parse import parse_scenario
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation
import yaml

G0 = 9.80665

# ------------------------------------------------------- the 1976 standard's own formulas

R_STAR, M0, GAMMA = 8.31432e3, 28.9644, 1.4        # J/(kmol K), kg/kmol (1976, table 2)
LAYERS = ((0.0, -6.5e-3), (11000.0, 0.0), (20000.0, 1.0e-3))   # H_b (m'), L_b (K/m')


def standard_1976(h, offset=0.0):
    """Density and speed of sound at geopotential h (m'), T offset K: eqs. 23, 33a, 33b, 42, 50."""
    t_b, p_b = 288.15, 101325.0
    for k, (h_b, lapse) in enumerate(LAYERS):
        top = LAYERS[k + 1][0] if k + 1 < len(LAYERS) else math.inf
        dh = min(h, top) - h_b if h > h_b or k == 0 else 0.0
        if lapse == 0.0:
            p = p_b * math.exp(-G0 * M0 * dh / (R_STAR * t_b))
        else:
            p = p_b * (t_b / (t_b + lapse * dh)) ** (G0 * M0 / (R_STAR * lapse))
        t = t_b + lapse * dh
        if h <= top:
            break
        t_b, p_b = t, p
    temperature = t + offset
    return p * M0 / (R_STAR * temperature), math.sqrt(GAMMA * R_STAR * temperature / M0)


@pytest.mark.parametrize('offset', [0.0, 15.0, -25.0])
def test_isa_with_a_temperature_offset_against_the_1976_formulas(offset):
    for h in (-500.0, 0.0, 1524.0, 7925.0, 10999.0, 11000.0, 15000.0, 20000.0, 25000.0):
        density, sound = atmosphere.isa(h, offset)
        want = standard_1976(h, offset)
        assert density == pytest.approx(want[0], rel=1e-10, abs=0), (h, offset)
        assert sound == pytest.approx(want[1], rel=1e-10, abs=0), (h, offset)
    # the standard's tables (1976, table I): sea level and 11 km, ISA day
    assert atmosphere.isa(0.0) == pytest.approx((1.2250, 340.294), rel=2e-5)
    assert atmosphere.isa(11000.0)[0] == pytest.approx(0.36392, rel=2e-5)
    # a hot day: the same pressure, less dense, faster sound
    _, _, _, p_hot = atmosphere.isa_state(1524.0, 15.0)
    assert p_hot == atmosphere.isa_state(1524.0, 0.0)[3]


# ------------------------------------------------------------ the free store vs DOP853

MASS, INERTIA = 230.0, np.array([4.1, 95.0, 95.0])
CG_OFFSET = np.array([0.04, -0.01, 0.015])
REFERENCE = np.array([0.25, 0.02, -0.03])
COEFFICIENTS = {'CX': -0.35, 'CY': 0.04, 'CZ': -0.6, 'Cl': 0.002, 'Cm': -0.05, 'Cn': 0.01}
DAMPING = {'Clp': -2.0, 'Cmq': -60.0, 'Cnr': -55.0}
DELTA = {'Cm': 0.02, 'CZ': -0.05}
AREA, LENGTH, ALTITUDE, HOT = 0.0324, 2.4, 1524.0, 15.0


def free_store():
    aero = {'area': AREA, 'length': LENGTH, 'alpha_deg': [-180, 180],
            'atmosphere': {'altitude': ALTITUDE, 'temperature_offset': HOT},
            'reference_point': REFERENCE.tolist(), 'delta': DELTA,
            **COEFFICIENTS, **DAMPING}
    return {'gravity': [0, 0, G0], 'duration': 1.0, 'dt': 0.001,
            'bodies': {'store': {'mass': MASS, 'inertia': INERTIA.tolist(),
                                 'position': [0.0, 0.0, 0.4], 'cg_offset': CG_OFFSET.tolist(),
                                 'orientation_rpy_deg': [3.0, 4.0, -2.0],
                                 'velocity': [240.0, 3.0, 6.0],
                                 'angular_velocity_deg': [10.0, -5.0, 3.0]}},
            'aero': {'store': aero}}


def reference_rhs(_, s):
    """Return the state's rate by the guide's equations (Newton, Euler, quaternions)."""
    v, q, w = s[3:6], s[6:10], s[10:13]
    turn = Rotation.from_quat(q).as_matrix()
    density, _ = standard_1976(ALTITUDE - s[2], HOT)   # height: along -gravity (z down)
    u = turn.T @ v                                     # still air: the air-relative velocity
    speed = np.linalg.norm(u)
    qs = 0.5 * density * speed ** 2 * AREA
    c = dict(COEFFICIENTS)
    for name, value in DELTA.items():
        c[name] += value
    force = qs * np.array([c['CX'], c['CY'], c['CZ']])
    damping = np.array([DAMPING['Clp'], DAMPING['Cmq'], DAMPING['Cnr']]) * w * LENGTH / (2 * speed)
    moment = qs * LENGTH * (np.array([c['Cl'], c['Cm'], c['Cn']]) + damping) \
        + np.cross(REFERENCE - CG_OFFSET, force)
    acceleration = turn @ force / MASS + np.array([0, 0, G0])
    w_dot = (moment - np.cross(w, INERTIA * w)) / INERTIA
    x, y, z, qw = q
    q_dot = 0.5 * np.array([qw * w[0] + y * w[2] - z * w[1], qw * w[1] + z * w[0] - x * w[2],
                            qw * w[2] + x * w[1] - y * w[0], -(x * w[0] + y * w[1] + z * w[2])])
    return np.concatenate([v, acceleration, q_dot, w_dot])


def test_free_store_about_a_reference_point_with_a_cg_offset_against_dop853():
    doc = free_store()
    sim = Simulator(parse_scenario(doc))
    assert sim.advance_to(1.0)
    store = doc['bodies']['store']
    turn0 = Rotation.from_euler('ZYX', store['orientation_rpy_deg'][::-1], degrees=True)
    start = np.concatenate([np.array(store['position']) + turn0.apply(CG_OFFSET),
                            store['velocity'], turn0.as_quat(),
                            np.radians(store['angular_velocity_deg'])])
    ref = solve_ivp(reference_rhs, (0.0, 1.0), start, method='DOP853', rtol=1e-13,
                    atol=1e-13).y[:, -1]
    assert np.abs(sim.position[0] - ref[:3]).max() < 1e-8
    gap = Rotation.from_quat(ref[6:10]).inv() * Rotation.from_quat(sim.orientation[0])
    assert gap.magnitude() < 1e-8
    # the store did turn and fall: the moments about the actual CG mattered
    moved = Rotation.from_quat(start[6:10]).inv() * Rotation.from_quat(ref[6:10])
    assert moved.magnitude() > 0.05 and ref[2] - start[2] > 1.0


def test_the_moment_about_the_cg_moves_with_the_cg_as_the_equations_say():
    # same store at rest in the air: only the CG offset differs; the moment about the
    # actual CG changes by (r_ref - cg) x F exactly
    moments = []
    for offset in ([0.0, 0.0, 0.0], [0.1, 0.0, 0.0]):
        doc = free_store()
        store = doc['bodies']['store']
        store.update(cg_offset=offset, orientation_rpy_deg=[0, 0, 0], velocity=[240.0, 0, 0],
                     angular_velocity_deg=[0, 0, 0])
        sim = Simulator(parse_scenario(doc))
        air = sim.air()[0]
        force = sim.applied_loads()[0, :3]
        moments.append((sim.applied_loads()[0, 3:], force, air))
    (m0, f0, _), (m1, f1, air1) = moments
    np.testing.assert_allclose(f1, f0, rtol=1e-13)
    np.testing.assert_allclose(m1 - m0, np.cross([-0.1, 0, 0], f0), rtol=1e-12, atol=1e-9)
    qsl = air1[3] * AREA * LENGTH
    np.testing.assert_allclose(air1[9:12], m1 / qsl, rtol=1e-12)


# ------------------------------------------------------------ leaving a table

def falling_store(outside='hold', **aero):
    """
    Return a level store in a 100 m/s headwind, no aero load: alpha = atan(g t / U) exactly.

    A pylon and a wrench of no force put the aero row away from the bodies' count.
    """
    return {'gravity': [0, 0, G0], 'duration': 1.2, 'dt': 0.001,
            'bodies': {'pylon': {'fixed': True},
                       'store': {'mass': MASS, 'inertia': INERTIA.tolist()}},
            'wrenches': [{'body': 'store', 'force': [0.0, 0.0, 0.0]}],
            'aero': {'store': {'area': AREA, 'length': LENGTH, 'density': 1.2,
                               'wind': [-100.0, 0, 0], 'alpha_deg': [-5, 5], 'CX': 0.0,
                               'zero': ['CY', 'CZ', 'Cl', 'Cm', 'Cn'], 'outside': outside,
                               **aero}}}


def test_leaving_a_table_is_located_inside_the_step():
    crossing = 100.0 * math.tan(math.radians(5.0)) / G0        # s
    sim = Simulator(parse_scenario(falling_store()))
    assert sim.advance_to(1.2)
    events = [e for e in sim.events if e['event'].startswith('aero_')]
    assert len(events) == 1 and events[0]['event'] == 'aero_outside'
    event = events[0]
    assert abs(event['time'] - crossing) < 1e-9
    assert (event['body'], event['axis'], event['low'], event['high']) == \
        ('store', 'alpha_deg', -5.0, 5.0)
    assert event['value'] == pytest.approx(5.0, abs=1e-7)
    from cfem_ros.core.engine.aero import seconds_outside
    assert seconds_outside(sim.events, 'store', sim.t) == pytest.approx(1.2 - crossing,
                                                                        abs=1e-9)
    # outside: stop ends the run there, with the axis and the value in the message
    sim = Simulator(parse_scenario(falling_store('stop')))
    assert not sim.advance_to(1.2)
    assert sim.status == 'aero_outside' and abs(sim.t - crossing) < 1e-9
    assert 'alpha_deg = 5' in sim.message and '[-5, 5]' in sim.message


def test_run_exits_1_where_a_table_that_says_stop_is_left(tmp_path, capsys):
    from cfem_ros import cli
    from cfem_ros.recording.analysis import open_run
    path = tmp_path / 'stop.yaml'
    path.write_text(yaml.safe_dump(falling_store('stop')))
    assert cli.main(['run', str(path), '-o', str(tmp_path / 'stop.mcap')]) == 1
    err = capsys.readouterr().err
    assert 'ERROR' in err and 'alpha_deg = 5' in err and 'outside: stop' in err
    run = open_run(str(tmp_path / 'stop.mcap'))   # complete up to there, the event in it
    assert [e['event'] for e in run.events if e['event'].startswith('aero')] == ['aero_outside']


def test_a_run_that_starts_outside_is_told_at_once_and_comes_back_inside():
    # the case: a Mach 0.45 run against a table from 0.8 to 0.95
    doc = falling_store(mach=[0.8, 0.95], altitude=0.0, alpha_deg=[-5, 90])
    del doc['aero']['store']['density']
    doc['aero']['store']['wind'] = [-153.0, 0, 0]
    doc['duration'] = 0.1
    sim = Simulator(parse_scenario(doc))
    first = sim.events[0]
    assert (first['event'], first['axis'], first['time']) == ('aero_outside', 'mach', 0.0)
    assert (first['low'], first['high']) == (0.8, 0.95)
    assert first['value'] == pytest.approx(153.0 / 340.294, rel=1e-5)
    # alpha from -10 deg, rising through -5: back inside its range, located in the step
    doc = falling_store(alpha_deg=[-5, 5])
    doc['bodies']['store']['velocity'] = [0.0, 0.0, -100.0 * math.tan(math.radians(10.0))]
    sim = Simulator(parse_scenario(doc))
    assert sim.advance_to(1.2)
    kinds = [(e['event'], e['time']) for e in sim.events]
    back = (100.0 * math.tan(math.radians(10.0)) - 100.0 * math.tan(math.radians(5.0))) / G0
    assert kinds[0] == ('aero_outside', 0.0) and kinds[1][0] == 'aero_inside'
    assert abs(kinds[1][1] - back) < 1e-9


@pytest.mark.parametrize('change, key', [
    ({'outside': 'clip'}, 'aero.store.outside'),
    ({'atmosphere': {'altitude': 100.0, 'temperature_offset': 500.0}},
     'aero.store.atmosphere.temperature_offset'),
    ({'atmosphere': {'height': 100.0}}, 'aero.store.atmosphere.height'),
    ({'delta': {'CQ': 0.1}}, 'aero.store.delta.CQ'),
    ({'reference_point': [0, 1]}, 'aero.store.reference_point'),
])
def test_bad_section_10_input_is_refused_with_the_key_path(change, key):
    doc = falling_store(**change)
    if 'atmosphere' in change:
        del doc['aero']['store']['density']
    with pytest.raises(ScenarioError) as err:
        parse_scenario(doc)
    assert err.value.key == key
