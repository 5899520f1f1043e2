# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""flight: (SPEC section 14): the steady manoeuvre, the load a store carries, the air it sees."""

import copy
import math

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.scenario.parse import parse_scenario
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

G = 9.80665
MASS = 907.1848


def _isa(h, offset=0.0):
    """ISA troposphere (U.S. Standard Atmosphere 1976, its constants), a hot/cold day."""
    r_air = 8314.32 / 28.9644                  # J/(kg K): R* / M0 of the 1976 standard
    t_isa = 288.15 - 0.0065 * h
    pressure = 101325.0 * (t_isa / 288.15) ** (G / (r_air * 0.0065))
    temperature = t_isa + offset               # the pressure stays ISA
    return pressure / (r_air * temperature), math.sqrt(1.4 * r_air * temperature)


def _document(flight, store_at=(0.0, 0.0, 0.0), aero=False):
    doc = {'duration': 1.0, 'dt': 0.001,
           'flight': {'carrier': 'aircraft', **flight},
           'bodies': {'aircraft': {'position': [10.0, -2.0, 3.0]},
                      'store': {'mass': MASS, 'inertia': [27.1164, 488.0944, 488.0944],
                                'position': [10.0 + store_at[0], -2.0 + store_at[1],
                                             3.0 + store_at[2]]}},
           'joints': {'hook': {'type': 'fixed', 'parent': 'aircraft', 'child': 'store',
                               'anchor': [10.0, -2.0, 3.2]}}}
    if aero:
        doc['aero'] = {'store': {'area': 0.2, 'length': 0.5, 'alpha_deg': [-10, 10],
                                 'CX': [-0.3, -0.3], 'CY': 0.0, 'CZ': [0.5, -0.5],
                                 'Cl': 0.0, 'Cm': [0.1, -0.1], 'Cn': 0.0}}
    return doc


CONDITIONS = [
    {'mach': 0.95, 'altitude': 7924.8, 'load_factor': 2.5},
    {'airspeed': 200.0, 'altitude': 1500.0, 'load_factor': -0.5, 'flight_path_deg': -30.0},
    {'mach': 0.6, 'altitude': 9000.0, 'load_factor': 3.0, 'flight_path_deg': 20.0,
     'alpha_deg': 4.0, 'temperature_offset': 15.0},
]


def _speed(flight):
    if 'airspeed' in flight:
        return flight['airspeed']
    return flight['mach'] * _isa(flight['altitude'], flight.get('temperature_offset', 0.0))[1]


@pytest.mark.parametrize('flight', CONDITIONS)
def test_the_carrier_flies_the_circular_arc_of_the_pull_up(flight):
    """Path and attitude against the circle in the vertical plane, within 1e-9 m over 1 s."""
    sim = Simulator(parse_scenario(_document(flight)))
    speed = _speed(flight)
    gamma = math.radians(flight.get('flight_path_deg', 0.0))
    alpha = math.radians(flight.get('alpha_deg', 0.0))
    q = G * (flight['load_factor'] - math.cos(gamma)) / speed
    radius = speed / q
    start = np.array([10.0, -2.0, 3.0])
    for t in (0.25, 0.5, 0.75, 1.0):
        sim.advance_to(t)
        phi = gamma + q * t                      # the flight path angle now (climb +, z down)
        expected = start + radius * np.array([math.sin(phi) - math.sin(gamma), 0.0,
                                              math.cos(phi) - math.cos(gamma)])
        assert np.abs(sim.position[0] - expected).max() < 1e-9
        assert np.abs(sim.velocity[0] - speed * np.array([math.cos(phi), 0.0,
                                                          -math.sin(phi)])).max() < 1e-9
        attitude = Rotation.from_euler('y', phi + alpha)
        assert (Rotation.from_quat(sim.orientation[0]) * attitude.inv()).magnitude() < 1e-12


def test_a_rolling_pull_up_follows_its_constant_body_rates_and_body_axis_velocity():
    """Roll about the flight path with the pitch rate: against an integration of R(t) v."""
    flight = {'mach': 0.8, 'altitude': 3000.0, 'load_factor': 2.0, 'roll_rate_deg_s': 40.0,
              'alpha_deg': 5.0}
    sim = Simulator(parse_scenario(_document(flight)))
    speed = _speed(flight)
    alpha = math.radians(5.0)
    along = np.array([math.cos(alpha), 0.0, math.sin(alpha)])
    rates = math.radians(40.0) * along + np.array([0.0, G * (2.0 - 1.0) / speed, 0.0])
    start = Rotation.from_euler('y', alpha)

    def turned(t):
        return start * Rotation.from_rotvec(rates * t)

    solution = solve_ivp(lambda t, p: turned(t).apply(speed * along), (0.0, 1.0),
                         [10.0, -2.0, 3.0], method='DOP853', rtol=1e-13, atol=1e-12,
                         dense_output=True)
    for t in (0.5, 1.0):
        sim.advance_to(t)
        assert np.abs(sim.position[0] - solution.sol(t)).max() < 1e-9
        assert (Rotation.from_quat(sim.orientation[0]) * turned(t).inv()).magnitude() < 1e-12
        assert np.abs(sim.rates[0] - rates).max() < 1e-12


@pytest.mark.parametrize('flight', CONDITIONS)
def test_a_store_without_aero_carries_n_g_at_release(flight):
    """The hook's load at t = 0 is m n g normal to the flight path and m g sin(gamma) along it."""
    sim = Simulator(parse_scenario(_document(flight)))
    force, _ = sim.joint_wrenches()
    gamma = math.radians(flight.get('flight_path_deg', 0.0))
    along = np.array([math.cos(gamma), 0.0, -math.sin(gamma)])     # the flight path, world
    up = np.array([-math.sin(gamma), 0.0, -math.cos(gamma)])        # its normal, lift side
    n = flight['load_factor']
    assert force[0] @ up == pytest.approx(MASS * n * G, rel=1e-9, abs=1e-8)
    assert force[0] @ along == pytest.approx(MASS * G * math.sin(gamma), rel=1e-9, abs=1e-8)
    assert abs(force[0][1]) < 1e-8


def test_a_store_below_the_carrier_adds_the_centripetal_load_of_the_pitch_rate():
    flight = CONDITIONS[0]
    sim = Simulator(parse_scenario(_document(flight, store_at=(0.0, 0.0, 1.5))))
    force, _ = sim.joint_wrenches()
    q = G * (2.5 - 1.0) / _speed(flight)
    assert -force[0][2] == pytest.approx(MASS * (2.5 * G + q * q * 1.5), rel=1e-9)


@pytest.mark.parametrize('flight', CONDITIONS)
def test_the_store_sees_the_flight_mach_and_dynamic_pressure_of_the_isa(flight):
    sim = Simulator(parse_scenario(_document(flight, aero=True)))
    air = sim.air()[0]
    density, sound = _isa(flight['altitude'], flight.get('temperature_offset', 0.0))
    speed = _speed(flight)
    assert air[2] == pytest.approx(speed / sound, rel=1e-9)                  # Mach
    assert air[3] == pytest.approx(0.5 * density * speed ** 2, rel=1e-9)    # Pa
    assert air[4] == pytest.approx(density, rel=1e-9)
    # the store is level (its attitude is the scenario's): its alpha is minus the path angle
    assert air[0] == pytest.approx(-flight.get('flight_path_deg', 0.0), abs=1e-9)   # deg


def test_gravity_is_z_down_with_flight():
    model = parse_scenario(_document(CONDITIONS[0]))
    assert model.gravity.tolist() == [0.0, 0.0, G]


@pytest.mark.parametrize('change, key', [
    (lambda d: d['bodies']['aircraft'].update(motion={'velocity': [250, 0, 0]}),
     'bodies.aircraft.motion'),
    (lambda d: d['bodies']['aircraft'].update(orientation_rpy_deg=[0, 5, 0]),
     'bodies.aircraft.orientation_rpy_deg'),
    (lambda d: d['aero']['store'].update(freestream=[-250, 0, 0]), 'aero.store.freestream'),
    (lambda d: d['aero']['store'].update(altitude=1000), 'aero.store.altitude'),
    (lambda d: d['aero']['store'].update(atmosphere={'altitude': 1000}),
     'aero.store.atmosphere'),
    (lambda d: d.update(gravity=[0, 0, -G]), 'gravity'),
    (lambda d: d['flight'].update(carrier='tanker'), 'flight.carrier'),
    (lambda d: d['flight'].update(airspeed=250), 'flight.airspeed'),
    (lambda d: d['flight'].pop('mach'), 'flight.mach'),
    (lambda d: d['flight'].update(altitude=30000), 'flight.altitude'),
    (lambda d: d['flight'].update(flight_path_deg=95), 'flight.flight_path_deg'),
    (lambda d: d['flight'].update(mach=-0.5), 'flight.mach'),
    (lambda d: d['flight'].update(speed=0.5), 'flight.speed'),
])
def test_conflicts_are_refused_with_the_key_path(change, key):
    doc = copy.deepcopy(_document(CONDITIONS[0], aero=True))
    change(doc)
    with pytest.raises(ScenarioError) as err:
        parse_scenario(doc, source='pull.yaml')
    assert f'{key}:' in str(err.value) or f'{key} ' in str(err.value)
    assert 'pull.yaml' in str(err.value)


def test_the_carrier_attitude_at_t0_is_the_flight_path_plus_alpha():
    model = parse_scenario(_document(CONDITIONS[2]))
    yaw, pitch, roll = Rotation.from_quat(model.bodies[0].orientation_xyzw).as_euler(
        'ZYX', degrees=True)
    assert (yaw, pitch, roll) == pytest.approx((0.0, 24.0, 0.0), abs=1e-9)


def test_check_states_the_condition_and_the_manoeuvre_it_flies(tmp_path, capsys):
    """cfem-sim check prints Mach, airspeed, pitch rate and dynamic pressure from the ISA."""
    import yaml
    from cfem_ros import cli
    flight = CONDITIONS[1]   # 200 m/s at 1500 m, n = -0.5 in a 30 deg dive
    path = tmp_path / 'dive.yaml'
    path.write_text(yaml.safe_dump(_document(flight)))
    assert cli.main(['check', str(path)]) == 0
    [line] = [x for x in capsys.readouterr().out.splitlines() if x.startswith('  flight:')]
    density, sound = _isa(1500.0)
    q = G * (-0.5 - math.cos(math.radians(-30.0))) / 200.0
    assert line == (f'  flight: aircraft at Mach {200.0 / sound:.4g} (200 m/s true), 1500 m, '
                    f'ISA +0 K, flight path -30 deg, n = -0.5: pitch rate '
                    f'{math.degrees(q):.5g} deg/s, dynamic pressure '
                    f'{0.5 * density * 200.0 ** 2:.6g} Pa')
