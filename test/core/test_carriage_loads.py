# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Carriage loads on redundant hooks, split by the hooks' compliance (SPEC section 7)."""

import logging
import math

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.scenario.parse import parse_scenario
import numpy as np
import pytest
from reference import normalized_error
from scipy.integrate import solve_ivp

MASS = 907.1848
INERTIA = [27.1164, 488.0944, 488.0944]   # the Eglin store's
HOOKS = np.array([[0.381, 0.0, -0.25], [-0.381, 0.0, -0.25]])   # from the CG, z down
G = 9.80665


def two_hooks(compliance=(None, None), gravity=(0.0, 0.0, G)):
    """Return the store on two ball hooks of a fixed pylon (CG at the origin)."""
    joints = {}
    for name, anchor, c in zip(('fwd_hook', 'aft_hook'), HOOKS, compliance):
        joints[name] = {'type': 'ball', 'parent': 'pylon', 'child': 'store',
                        'anchor': anchor.tolist()}
        if c is not None:
            joints[name]['compliance'] = list(c)
    doc = {'gravity': list(gravity), 'dt': 0.001,
           'bodies': {'pylon': {'fixed': True},
                      'store': {'mass': MASS, 'inertia': INERTIA}},
           'joints': joints}
    return parse_scenario(doc, source='two_hooks.yaml')


def hook_forces(model):
    """Return the hooks' forces on the store at t = 0 (world axes, N), (2, 3)."""
    sim = Simulator(model)
    return sim.joint_wrenches()[0]


def penalty_springs(compliance, gravity, t_end=0.04):
    """
    Hold the same store at its hooks by stiff springs and dashpots; integrate until static.

    An independent model: the store is a free rigid body in the x-z plane
    (x, z, pitch), each hook a spring of stiffness 1 / compliance per
    world direction between the store's hook point and the pylon's,
    damped near critically; DOP853 integrates it from rest at the
    undeflected position. Stiff: the deflections (micrometres) turn the
    store by about 1e-5 rad, which moves the loads by less than 1e-5 of
    their size. Returns the spring forces on the store at the
    end (world axes, N), (2, 3), and the largest speed then (m/s).
    """
    stiffness = [np.array([1.0 / c[0], 1.0 / c[2]]) for c in compliance]
    damping = [2.0 * np.sqrt(k * MASS) for k in stiffness]   # critical, per hook alone
    arms = HOOKS[:, [0, 2]]
    iyy = INERTIA[1]
    g = np.array([gravity[0], gravity[2]])

    def turn(theta):
        # pitch about +y: x' = x cos + z sin, z' = -x sin + z cos
        c, s = math.cos(theta), math.sin(theta)
        return np.array([[c, s], [-s, c]])

    def forces(state):
        x, z, theta, vx, vz, q = state
        rot = turn(theta)
        out = []
        for i in range(2):
            r = rot @ arms[i]
            point = np.array([x, z]) + r
            velocity = np.array([vx, vz]) + q * np.array([r[1], -r[0]])
            out.append((r, -stiffness[i] * (point - arms[i]) - damping[i] * velocity))
        return out

    def rhs(_, state):
        total, moment = MASS * g, 0.0
        for r, f in forces(state):
            total = total + f
            moment += r[1] * f[0] - r[0] * f[1]   # y component of r x f (x-z plane)
        return np.concatenate([state[3:], total / MASS, [moment / iyy]])

    sol = solve_ivp(rhs, (0.0, t_end), np.zeros(6), method='DOP853', rtol=1e-10,
                    atol=1e-14)
    assert sol.success
    end = sol.y[:, -1]
    spring = np.array([[f[0], 0.0, f[1]] for _, f in forces(end)])
    return spring, float(np.max(np.abs(end[3:5])))


@pytest.mark.parametrize('compliance', [
    ([2e-9, 1e-9, 1.5e-9], [1e-9, 1e-9, 1e-9]),
    ([1e-9, 1e-9, 1e-9], [4e-9, 2e-9, 1e-9]),
])
def test_hook_loads_match_stiff_springs_integrated_until_static(compliance):
    # a 10 deg nose-down pylon: gravity along the hooks' line loads the redundant direction
    gravity = (G * math.sin(math.radians(10)), 0.0, G * math.cos(math.radians(10)))
    cfem = hook_forces(two_hooks(compliance, gravity))
    springs, speed = penalty_springs(compliance, gravity)
    assert speed < 1e-8   # static: m/s, against deflections of micrometres
    # hook loads on the store in CFEM are the springs' on the store
    scale = np.abs(springs).max()
    assert normalized_error(cfem, springs, scale) < 1e-4
    # the redundant (x) direction in particular, relative to its own size
    assert normalized_error(cfem[:, 0], springs[:, 0], np.abs(springs[:, 0]).max()) < 1e-4


@pytest.mark.parametrize('c1, c2', [(1e-8, 1e-8), (2e-8, 1e-8), (1e-9, 3e-8)])
def test_axial_split_is_that_of_two_springs(c1, c2):
    # a rigid body on two axial springs: F1 = F k1 / (k1 + k2) = F c2 / (c1 + c2)
    load = MASS * 3.0
    forces = hook_forces(two_hooks(([c1, 1e-8, 1e-8], [c2, 1e-8, 1e-8]), (3.0, 0.0, 0.0)))
    expected = -load * np.array([c2, c1]) / (c1 + c2)
    assert normalized_error(forces[:, 0], expected, load) < 1e-9


def test_without_compliance_the_split_stays_least_norm():
    forces = hook_forces(two_hooks((None, None), (3.0, 0.0, G)))
    assert normalized_error(forces[:, 0], [-MASS * 1.5, -MASS * 1.5], MASS * 3.0) < 1e-9


def test_compliance_changes_the_split_not_the_motion():
    gravity = (2.0, 0.0, G)
    runs = []
    for compliance in ((None, None), ([5e-9, 1e-8, 1e-8], [1e-8, 1e-8, 1e-8])):
        doc_model = two_hooks(compliance, gravity)
        # release the forward hook at 0.05 s: the store then swings on the aft one
        joints = tuple(j if j.name != 'fwd_hook' else
                       type(j)(**{**j.__dict__, 'release': type(j.release)(time=0.05)})
                       for j in doc_model.joints)
        sim = Simulator(type(doc_model)(**{**doc_model.__dict__, 'joints': joints}))
        before = sim.joint_wrenches()[0]
        assert sim.advance_to(0.2), sim.message
        runs.append((before, sim.y.copy(), sim.events))
    (free_split, y_plain, events_plain), (weighted, y_weighted, events_weighted) = runs
    assert abs(weighted[0, 0] / weighted[1, 0] - 2.0) < 1e-9   # forward hook twice as soft
    assert abs(free_split[0, 0] / free_split[1, 0] - 1.0) < 1e-9
    # the same resultant on the store, the same motion
    assert normalized_error(weighted.sum(axis=0), free_split.sum(axis=0), MASS * G) < 1e-12
    assert normalized_error(y_weighted, y_plain, 1.0) < 1e-12
    assert events_plain == events_weighted


@pytest.mark.parametrize('value, problem', [
    ([1e-8, 1e-8], 'a list of 3 numbers'),
    ([1e-8, 0.0, 1e-8], '3 numbers > 0'),
    ([1e-8, 'x', 1e-8], 'a number'),
])
def test_bad_compliance_is_refused_with_its_key(value, problem):
    with pytest.raises(ScenarioError) as err:
        two_hooks((value, None))
    assert 'joints.fwd_hook.compliance' in str(err.value) and problem in str(err.value)


def test_hooks_with_compliance_are_noted_not_warned(caplog):
    stiff = [1e-8, 1e-8, 1e-8]
    with caplog.at_level(logging.INFO, logger='cfem_ros'):
        Simulator(two_hooks((stiff, stiff)))
        Simulator(two_hooks((stiff, None)))   # one hook without: the split is partly a guess
    (noted,), (warned,) = ([r for r in caplog.records if r.levelno == level]
                           for level in (logging.INFO, logging.WARNING))
    assert noted.getMessage().startswith('the joints aft_hook, fwd_hook constrain 1 direction')
    assert 'declared compliance' in noted.getMessage()
    assert warned.getMessage().startswith('the joints aft_hook, fwd_hook constrain 1 direction')


def test_only_the_joints_of_the_redundant_rows_are_named(caplog):
    doc = {'gravity': [0.0, 0.0, G], 'dt': 0.001,
           'bodies': {'aircraft': {'fixed': True},
                      'pylon': {'mass': 50.0, 'inertia': [1.0, 1.0, 1.0]},
                      'store': {'mass': MASS, 'inertia': INERTIA}},
           'joints': {'mount': {'type': 'fixed', 'parent': 'aircraft', 'child': 'pylon',
                                'anchor': [0.0, 0.0, -0.5]}}}
    for name, anchor in zip(('fwd_hook', 'aft_hook'), HOOKS):
        doc['joints'][name] = {'type': 'ball', 'parent': 'pylon', 'child': 'store',
                               'anchor': anchor.tolist()}
    with caplog.at_level(logging.WARNING, logger='cfem_ros'):
        Simulator(parse_scenario(doc, source='mounted_hooks.yaml'))
    (warned,) = caplog.records
    assert warned.getMessage().startswith('the joints aft_hook, fwd_hook constrain 1 direction')
