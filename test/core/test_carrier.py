# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Kinematic bodies (a moving carrier): exact joints to a prescribed trajectory."""

import copy
import math

from cfem_ros.core import rotations
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.native import motion
from cfem_ros.core.scenario.parse import parse_scenario
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation, RotationSpline

G = 9.80665
MASS = 500.0
INERTIA = [50.0, 400.0, 420.0]
HINGE = np.array([0.5, 0.0, -0.6])     # in the carrier's axes (carrier CG at the origin)
STORE = np.array([0.0, 0.0, -1.0])     # the store's CG at t = 0, carrier axes
SPEED = 250.0


def _document(aircraft, store_extra=None, release=None):
    store = {'mass': MASS, 'inertia': INERTIA, 'position': STORE.tolist()}
    store.update(store_extra or {})
    joint = {'type': 'hinge', 'parent': 'aircraft', 'child': 'store',
             'anchor': HINGE.tolist(), 'axis': [0, 1, 0]}
    if release is not None:
        joint['release'] = {'time': release}
    return {'name': 'carrier', 'dt': 0.001, 'duration': 2.0,
            'bodies': {'aircraft': aircraft, 'store': store}, 'joints': {'hook': joint}}


def _relative(sim):
    """Return the store's CG in the carrier's axes and the relative quaternion."""
    pos, quat = sim.position, sim.orientation
    rot = rotations.matrices(quat)
    return rot[0].T @ (pos[1] - pos[0]), rotations.multiply(
        rotations.conjugate(quat[0:1]), quat[1:2])[0]


def _pitch_solution(rate, origin_acceleration, times):
    """
    Integrate the hinged store in the carrier's rotating frame (DOP853).

    The carrier turns at a constant pitch rate about its y axis, its origin
    (CG) accelerating by ``origin_acceleration`` (carrier axes, constant):
    in its frame the store swings about the fixed hinge under gravity (turned
    into carrier axes), the origin's acceleration, the centrifugal and the
    Coriolis forces; with every rotation about y, no gyroscopic moment.
    """
    s0 = STORE - HINGE
    omega = np.array([0.0, rate, 0.0])
    inertia_h = INERTIA[1] + MASS * (s0[0] ** 2 + s0[2] ** 2)
    a_origin = np.asarray(origin_acceleration, dtype=float)

    def rhs(t, state):
        theta, theta_dot = state
        s = Rotation.from_rotvec([0.0, theta, 0.0]).apply(s0)
        r = HINGE + s
        r_dot = np.cross([0.0, theta_dot, 0.0], s)
        gravity = Rotation.from_rotvec([0.0, rate * t, 0.0]).inv().apply([0.0, 0.0, -G])
        force = MASS * (gravity - a_origin - np.cross(omega, np.cross(omega, r))
                        - 2.0 * np.cross(omega, r_dot))
        return [theta_dot, np.cross(s, force)[1] / inertia_h]

    sol = solve_ivp(rhs, (0.0, times[-1]), [0.0, 0.0], method='DOP853', t_eval=times,
                    rtol=1e-12, atol=1e-14)
    assert sol.success
    return [HINGE + Rotation.from_rotvec([0.0, th, 0.0]).apply(s0) for th in sol.y[0]]


def _run(document, times):
    sim = Simulator(parse_scenario(document))
    out = []
    for t in times:
        assert sim.advance_to(t), sim.message
        out.append(_relative(sim))
    return sim, out


def _pullup(t, rate):
    """Carrier on a circle at SPEED turning at rate about y: position, quaternion."""
    phi = rate * t
    position = np.array([SPEED / rate * math.sin(phi), 0.0, SPEED / rate * (math.cos(phi) - 1)])
    return position, Rotation.from_rotvec([0.0, phi, 0.0]).as_quat()


TIMES = np.linspace(0.25, 2.0, 8)


def test_constant_pitch_rate_matches_the_rotating_frame_solution():
    rate = math.radians(20.0)
    aircraft = {'motion': {'velocity': [SPEED, 0, 0], 'angular_velocity': [0, rate, 0]}}
    sim, rel = _run(_document(aircraft), TIMES)
    # the carrier is exactly where its motion puts it
    assert np.allclose(sim.position[0], [SPEED * 2.0, 0, 0], rtol=0, atol=1e-12)
    expected = _pitch_solution(rate, [0.0, 0.0, 0.0], TIMES)
    error = max(np.abs(r[0] - e).max() for r, e in zip(rel, expected))
    swing = max(np.abs(r[0] - STORE).max() for r in rel)
    assert swing > 0.05   # the store does swing
    assert error < 1e-8, error


def test_steady_pull_up_from_a_table_matches_the_rotating_frame_solution():
    rate = -G / SPEED    # 2 g: the centripetal acceleration is g, up
    times = np.arange(-0.2, 2.2 + 1e-9, 0.005)
    rows = [[t, *_pullup(t, rate)[0], *_pullup(t, rate)[1]] for t in times]
    sim, rel = _run(_document({'motion': {'table': rows}}), TIMES)
    position, quat = _pullup(2.0, rate)
    assert np.allclose(sim.position[0], position, rtol=0, atol=1e-9)
    assert abs(abs(quat @ sim.orientation[0]) - 1) < 1e-12
    # the origin accelerates by omega x v: (0, 0, -rate V) in the carrier's axes
    expected = _pitch_solution(rate, [0.0, 0.0, -rate * SPEED], TIMES)
    error = max(np.abs(r[0] - e).max() for r, e in zip(rel, expected))
    swing = max(np.abs(r[0] - STORE).max() for r in rel)
    assert swing > 0.05
    # the table's splines differ from the circle by about 1e-9 m/s^2 at 200 Hz
    assert error < 1e-7, error


def test_store_released_in_the_pull_up_is_in_free_fall():
    rate = -G / SPEED
    times = np.arange(-0.2, 2.2 + 1e-9, 0.005)
    rows = [[t, *_pullup(t, rate)[0], *_pullup(t, rate)[1]] for t in times]
    sim = Simulator(parse_scenario(_document({'motion': {'table': rows}}, release=0.5)))
    assert sim.advance_to(0.5)
    assert sim.advance_to(0.5 + 1e-9) and not sim.active[0]
    t0, p0, v0 = sim.t, sim.position[1].copy(), sim.velocity[1].copy()
    assert sim.advance_to(1.5)
    dt = sim.t - t0
    expected = p0 + v0 * dt + 0.5 * np.array([0, 0, -G]) * dt ** 2
    assert np.abs(sim.position[1] - expected).max() < 1e-9


def test_a_carrier_at_constant_velocity_gives_the_fixed_carrier_motion():
    fixed = _document({'fixed': True}, release=0.7)
    moving = _document({'motion': {'velocity': [SPEED, 3.0, -2.0]}}, release=0.7)
    sim_f, rel_f = _run(fixed, TIMES)
    sim_m, rel_m = _run(moving, TIMES)
    assert not sim_f.active[0] and not sim_m.active[0]
    for (pf, qf), (pm, qm) in zip(rel_f, rel_m):
        assert np.abs(pm - pf).max() < 1e-9
        assert np.abs(qm - qf).max() < 1e-9
    # the store started with the carrier's velocity: its own is the fixed case's plus it
    assert np.abs(sim_m.velocity[1] - sim_f.velocity[1] - [SPEED, 3.0, -2.0]).max() < 1e-9
    assert np.abs(sim_m.position[0] - np.array([SPEED, 3.0, -2.0]) * 2.0).max() < 1e-12


def test_a_table_of_constant_velocity_gives_the_constant_velocity_result():
    rate = np.radians([3.0, -10.0, 5.0])
    q0 = Rotation.from_euler('xyz', [0.1, -0.2, 0.3])
    velocity = np.array([SPEED, 0.0, 5.0])
    aircraft = {'motion': {'velocity': velocity.tolist(), 'angular_velocity': rate.tolist()},
                'orientation_xyzw': q0.as_quat().tolist()}
    times = np.arange(-0.1, 2.1 + 1e-9, 0.01)
    rows = [[t, *(velocity * t), *(q0 * Rotation.from_rotvec(rate * t)).as_quat()]
            for t in times]
    constant = Simulator(parse_scenario(_document(aircraft)))
    table = Simulator(parse_scenario(_document({'motion': {'table': rows}})))
    for t in TIMES:
        assert constant.advance_to(t) and table.advance_to(t)
        assert np.abs(constant.y - table.y).max() < 1e-9
        fc, mc = constant.joint_wrenches()
        ft, mt = table.joint_wrenches()
        assert np.abs(fc - ft).max() < 1e-6 * np.abs(fc).max()


def test_compiled_trajectory_matches_scipy_splines():
    rng = np.random.default_rng(3)
    times = np.cumsum(rng.uniform(0.05, 0.2, 12)) - 0.3
    positions = rng.normal(scale=20.0, size=(12, 3))
    attitudes = Rotation.from_rotvec(np.cumsum(rng.normal(scale=0.3, size=(12, 3)), axis=0))
    rows = np.column_stack([times, positions, attitudes.as_quat()]).tolist()
    model = parse_scenario(_document({'motion': {'table': rows}}))
    position, attitude = CubicSpline(times, positions), RotationSpline(times, attitudes)
    for t in np.linspace(times[0], times[-1], 37):
        p, v, q, w, a, alpha = motion.state_at(model, t)[0]
        r = attitude(t).as_matrix()
        assert np.allclose(p, position(t), rtol=0, atol=1e-10)
        assert np.allclose(v, position(t, 1), rtol=0, atol=1e-9)
        assert np.allclose(a, position(t, 2), rtol=0, atol=1e-8)
        assert abs(abs(q @ attitude(t).as_quat()) - 1.0) < 1e-13
        assert np.allclose(w, attitude(t, 1), rtol=0, atol=1e-10)
        assert np.allclose(alpha, r @ attitude(t, 2), rtol=0, atol=1e-8)
    # the body rates are the attitude's: dq/dt = q (w, 0) / 2, by central differences
    t, h = 0.4, 1e-5
    _, _, q, w, _, _ = motion.state_at(model, t)[0]
    qa, qb = motion.state_at(model, t - h)[0][2], motion.state_at(model, t + h)[0][2]
    qb = qb if qb @ qa > 0 else -qb
    dq = (qb - qa) / (2 * h)
    expected = 0.5 * rotations.multiply(q[None], np.array([[*w, 0.0]]))[0]
    assert np.allclose(dq, expected, rtol=0, atol=1e-6)


def test_stores_given_their_own_velocity_keep_it():
    doc = _document({'motion': {'velocity': [SPEED, 0, 0]}},
                    store_extra={'velocity': [0.0, 0.0, 0.0]})
    sim = Simulator(parse_scenario(doc))
    # corrected to satisfy the hinge (mass weighted): not the carrier's velocity
    assert abs(sim.velocity[1][0] - SPEED) > 1.0


@pytest.mark.parametrize('change, key', [
    (lambda d: d['bodies']['aircraft'].update(fixed=True), 'bodies.aircraft.motion'),
    (lambda d: d['bodies']['aircraft'].update(velocity=[1, 0, 0]), 'bodies.aircraft.velocity'),
    (lambda d: d['bodies']['aircraft']['motion'].update(table=[[0, 0, 0, 0, 0, 0, 0, 1]]),
     'bodies.aircraft.motion.velocity'),
    (lambda d: d['bodies']['aircraft'].update(motion={'table': [
        [0, 0, 0, 0, 0, 0, 0, 1], [0, 1, 0, 0, 0, 0, 0, 1]]}), 'bodies.aircraft.motion.table[1]'),
    (lambda d: d['bodies']['aircraft'].update(motion={'table': [
        [0.5, 0, 0, 0, 0, 0, 0, 1], [1, 1, 0, 0, 0, 0, 0, 1]]}),
     'bodies.aircraft.motion.table[0]'),
    (lambda d: d['bodies']['aircraft'].update(motion={'table': [
        [0, 0, 0, 0, 0, 0, 0, 1], [1, 1, 0, 0, 0, 0, 0, 2]]}),
     'bodies.aircraft.motion.table[1]'),
    (lambda d: d['bodies']['aircraft'].update(motion={'table': 'missing.csv'}),
     'bodies.aircraft.motion.table'),
    (lambda d: d['wrenches'].append({'body': 'aircraft', 'force': [1, 0, 0]}),
     'wrenches[0].body'),
])
def test_bad_motion_is_refused_with_its_key(change, key):
    doc = copy.deepcopy(_document({'motion': {'velocity': [SPEED, 0, 0]}}))
    doc['wrenches'] = []
    change(doc)
    with pytest.raises(ScenarioError) as err:
        parse_scenario(doc)
    assert key in str(err.value)
    assert '\n' not in str(err.value)


def test_table_from_a_csv_file_relative_to_the_scenario(tmp_path):
    lines = ['qw,qx,qy,qz,t,x,y,z']
    for t in np.arange(0.0, 2.01, 0.05):
        lines.append(f'1,0,0,0,{t:.2f},{SPEED * t:.6f},0,0')
    (tmp_path / 'flight.csv').write_text('\n'.join(lines) + '\n')
    doc = _document({'motion': {'table': 'flight.csv'}})
    path = tmp_path / 'scenario.yaml'
    import yaml
    path.write_text(yaml.safe_dump(doc))
    from cfem_ros.core.scenario.parse import load_scenario
    model = load_scenario(str(path))
    p, v, q, w, a, alpha = motion.state_at(model, 1.234)[0]
    assert np.allclose(p, [SPEED * 1.234, 0, 0], atol=1e-9)
    assert np.allclose(v, [SPEED, 0, 0], atol=1e-9)
    assert np.allclose(q, [0, 0, 0, 1], atol=1e-15)


@pytest.mark.parametrize('make, said', [
    (None, 'cannot read the file (No such file'), ('mkdir', 'is a directory')])
def test_a_motion_csv_that_cannot_be_read_is_one_message_about_a_csv_file(
        tmp_path, capsys, make, said):
    # the issue's case: "expected a readable, regular YAML scenario file); expected a
    # readable CSV file", the scenario file's refusal inside the table's
    if make:
        (tmp_path / 'flight.csv').mkdir()
    import yaml
    from cfem_ros import cli
    path = tmp_path / 'scenario.yaml'
    path.write_text(yaml.safe_dump(_document({'motion': {'table': 'flight.csv'}})))
    assert cli.main(['check', str(path)]) == 2
    line, = capsys.readouterr().err.splitlines()
    assert line.startswith(f'ERROR: {path}: bodies.aircraft.motion.table: ')
    assert line.count("'flight.csv' ('") == 1 and f"flight.csv'): {said}" in line
    assert line.count('expected') == 1 and line.endswith('expected a readable, regular CSV file')
    assert 'YAML' not in line


def test_relative_outputs_are_the_pose_and_twist_in_the_carrier_frame():
    rate = math.radians(20.0)
    aircraft = {'motion': {'velocity': [SPEED, 0, 0], 'angular_velocity': [0, rate, 0]}}
    model = parse_scenario(_document(aircraft))
    assert model.references == ((1, 0),)
    sim = Simulator(model)
    h = 1e-4
    assert sim.advance_to(0.6 - h)
    before = _relative(sim)[0]
    assert sim.advance_to(0.6)
    rel = sim.outputs()[-13:]
    assert np.array_equal(rel, sim.relative_states()[0])   # the node's: the same formula
    position, quat = _relative(sim)
    assert np.allclose(rel[:3], position, rtol=0, atol=1e-12)
    assert abs(abs(rel[3:7] @ quat) - 1) < 1e-12
    # the velocity seen from the carrier: the relative position's rate of change
    assert np.allclose(rel[7:10], (position - before) / h, rtol=0, atol=1e-3)
    # hinged about the carrier's y: the relative angular velocity is along y only
    assert abs(rel[10]) < 1e-9 and abs(rel[12]) < 1e-9 and abs(rel[11]) > 0.01
    assert np.allclose(rel[7:10], np.cross(rel[10:], position - HINGE), rtol=0, atol=1e-9)
    # the applied loads (none) are not mixed with the relative numbers
    assert sim.applied_loads().shape == (0, 6)


def test_reference_key_names_the_frame_of_the_relative_outputs():
    doc = _document({'fixed': True})
    doc['bodies']['store']['reference'] = 'aircraft'
    assert parse_scenario(doc).references == ((1, 0),)
    doc['bodies']['store']['reference'] = 'store'
    with pytest.raises(ScenarioError, match='bodies.store.reference'):
        parse_scenario(doc)


def test_recording_has_the_relative_topics_and_plot(tmp_path):
    from cfem_ros import plots
    from cfem_ros.recording.analysis import open_run
    from cfem_ros.recording.offline import run
    from cfem_ros.recording.container import Recorder
    from cfem_ros.recording.recorder import StateRecorder
    rate = math.radians(20.0)
    aircraft = {'motion': {'velocity': [SPEED, 0, 0], 'angular_velocity': [0, rate, 0]}}
    sim = Simulator(parse_scenario(_document(aircraft, release=0.3)))
    path = str(tmp_path / 'run.mcap')
    with Recorder(path) as recorder:
        assert run(sim, StateRecorder(recorder, sim), rate_hz=50.0, duration=0.6)
    recorded = open_run(path)
    track = recorded.relative['store']
    assert track.reference == 'aircraft'
    assert len(track.time) == 31
    assert np.allclose(track.position[-1], _relative(sim)[0], rtol=0, atol=1e-12)
    assert np.isfinite(track.velocity).all()
    paths = plots.write_figures(recorded, str(tmp_path / 'figures'))
    assert any(p.endswith('trajectories_relative.png') for p in paths)


def _odometry_inputs(rate, until, step=0.01):
    from cfem_ros.core.run.inputs import odometry_input
    out = []
    for k in range(int(round(until / step)) + 1):
        t = k * step
        position, quat = _pullup(t, rate)
        out.append(odometry_input('aircraft', position, quat, [SPEED, 0, 0], [0, rate, 0],
                                  'world', time=t))
    return out


def _pull_up_error(step, interpolate):
    """Return the store's largest error in the pull-up driven by odometry every step s."""
    from cfem_ros.core.run.session import Session
    rate = -G / SPEED
    aircraft = {'motion': {'velocity': [SPEED, 0, 0], 'angular_velocity': [0, rate, 0]}}
    sim = Simulator(parse_scenario(_document(aircraft)))
    session = Session(sim, rate_hz=100.0, duration=2.0, outputs=[],
                      interpolate_odometry=interpolate)
    for item in _odometry_inputs(rate, 2.0, step):
        session.submit(item)
    rel = []
    for t in TIMES:
        session.advance(t)
        assert sim.status == 'running', sim.message
        rel.append(_relative(sim))
    # the run ends on the last message (t = 2 s): the carrier is on the circle
    assert np.allclose(sim.position[0], _pullup(2.0, rate)[0], rtol=0, atol=1e-6)
    assert max(np.abs(r[0] - STORE).max() for r in rel) > 0.05   # the store does swing
    expected = _pitch_solution(rate, [0.0, 0.0, -rate * SPEED], TIMES)
    return max(np.abs(r[0] - e).max() for r, e in zip(rel, expected))


def test_odometry_at_100_hz_drives_the_carrier_through_the_pull_up():
    # between messages the carrier is on the cubic through both poses and
    # velocities: off the circle by at most h^4 V w^3 / 384 (the fourth
    # derivative's bound; 4e-13 m at 100 Hz); the 7e-11 m measured is RK4's
    assert _pull_up_error(0.01, interpolate=True) < 1e-9
    # extrapolated from each message (a turning with the body): off the circle
    # by |a| w^3 h^4 / 24 (3e-14 m) at the next message; 1.1e-9 m measured
    assert _pull_up_error(0.01, interpolate=False) < 5e-9


def test_odometry_at_20_hz_is_interpolated_not_extrapolated():
    # at 20 Hz the cubic is still within 3e-10 m of the circle; extrapolated
    # from each message, the store feels a jump in acceleration at every
    # message, and is 7e-9 m off
    assert _pull_up_error(0.05, interpolate=True) < 1e-9
    assert _pull_up_error(0.05, interpolate=False) > 2e-9


def _flight(t):
    """Return a carrier weaving in three axes: CG, attitude, velocity (world), angle rates."""
    position = np.array([SPEED * t + 3.0 * math.sin(2.0 * t),
                         2.0 * (math.cos(1.5 * t) - 1.0), -1.0 * t ** 2])
    velocity = np.array([SPEED + 6.0 * math.cos(2.0 * t), -3.0 * math.sin(1.5 * t), -2.0 * t])
    angles = np.array([0.3 * math.sin(1.1 * t), 0.1 * t + 0.05 * t ** 2, -0.2 * math.sin(t)])
    rates = np.array([0.33 * math.cos(1.1 * t), 0.1 + 0.1 * t, -0.2 * math.cos(t)])
    return position, Rotation.from_euler('XYZ', angles), velocity, rates, angles


def _body_rates(angles, angle_rates):
    """Return the body rates of intrinsic X-Y-Z angles changing at angle_rates."""
    e1 = Rotation.from_euler('Z', -angles[2])
    e2 = Rotation.from_euler('YZ', [-angles[1], -angles[2]])
    return (e2.apply([angle_rates[0], 0, 0]) + e1.apply([0, angle_rates[1], 0])
            + np.array([0, 0, angle_rates[2]]))


def test_odometry_between_messages_is_the_cubic_hermite_through_them():
    from cfem_ros.core.run.inputs import odometry_input
    from cfem_ros.core.run.session import Session, Sink as SessionSink
    from scipy.interpolate import CubicHermiteSpline
    times = np.arange(0.0, 1.0 + 1e-9, 0.05)   # 20 Hz
    flight = [_flight(t) for t in times]
    start = {'velocity': flight[0][2].tolist(),
             'angular_velocity': _body_rates(flight[0][4], flight[0][3]).tolist()}
    sim = Simulator(parse_scenario(_document({'motion': start})))
    samples = []

    class Sink(SessionSink):
        def sample(self):
            samples.append((sim.t, sim.position[0].copy(), sim.velocity[0].copy(),
                            sim.orientation[0].copy(), sim.rates[0].copy()))

        def events(self):
            pass

        def received(self, item, t):
            pass

    session = Session(sim, rate_hz=200.0, duration=1.0, outputs=[Sink()])
    for t, (p, attitude, v, rates, angles) in zip(times, flight):
        session.submit(odometry_input('aircraft', p, attitude.as_quat(),
                                      attitude.inv().apply(v), _body_rates(angles, rates),
                                      'world', time=t))
    session.advance(1.0)
    assert sim.status == 'running', sim.message
    assert len(samples) == 201
    spline = CubicHermiteSpline(times, [f[0] for f in flight], [f[2] for f in flight])
    for t, p, v, q, w in samples:
        # position and velocity: scipy's cubic Hermite spline through the messages
        assert np.abs(p - spline(t)).max() < 1e-9, t
        assert np.abs(v - spline(t, 1)).max() < 1e-8, t
        # attitude: near the flight's (a cubic in rotation vector, not in angles)
        _, attitude, _, rates, angles = _flight(t)
        assert (Rotation.from_quat(q) * attitude.inv()).magnitude() < 1e-4, t
        k = int(round(t / 0.05))
        if k > 0 and abs(t - times[k]) < 1e-12:
            # on a message, before it takes effect: the segment ends on its
            # attitude and body rates (the rotation vector's rate mapped back)
            assert abs(abs(q @ attitude.as_quat()) - 1.0) < 1e-13, t
            assert np.abs(w - _body_rates(angles, rates)).max() < 1e-12, t


def test_odometry_known_too_late_to_interpolate_is_warned(caplog):
    from cfem_ros.core.run.inputs import odometry_input
    from cfem_ros.core.run.session import Session
    sim = Simulator(parse_scenario(_document({'motion': {'velocity': [SPEED, 0, 0]}})))
    session = Session(sim, rate_hz=100.0, duration=1.0, outputs=[])
    session.submit(odometry_input('aircraft', [0, 0, 0], [0, 0, 0, 1], [SPEED, 0, 0],
                                  [0, 0, 0], 'world', time=0.0))
    session.advance(0.02)   # on from the message at 0 without the next one
    late = odometry_input('aircraft', [SPEED * 0.05, 0, 1e-5], [0, 0, 0, 1], [SPEED, 0, 0],
                          [0, 0, 0], 'world', time=0.05)
    with caplog.at_level('WARNING', logger='cfem_ros'):
        session.submit(late)
    assert 'became known after the simulation had moved on' in caplog.text
    session.advance(0.04)
    # still extrapolated from the first message: straight and level (the cubic
    # to the late one would have descended 9e-6 m by now)
    assert np.allclose(sim.position[0], [SPEED * 0.04, 0, 0], rtol=0, atol=1e-12)
    session.advance(0.06)   # the late message took effect at its time
    assert sim.status == 'running', sim.message
    assert np.allclose(sim.position[0], [SPEED * 0.06, 0, 1e-5], rtol=0, atol=1e-12)


def test_odometry_stops_beyond_the_horizon_with_a_warning(caplog):
    from cfem_ros.core.engine.carrier import ODOMETRY_HORIZON
    from cfem_ros.core.run.session import Session
    rate = -G / SPEED
    aircraft = {'motion': {'velocity': [SPEED, 0, 0], 'angular_velocity': [0, rate, 0]}}
    sim = Simulator(parse_scenario(_document(aircraft)))
    session = Session(sim, rate_hz=100.0, duration=2.0, outputs=[])
    for item in _odometry_inputs(rate, 0.5):
        session.submit(item)
    with caplog.at_level('WARNING', logger='cfem_ros'):
        session.advance(0.5 + ODOMETRY_HORIZON - 0.01)
        assert 'no odometry' not in caplog.text
        session.advance(0.8)
    assert "no odometry for body 'aircraft' since t = 0.500000 s" in caplog.text
    v1, w1, p1 = sim.velocity[0].copy(), sim.rates[0].copy(), sim.position[0].copy()
    session.advance(1.0)
    assert np.abs(sim.velocity[0] - v1).max() < 1e-12
    assert np.abs(sim.rates[0] - w1).max() < 1e-12
    assert np.allclose(sim.position[0], p1 + 0.2 * v1, rtol=0, atol=1e-9)


def test_a_carrier_back_from_an_odometry_gap_takes_what_hangs_on_it_along(caplog):
    from cfem_ros.core.run.session import Session, Sink as SessionSink
    rate = -G / SPEED
    aircraft = {'motion': {'velocity': [SPEED, 0, 0], 'angular_velocity': [0, rate, 0]}}
    sim = Simulator(parse_scenario(_document(aircraft)))
    before = []

    class Sink(SessionSink):
        def sample(self):
            if abs(sim.t - 0.8) < 1e-12:   # the sample at 0.8 s: before the message acts
                before.append((sim.position[0].copy(), *_relative(sim)))

        def events(self):
            pass

        def received(self, item, t):
            pass

    session = Session(sim, rate_hz=100.0, duration=1.5, outputs=[Sink()])
    # a 0.3 s dropout from 0.5 s: at constant velocity past the horizon, the
    # carrier is 0.5 g (0.2 s)^2 = 0.2 m off the pull-up when odometry resumes
    for item in _odometry_inputs(rate, 1.5):
        if not 0.5 < item.time < 0.8:
            session.submit(item)
    with caplog.at_level('WARNING', logger='cfem_ros'):
        session.advance(0.8)
    assert "no odometry for body 'aircraft' since t = 0.500000 s" in caplog.text
    carrier, position, quat = before[0]
    assert np.linalg.norm(sim.position[0] - carrier) > 0.1   # the carrier jumped back
    # the store jumped with it: the same pose in the carrier's frame
    after = _relative(sim)
    assert np.abs(after[0] - position).max() < 1e-12
    assert abs(abs(after[1] @ quat) - 1.0) < 1e-14
    # and the joint holds on: in position, and in velocity from then on
    session.advance(1.5)
    assert sim.status == 'running', sim.message
    assert sim.constraint_violation() < 1e-9
    assert np.allclose(sim.position[0], _pullup(1.5, rate)[0], rtol=0, atol=1e-6)


def test_odometry_is_refused_for_a_body_that_is_not_kinematic():
    from cfem_ros.core.run.inputs import apply_input, odometry_input
    sim = Simulator(parse_scenario(_document({'motion': {'velocity': [SPEED, 0, 0]}})))
    bad = odometry_input('store', [0, 0, 0], [0, 0, 0, 1], [0, 0, 0], [0, 0, 0], 'world')
    with pytest.raises(ValueError, match='not kinematic'):
        apply_input(sim, bad)
    skewed = odometry_input('aircraft', [0, 0, 0], [0, 0, 0, 2], [0, 0, 0], [0, 0, 0], 'world')
    with pytest.raises(ValueError, match='norm'):
        apply_input(sim, skewed)
    framed = odometry_input('aircraft', [0, 0, 0], [0, 0, 0, 1], [0, 0, 0], [0, 0, 0], 'map')
    with pytest.raises(ValueError, match='world frame'):
        apply_input(sim, framed)
