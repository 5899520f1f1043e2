# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The linear-time tree solve against the whole Lagrange-multiplier system.

A tree of every joint type (some joints written child-to-parent, a floating
pair, a body without joints) is put in a state that breaks its joints a
little, as integration drift does. At that state the accelerations and the
joint loads of the engine must equal those of [M -J^T; J 0] [a; lambda] =
[f; b] assembled and solved here with numpy (mass matrix, gyroscopic and
external loads computed here; J and b are the engine's rows). Bound: 1e-9
relative, a thousand times the rounding seen (about 1e-13).
"""

import logging

from cfem_ros import parse_scenario, Simulator
from cfem_ros.core.native import kernel
import numpy as np
from reference import quat_matrix

KINDS = ('hinge', 'universal', 'ball', 'slider', 'planar', 'cylindrical', 'fixed')


def tree_scenario():
    """Fourteen bodies in a tree off the ground, a floating pair and a lone body."""
    rng = np.random.default_rng(7)
    bodies = {'G': {'fixed': True}}
    joints = {}
    for i, kind in enumerate(KINDS * 2):
        name = f'b{i}'
        bodies[name] = {
            'mass': float(1 + rng.random()),
            'inertia': [1.0 + 0.5 * rng.random(), 1.2, 1.4 + 0.3 * rng.random()],
            'position': [float(i), 0.3 * i, -0.5 * i],
            'angular_velocity': [0.1 * i, -0.2, 0.3]}
        parent = 'G' if i == 0 else (f'b{i - 1}' if i % 5 else 'b0')
        parent, child = (parent, name) if i % 3 or parent == 'G' else (name, parent)
        axis = np.array([0.3, 1.0, 0.2])
        joints[f'j{i}'] = {'type': kind, 'parent': parent, 'child': child,
                           'anchor': [i - 0.5, 0.3 * i - 0.1, -0.5 * i + 0.2],
                           'axis': axis.tolist()}
        if kind == 'universal':
            joints[f'j{i}']['axis2'] = np.cross(axis, [1.0, 0.0, 0.0]).tolist()
    bodies['f1'] = {'mass': 2.0, 'inertia': [1, 2, 3], 'position': [0, 5, 0]}
    bodies['f2'] = {'mass': 2.0, 'inertia': [1, 2, 3], 'position': [1, 5, 0],
                    'angular_velocity': [1, 2, 3]}
    joints['jf'] = {'type': 'hinge', 'parent': 'f2', 'child': 'f1', 'anchor': [0.5, 5, 0],
                    'axis': [0, 0, 1]}
    bodies['lone'] = {'mass': 3.0, 'inertia': [1, 2, 3], 'position': [0, -5, 0],
                      'angular_velocity': [0.5, 0, 1]}
    return parse_scenario({'name': 'tree', 'duration': 1, 'dt': 0.001, 'bodies': bodies,
                           'joints': joints})


def kkt_solution(sim, y):
    """Accelerations (n, 6) and joint forces on children, from the whole system."""
    n = sim.n
    quat, rates = y[6 * n:10 * n].reshape(n, 4), y[10 * n:].reshape(n, 3)
    mass = np.zeros((6 * n, 6 * n))
    force = np.zeros(6 * n)
    for i, body in enumerate(sim.model.bodies):
        if body.fixed:
            continue
        rot = quat_matrix(quat[i] / np.linalg.norm(quat[i]))
        inertia = rot @ body.inertia @ rot.T
        omega = rot @ rates[i]
        mass[6 * i:6 * i + 3, 6 * i:6 * i + 3] = body.mass * np.eye(3)
        mass[6 * i + 3:6 * i + 6, 6 * i + 3:6 * i + 6] = inertia
        held = sim._loads[i]
        external = np.stack([held[kernel.LOADS.span('H_FORCE')],
                             held[kernel.LOADS.span('H_TORQUE')]])
        if held[kernel.LOADS.H_AXES] > 0.0:     # given in body axes
            external = external @ rot.T
        force[6 * i:6 * i + 3] = body.mass * sim.gravity + external[0]
        force[6 * i + 3:6 * i + 6] = external[1] - np.cross(omega, inertia @ omega)
    top = sim.topology
    jac, _ = top.jacobian(y, n)
    rhs = kernel.views(top.system)['rhs'].copy()
    free = np.flatnonzero(np.repeat(sim.free, 6))
    m = top.m
    system = np.zeros((len(free) + m, len(free) + m))
    system[:len(free), :len(free)] = mass[np.ix_(free, free)]
    system[:len(free), len(free):] = -jac[:, free].T
    system[len(free):, :len(free)] = jac[:, free]
    solution = np.linalg.solve(system, np.concatenate([force[free], rhs]))
    acc = np.zeros(6 * n)
    acc[free] = solution[:len(free)]
    lam = solution[len(free):]
    forces = np.zeros((len(sim.model.joints), 3))
    for r in np.flatnonzero(top.translation):
        b = top.rows_i[r, 1]
        forces[top.joint[r]] += lam[r] * jac[r, 6 * b:6 * b + 3]
    return acc.reshape(n, 6), forces


def test_tree_solve_equals_the_whole_system(caplog):
    caplog.set_level(logging.ERROR)
    sim = Simulator(tree_scenario())
    assert sim.topology.dense == 0
    sim.set_wrench('b3', [1.0, 2.0, 3.0], [4.0, 5.0, 6.0])
    sim.set_wrench('b9', [0.5, 0.0, -1.0], [0.0, 1.0, 0.0], body_axes=True)
    assert sim.advance_to(0.3), sim.message
    rng = np.random.default_rng(3)
    y = sim.y.copy()
    n = sim.n
    y[:3 * n] += 1e-4 * rng.standard_normal(3 * n)            # joints drifted apart
    y[3 * n:6 * n] += 1e-3 * rng.standard_normal(3 * n)       # and moving apart
    dy = sim.derivative(y)
    forces, _, _ = sim.sampling.joint_loads(y)
    expected_acc, expected_forces = kkt_solution(sim, y)
    quat = y[6 * n:10 * n].reshape(n, 4)
    alpha_world = np.array([quat_matrix(q / np.linalg.norm(q)) @ a
                            for q, a in zip(quat, dy[10 * n:].reshape(n, 3))])
    acc = np.concatenate([dy[3 * n:6 * n].reshape(n, 3), alpha_world], axis=1)
    scale = np.abs(expected_acc).max()
    assert np.abs(acc - expected_acc).max() <= 1e-9 * scale
    assert np.abs(forces - expected_forces).max() <= 1e-9 * np.abs(expected_forces).max()


def test_closed_loop_falls_back_to_the_whole_system(caplog):
    """A hanging loop of two links (three balls): the dense form, joints kept together."""
    loop = {'name': 'loop', 'duration': 1, 'dt': 0.001, 'bodies': {
        'G': {'fixed': True},
        'a': {'mass': 1.0, 'inertia': [1, 1, 1], 'position': [0.3, 0, -0.4]},
        'b': {'mass': 1.0, 'inertia': [1, 1, 1], 'position': [0.9, 0, -0.4]}},
        'joints': {
            'j1': {'type': 'ball', 'parent': 'G', 'child': 'a', 'anchor': [0, 0, 0]},
            'j2': {'type': 'ball', 'parent': 'a', 'child': 'b', 'anchor': [0.6, 0, -0.8]},
            'j3': {'type': 'ball', 'parent': 'b', 'child': 'G', 'anchor': [1.2, 0, 0]}}}
    caplog.set_level(logging.ERROR)
    sim = Simulator(parse_scenario(loop))
    assert sim.topology.dense > 0 and sim.topology.m == 9
    sim.set_wrench('a', [0.0, 5.0, 0.0], [0.0, 0.0, 0.0])
    assert sim.advance_to(0.5), sim.message
    on_a, on_b = sim.joint_points()
    assert np.abs(on_a - on_b).max() < 1e-6
    assert np.abs(sim.position[1:, 1]).max() > 1e-2   # it did swing out of its plane


def test_sample_outputs_match_the_separate_accessors():
    """One kernel call for a sample gives what the accessors give one by one."""
    sim = Simulator(tree_scenario())
    sim.advance_to(0.05)
    for _ in range(2):
        values = sim.outputs()
        n, active = sim.n, list(sim.active_joints)
        assert active == list(np.flatnonzero(sim.active))
        bodies = values[:13 * n].reshape(n, 13)
        np.testing.assert_array_equal(bodies[:, 0:3], sim.position)
        np.testing.assert_array_equal(bodies[:, 3:7], sim.orientation)
        np.testing.assert_allclose(bodies[:, 7:10], sim.velocity_body(), rtol=0, atol=1e-12)
        np.testing.assert_array_equal(bodies[:, 10:13], sim.rates)
        force, moment = sim.joint_wrenches()
        loads = values[13 * n:].reshape(len(active), 6)
        np.testing.assert_allclose(loads[:, :3], force[active], rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(loads[:, 3:], moment[active], rtol=1e-12, atol=1e-9)
        sim.release(active[0])
    assert len(sim.active_joints) == len(active) - 1
