# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The paper's three cases, releases, inputs and start-up checks of the engine.

Bounds as in test_joints: 1e-6 for the motion, 1e-9 m for joint points,
1e-6 s for an angle-triggered release time.
"""

import logging
import pathlib

from cfem_ros import load_scenario, parse_scenario, Simulator
from crossings import (assert_same_location, assert_same_runs, joint_forces, rk4,
                       step_with_condition)
import numpy as np
import pytest
from reference import (axis_rotation, normalized_error, parallel_axis, PivotChain,
                       quat_matrix, torque_free)
from scipy.optimize import brentq as scipy_brentq
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'


def model(name, **overrides):
    return load_scenario(str(CONFIG / f'{name}.yaml'), **overrides)


def test_fixed_joint_spin_matches_the_composite_body_then_separates():
    m = model('fixed_joint_spin')
    sim = Simulator(m)
    a, b = m.bodies
    # the welded pair is one torque-free body about its CG at the origin
    composite = sum(parallel_axis(body.inertia, body.mass, body.position) for body in (a, b))
    times = np.linspace(0.0, 10.0, 21)
    rots, rates = torque_free(composite, np.eye(3), a.rates_body, times)
    moments = []
    for t, rot, w in zip(times, rots, rates):
        assert sim.advance_to(t)
        assert normalized_error(sim.position[0], rot @ a.position) < 1e-6
        assert normalized_error(sim.position[1], rot @ b.position) < 1e-6
        assert normalized_error(quat_matrix(sim.orientation[1]), rot) < 1e-6
        assert normalized_error(sim.rates[0], w) < 1e-6
        assert normalized_error(sim.rates[1], sim.rates[0]) < 1e-9   # rates equal
        if t < 10.0:
            # the weld's wrench on B is B's inverse dynamics
            omega = rot @ w
            alpha = rot @ np.linalg.solve(composite, -np.cross(w, composite @ w))
            r_b = rot @ b.position
            force = b.mass * (np.cross(alpha, r_b) + np.cross(omega, np.cross(omega, r_b)))
            inertia_b = rot @ b.inertia @ rot.T
            arm = rot @ (m.joints[0].anchor - b.position)
            moment = (inertia_b @ alpha + np.cross(omega, inertia_b @ omega)
                      - np.cross(arm, force))
            f_sim, t_sim = sim.joint_wrenches()
            assert normalized_error(f_sim[0], force, np.linalg.norm(force)) < 1e-6
            assert normalized_error(t_sim[0], moment, np.linalg.norm(moment)) < 1e-6
            moments.append(np.linalg.norm(moment))
    assert min(moments) > 1e-3
    assert sim.events == [{'event': 'release', 'joint': 'weld', 'time': 10.0, 'cause': 'time'}]
    # after the release B, the light body, leaves the welded motion; A hardly
    # does (paper Figs. 3-4): compare both with the pair still welded
    later = np.linspace(10.5, 20.0, 20)
    _, welded = torque_free(composite, rots[-1], rates[-1], np.concatenate([[10.0], later]))
    for t, w in zip(later, welded[1:]):
        assert sim.advance_to(t)
        off_a = np.linalg.norm(sim.rates[0] - w)
        off_b = np.linalg.norm(sim.rates[1] - w)
        assert off_a < 0.05 * off_b and off_b > 0.5
    # each body now tumbles torque-free: its angular momentum is constant
    momenta = [quat_matrix(sim.orientation[i]) @ body.inertia @ sim.rates[i]
               for i, body in enumerate((a, b))]
    assert sim.advance_to(25.0)
    for i, body in enumerate((a, b)):
        now = quat_matrix(sim.orientation[i]) @ body.inertia @ sim.rates[i]
        assert normalized_error(now, momenta[i], np.linalg.norm(momenta[i])) < 1e-9


def test_double_pendulum_keeps_its_joint_points_together():
    m = model('double_pendulum')
    sim = Simulator(m)
    gaps = []
    for t in np.linspace(0.1, 10.0, 100):
        assert sim.advance_to(t)
        on_parent, on_child = sim.joint_points()
        gaps.append(np.linalg.norm(on_child - on_parent, axis=1).max())
    assert max(gaps) < 1e-9
    assert sim.max_violation < 1e-9
    # it really moves: B swings through metres, and sideways (y) too
    assert np.ptp(sim.position[2]) > 0.5 and abs(sim.position[2][1]) > 1e-3


def store_reference(m):
    """Exact store motion: pendulum about the pivot, then free flight."""
    body, joint = m.bodies[1], m.joints[0]
    chain = PivotChain(body.mass, body.inertia, np.eye(3), body.position, joint.anchor,
                       [joint.triad[0]], m.gravity)

    def ten_degrees(_, s):
        return abs(s[0]) - np.radians(10.0)
    ten_degrees.terminal = True
    solution = chain.solve(np.zeros(1), [0.0, 1.0], events=ten_degrees)
    t_release = solution.t_events[0][0]
    q, qd = solution.y_events[0][0][:1], solution.y_events[0][0][1:]
    cg, rot, rates, _, _ = chain.state(q, qd)
    omega = rot @ rates
    velocity = np.cross(omega, cg - joint.anchor)

    def after(t):
        tau = t - t_release
        rot_t = axis_rotation(omega / np.linalg.norm(omega), np.linalg.norm(omega) * tau) @ rot
        return cg + velocity * tau + 0.5 * m.gravity * tau ** 2, rot_t, rates
    return t_release, after


def test_store_release_time_and_free_flight_are_exact():
    m = model('store_separation')
    t_release, after = store_reference(m)
    sim = Simulator(m)
    assert sim.advance_to(1.5)
    (event,) = sim.events
    assert event['cause'] == 'angle' and event['joint'] == 'pivot'
    assert abs(event['time'] - t_release) < 1e-6
    assert 0.25 < t_release < 0.30     # the paper's "about 0.27 s"
    cg, rot, rates = after(1.5)
    assert normalized_error(sim.position[1], cg) < 1e-6
    assert normalized_error(quat_matrix(sim.orientation[1]), rot) < 1e-6
    assert normalized_error(sim.rates[1], rates) < 1e-6


def test_store_pitch_is_parabolic_then_linear_in_the_symmetry_plane():
    m = model('store_separation')
    sim = Simulator(m)
    times = np.arange(0, 151) * 0.01
    pitch, lateral = [], []
    for t in times:
        assert sim.advance_to(t)
        q = sim.orientation[1]
        assert abs(q[0]) < 1e-12 and abs(q[2]) < 1e-12    # roll and yaw stay zero
        pitch.append(2 * np.arctan2(q[1], q[3]))            # unwrapped, past -90 deg
        lateral.append(sim.position[1][1])
    assert np.abs(lateral).max() < 1e-12                    # no y motion
    t_release = sim.events[0]['time']
    curvature = np.diff(pitch, 2) / 0.01 ** 2
    before = curvature[times[1:-1] < t_release - 0.01]
    after = curvature[times[1:-1] > t_release + 0.01]
    assert np.all(before < -3.0)            # nose down, accelerating: a parabola
    assert np.abs(after).max() < 1e-6       # free tumbling: pitch linear in time
    assert pitch[-1] < -np.radians(90)      # through the pitch singularity without trouble


def test_command_release_frees_the_joint_at_once():
    m = model('store_separation')
    sim = Simulator(m)
    assert sim.advance_to(0.1)
    event = sim.release('pivot')
    assert event == {'event': 'release', 'joint': 'pivot', 'time': 0.1, 'cause': 'command'}
    rates = sim.rates[1].copy()
    assert sim.advance_to(0.5)
    assert normalized_error(sim.rates[1], rates) < 1e-12     # no more torque
    with pytest.raises(ValueError, match='already released'):
        sim.release('pivot')
    with pytest.raises(ValueError, match='unknown joint'):
        sim.release('hook')


def free_body(**extra):
    doc = {'gravity': [0, 0, 0], 'bodies': {'box': {
        'mass': 4.0, 'inertia': [1.0, 2.0, 2.5], **extra}}}
    return Simulator(parse_scenario(doc))


def test_constant_world_force_moves_a_free_body_as_f_t2_over_2m():
    sim = free_body()
    force = np.array([3.0, -2.0, 8.0])
    sim.set_wrench('box', force, [0, 0, 0])
    assert sim.advance_to(2.0)
    assert normalized_error(sim.position[0], force * 2.0 ** 2 / (2 * 4.0)) < 1e-12


def test_body_axis_force_turns_with_the_body():
    spin = 2.0
    sim = free_body(angular_velocity=[0, 0, spin])
    sim.set_wrench('box', [1.0, 0, 0], [0, 0, 0], body_axes=True)
    t = 1.3
    assert sim.advance_to(t)
    # a(t) = F/m (cos wt, sin wt, 0) integrated twice
    f_m = 1.0 / 4.0
    expected = f_m / spin * np.array([(1 - np.cos(spin * t)) / spin,
                                      t - np.sin(spin * t) / spin, 0.0])
    assert normalized_error(sim.position[0], expected) < 1e-9


def test_inconsistent_initial_velocity_is_projected_with_a_warning(caplog):
    doc = yaml.safe_load((CONFIG / 'joints' / 'slider.yaml').read_text())
    doc['bodies']['block']['velocity'] = [1.0, 2.0, 3.0]
    doc['bodies']['block']['angular_velocity'] = [0.5, 0, 0]
    with caplog.at_level(logging.WARNING, logger='cfem_ros'):
        sim = Simulator(parse_scenario(doc))
    axis = sim.model.joints[0].triad[0]
    v0 = np.array([1.0, 2.0, 3.0])
    assert normalized_error(sim.velocity[1], (v0 @ axis) * axis) < 1e-12
    assert normalized_error(sim.rates[1], np.zeros(3)) < 1e-12
    assert 'block' in caplog.text and 'corrected' in caplog.text


def test_redundant_hinges_move_exactly_and_share_the_loads(caplog):
    single = yaml.safe_load((CONFIG / 'joints' / 'hinge.yaml').read_text())
    double = yaml.safe_load((CONFIG / 'joints' / 'hinge.yaml').read_text())
    double['joints']['pin2'] = dict(double['joints']['pin'], anchor=[0, 0, 0])
    with caplog.at_level(logging.WARNING, logger='cfem_ros'):
        sim2 = Simulator(parse_scenario(double))
        sim1 = Simulator(parse_scenario(single))
        for t in (0.5, 1.0):
            assert sim1.advance_to(t) and sim2.advance_to(t)
            assert normalized_error(sim2.position, sim1.position) < 1e-12
            f1, m1 = sim1.joint_wrenches()
            f2, m2 = sim2.joint_wrenches()
            assert normalized_error(f2.sum(axis=0), f1[0], np.linalg.norm(f1[0])) < 1e-9
            assert normalized_error(f2[0], f2[1], np.linalg.norm(f1[0])) < 1e-9  # least norm
    assert sum('more than once' in r.getMessage() for r in caplog.records) == 1
    assert sim2.dof == 1


def test_distance_trigger_releases_the_slider_at_the_exact_time():
    doc = yaml.safe_load((CONFIG / 'joints' / 'slider.yaml').read_text())
    doc['joints']['rail']['release'] = {'distance': 0.1}
    sim = Simulator(parse_scenario(doc))
    axis = sim.model.joints[0].triad[0]
    accel = abs(sim.model.gravity @ axis)
    t_release = np.sqrt(2 * 0.1 / accel)          # 0.1 = a t^2 / 2
    assert sim.advance_to(0.5)
    (event,) = sim.events
    assert event['cause'] == 'distance'
    assert abs(event['time'] - t_release) < 1e-9
    # free fall afterwards from the release state
    tau = 0.5 - t_release
    v = accel * t_release * np.sign(sim.model.gravity @ axis) * axis
    p = sim.model.bodies[1].position + 0.5 * accel * t_release ** 2 * (v / np.linalg.norm(v))
    expected = p + v * tau + 0.5 * sim.model.gravity * tau ** 2
    assert normalized_error(sim.position[1], expected) < 1e-9


def test_force_trigger_releases_the_pendulum_when_the_pin_load_reaches_it():
    m = load_scenario(str(CONFIG / 'joints' / 'hinge.yaml'))
    body, joint = m.bodies[1], m.joints[0]
    chain = PivotChain(body.mass, body.inertia, np.eye(3), body.position, joint.anchor,
                       [joint.triad[0]], m.gravity)
    limit = 40.0                                  # N; the weight is 19.6 N

    def load_reaches(_, s):
        return np.linalg.norm(chain.state(s[:1], s[1:])[3]) - limit
    load_reaches.terminal = True
    solution = chain.solve(np.zeros(1), [0.0, 2.0], events=load_reaches)
    t_release = solution.t_events[0][0]
    doc = yaml.safe_load((CONFIG / 'joints' / 'hinge.yaml').read_text())
    doc['joints']['pin']['release'] = {'force': limit}
    sim = Simulator(parse_scenario(doc))
    assert sim.advance_to(1.0)
    (event,) = sim.events
    assert event['cause'] == 'force'
    assert abs(event['time'] - t_release) < 1e-6


def hinge(release):
    """Return the hinge pendulum of config/joints with a release condition on its pin."""
    doc = yaml.safe_load((CONFIG / 'joints' / 'hinge.yaml').read_text())
    doc['joints']['pin']['release'] = release
    return parse_scenario(doc)


def test_angle_condition_is_located_in_compiled_code_as_in_python():
    sim = Simulator(hinge({'angle_deg': 30.0}))
    h = step_with_condition(sim, 1.0)
    (s, joints, causes), stroke = assert_same_location(sim, h)
    assert (joints, causes, stroke) == ([0], ['angle'], None)
    assert 0.0 < s < h
    # scipy's brentq on the angle of the step's RK4 map, computed from rotation matrices

    def excess(u):
        rot = quat_matrix(rk4(sim, sim.y, u)[6 * sim.n + 4:6 * sim.n + 8])
        return np.arccos((np.trace(rot) - 1.0) / 2.0) - np.radians(30.0)
    # angle rounding ~1e-16 rad at ~2 rad/s, plus the 1e-15 s tolerance
    assert abs(scipy_brentq(excess, 0.0, h, xtol=1e-15) - s) < 1e-13
    assert_same_runs(sim.model, [0.2, 0.5, 1.0])


def test_force_condition_is_located_in_compiled_code_as_in_python():
    sim = Simulator(hinge({'force': 40.0}))
    h = step_with_condition(sim, 1.0)
    (s, joints, causes), stroke = assert_same_location(sim, h)
    assert (joints, causes, stroke) == ([0], ['force'], None)
    assert 0.0 < s < h

    def excess(u):
        return np.linalg.norm(joint_forces(sim, rk4(sim, sim.y, u))[0]) - 40.0
    # the load's rounding, ~1e-14 N, at a rate of ~100 N/s
    assert abs(scipy_brentq(excess, 0.0, h, xtol=1e-15) - s) < 1e-13
    assert_same_runs(sim.model, [0.2, 0.5, 1.0])


def test_two_conditions_reached_at_the_same_time_release_both_in_one_step():
    # two identical pendulums, one on a distance, one on an angle: the angle first,
    # then a tie of two angles whose excesses are the same numbers
    doc = yaml.safe_load((CONFIG / 'joints' / 'hinge.yaml').read_text())
    doc['bodies']['twin'] = dict(doc['bodies']['rod'])
    doc['joints']['pin']['release'] = {'angle_deg': 30.0, 'distance': 1.0}
    doc['joints']['twin_pin'] = dict(doc['joints']['pin'], child='twin',
                                     release={'angle_deg': 30.0})
    sim = Simulator(parse_scenario(doc))
    h = step_with_condition(sim, 1.0)
    (s, joints, causes), stroke = assert_same_location(sim, h)
    assert (joints, causes, stroke) == ([0, 1], ['angle', 'angle'], None)
    assert 0.0 < s < h
    sim = assert_same_runs(sim.model, [0.5])
    assert [(e['joint'], e['cause']) for e in sim.events] == [('pin', 'angle'),
                                                              ('twin_pin', 'angle')]
    assert sim.events[0]['time'] == sim.events[1]['time']
