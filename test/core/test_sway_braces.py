# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Sway braces (SPEC section 11) against statics, spring-mass solutions and linear roll dynamics.

The store is the Eglin store on two ball hooks 0.25 m above its CG (z down),
with four pads 35 deg either side of its top: the statics of the free body
(numpy's linear solve), the exact motion of a mass pushed by preloaded
springs (the instants each pad lets go and touches again), and the roll of
a store whose pads' preloads differ a little, against the linearised roll
dynamics about the hook line.
"""

import copy
import math

from cfem_ros import cli
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.scenario.parse import parse_scenario
import numpy as np
import pytest

MASS = 907.1848
INERTIA = [27.1164, 488.0944, 488.0944]
G = 9.80665
HOOKS = np.array([[0.381, 0.0, -0.25], [-0.381, 0.0, -0.25]])   # from the CG, z down
RADIUS = 0.25
SIDE = math.radians(35.0)
#: The pads: station x, side (-1 left, +1 right); points on the skin, pushing toward the axis.
PADS = [(0.45, -1), (0.45, 1), (-0.45, -1), (-0.45, 1)]
NAMES = ['fwd_left', 'fwd_right', 'aft_left', 'aft_right']


def pad(x, side):
    point = [x, side * RADIUS * math.sin(SIDE), -RADIUS * math.cos(SIDE)]
    direction = [0.0, -side * math.sin(SIDE), math.cos(SIDE)]
    return point, direction


def store_on_hooks(preloads=(2000.0,) * 4, stiffness=5.0e6, damping=0.0, dt=0.001):
    """Return the scenario document: the store on two ball hooks and four braces."""
    braces = []
    for name, (x, side), preload in zip(NAMES, PADS, preloads):
        point, direction = pad(x, side)
        braces.append({'name': name, 'body': 'store', 'carrier': 'pylon', 'point': point,
                       'direction': direction, 'preload': preload, 'stiffness': stiffness,
                       'damping': damping})
    joints = {name: {'type': 'ball', 'parent': 'pylon', 'child': 'store',
                     'anchor': anchor.tolist()}
              for name, anchor in zip(('fwd_hook', 'aft_hook'), HOOKS)}
    return {'gravity': [0, 0, G], 'dt': dt, 'duration': 1.0,
            'bodies': {'pylon': {'fixed': True},
                       'store': {'mass': MASS, 'inertia': INERTIA,
                                 'shape': {'cylinder': [RADIUS, 2.5]}}},
            'joints': joints, 'sway_braces': braces}


def test_hook_and_brace_loads_at_rest_are_the_statics_and_the_store_stays_put():
    preloads = (2000.0, 2000.0, 3000.0, 3000.0)   # the aft pads harder: the hooks share unevenly
    sim = Simulator(parse_scenario(store_on_hooks(preloads), source='braces.yaml'))
    brace_loads = sim.applied_loads()
    assert [s for _, s in sim.applied_sources] == NAMES
    # each brace pushes its preload along its direction, at its point
    pushes = []
    for (x, side), preload, load in zip(PADS, preloads, brace_loads):
        point, direction = pad(x, side)
        force = preload * np.array(direction)
        pushes.append((np.array(point), force))
        np.testing.assert_allclose(load[:3], force, rtol=0, atol=1e-9)
        np.testing.assert_allclose(load[3:], np.cross(point, force), rtol=0, atol=1e-9)
    # the free body: hook forces f1, f2 (6 unknowns) balance weight and pushes; the hooks
    # share the load along their line equally (least norm, no compliance given); the
    # roll equation holds by the pads' symmetry and is checked after
    weight = np.array([0.0, 0.0, MASS * G])
    applied = weight + sum(f for _, f in pushes)
    moment = sum(np.cross(p, f) for p, f in pushes)
    rows, rhs = [], []
    for k in range(3):   # sum of forces
        row = np.zeros(6)
        row[k] = row[3 + k] = 1.0
        rows.append(row)
        rhs.append(-applied[k])
    arms = [np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]]) for r in HOOKS]
    for k in (1, 2):   # pitch and yaw moments about the CG
        rows.append(np.concatenate([arms[0][k], arms[1][k]]))
        rhs.append(-moment[k])
    rows.append(np.array([1.0, 0, 0, -1.0, 0, 0]))
    rhs.append(0.0)
    hooks = np.linalg.solve(np.array(rows), np.array(rhs)).reshape(2, 3)
    roll = moment[0] + sum(np.cross(r, f)[0] for r, f in zip(HOOKS, hooks))
    assert abs(roll) < 1e-9
    np.testing.assert_allclose(sim.joint_wrenches()[0], hooks, rtol=0, atol=1e-6)
    assert np.max(np.abs(hooks)) > 5e3   # the hooks carry weight and preloads
    start = sim.y.copy()
    assert sim.advance_to(1.0), sim.message
    n = sim.n
    assert np.max(np.abs(sim.y[:3 * n] - start[:3 * n])) < 1e-9
    assert np.max(np.abs(sim.y[6 * n:10 * n] - start[6 * n:10 * n])) < 1e-9
    assert not [e for e in sim.events if e['event'] == 'brace_contact']


def pushed_store(braces, gravity=0.0, dt=2e-4, duration=0.1):
    """Return a free 100 kg block pushed down (+z) by braces on a fixed pylon, through its CG."""
    doc = {'gravity': [0, 0, gravity], 'dt': dt, 'duration': duration,
           'bodies': {'pylon': {'fixed': True, 'position': [0, 0, -1.0]},
                      'store': {'mass': 100.0, 'inertia': [2.0, 3.0, 4.0],
                                'shape': {'box': [1.0, 0.4, 0.4]}}},
           'sway_braces': [{'name': name, 'body': 'store', 'carrier': 'pylon',
                            'point': [0, 0, -0.2], 'direction': [0, 0, 1],
                            'preload': preload, 'stiffness': k}
                           for name, preload, k in braces]}
    return Simulator(parse_scenario(doc, source='pushed.yaml'))


def brace_events(sim):
    return [(e['brace'], e['contact'], e['time']) for e in sim.events
            if e['event'] == 'brace_contact']


def test_each_pad_lets_go_when_the_exact_spring_mass_solution_says():
    m, (p1, k1), (p2, k2) = 100.0, (1000.0, 1.0e5), (3000.0, 1.0e5)
    sim = pushed_store([('first', p1, k1), ('second', p2, k2)])
    assert sim.advance_to(0.1), sim.message
    # both pads: x = P / K (1 - cos w t) until x = p1 / k1, where the first lets go
    big_k, push = k1 + k2, p1 + p2
    w = math.sqrt(big_k / m)
    t1 = math.acos(1.0 - (p1 / k1) * big_k / push) / w
    x1, v1 = p1 / k1, push / big_k * w * math.sin(w * t1)
    # then x - p2 / k2 = A cos(w2 tau + phi); the second lets go where x = p2 / k2 again
    w2 = math.sqrt(k2 / m)
    phi = math.atan2(-v1 / w2, x1 - p2 / k2)
    tau = ((0.5 * math.pi - phi) % math.pi) / w2
    t2 = t1 + tau
    events = brace_events(sim)
    assert [(b, c) for b, c, _ in events] == [('first', False), ('second', False)]
    assert abs(events[0][2] - t1) < 1e-9 and abs(events[1][2] - t2) < 1e-9
    # free flight after: the speed the springs gave, no pad pulling
    speed = math.sqrt(v1 ** 2 + (k2 / m) * (x1 - p2 / k2) ** 2)
    assert abs(sim.velocity[1][2] - speed) < 1e-8
    assert np.all(sim.applied_loads() == 0.0)


def test_a_pad_touches_again_when_gravity_brings_the_store_back():
    # pushed away against gravity (-z): the pad lets go at x = P / k and the store flies
    # up and falls back onto it after 2 v / g
    m, p, k, g = 100.0, 3000.0, 1.0e5, 9.80665
    sim = pushed_store([('pad', p, k)], gravity=-g, duration=0.3)
    assert sim.advance_to(0.3), sim.message
    w, rest = math.sqrt(k / m), (p - m * g) / k
    t1 = math.acos(1.0 - (p / k) / rest) / w
    v1 = rest * w * math.sin(w * t1)
    events = brace_events(sim)
    assert [(b, c) for b, c, _ in events][:2] == [('pad', False), ('pad', True)]
    assert abs(events[0][2] - t1) < 1e-9
    assert abs(events[1][2] - (t1 + 2.0 * v1 / g)) < 1e-9


def test_the_carrier_takes_the_opposite_push():
    # a free carrier: the pads push the two bodies apart, momentum stays zero
    doc = store_on_hooks(damping=2.0e3)
    doc['gravity'] = [0, 0, 0]
    doc['joints'] = {}
    doc['bodies']['pylon'] = {'mass': 150.0, 'inertia': [5.0, 60.0, 60.0],
                              'position': [0, 0, -0.5]}
    doc['sway_braces'][0]['preload'] = 2600.0   # uneven: the store also turns
    sim = Simulator(parse_scenario(doc, source='free.yaml'))
    sources = sim.applied_sources
    assert sources[:2] == [('store', 'fwd_left'), ('pylon', 'fwd_left')]
    loads = sim.applied_loads()
    np.testing.assert_allclose(loads[1, :3], -loads[0, :3], rtol=0, atol=0)
    assert sim.advance_to(0.05), sim.message
    momentum = 150.0 * sim.velocity[0] + MASS * sim.velocity[1]
    assert np.max(np.abs(momentum)) < 1e-9 * MASS * np.max(np.abs(sim.velocity[1]))
    assert np.max(np.abs(sim.velocity[1])) > 0.01
    assert len(brace_events(sim)) >= 4


def linear_roll(preloads, stiffness, damping, t):
    """Return the roll about the hook line at t of the linearised dynamics, rad (from rest)."""
    axis = np.array([0.0, 0.0, -0.25])
    arms, reach = [], []
    for x, side in PADS:
        point, direction = pad(x, side)
        arms.append(np.cross(np.array(point) - axis, direction)[0])
        reach.append(np.dot(np.array(point) - axis, direction))
    arms = np.array(arms)
    moment = float(np.dot(preloads, arms))
    inertia = INERTIA[0] + MASS * 0.25 ** 2
    # the pads' axes stay in the pylon's axes while the point turns with the store about
    # the hook line: a push f along a at r gives -theta f (r . a) more roll moment
    spring = (stiffness * float(np.sum(arms ** 2)) + MASS * G * 0.25
              + float(np.dot(preloads, reach)))
    dashpot = damping * float(np.sum(arms ** 2))
    w = math.sqrt(spring / inertia)
    zeta = dashpot / (2.0 * math.sqrt(spring * inertia))
    wd = w * math.sqrt(1.0 - zeta ** 2)
    decay = math.exp(-zeta * w * t)
    return moment / spring * (1.0 - decay * (math.cos(wd * t) + zeta * w / wd
                                             * math.sin(wd * t)))


def test_a_preload_sweep_rolls_as_the_linearised_roll_dynamics_say(tmp_path):
    from cfem_ros.study import load_sweep
    from cfem_ros.study.runs import run_rows
    import yaml

    base = 2000.0
    extra = [0.0, 10.0, 20.0, 40.0]   # N more on the forward left pad
    scenario = store_on_hooks(damping=2.0e3, dt=5e-4)
    scenario['duration'] = 0.1
    (tmp_path / 'scenario.yaml').write_text(yaml.safe_dump(scenario))
    sweep = {'scenario': 'scenario.yaml', 'runs': 1, 'seed': 1,
             'vary': {'sway_braces[0].preload': {'grid': [base + d for d in extra]}},
             'metrics': {'at': [{'time': 0.1, 'body': 'store', 'relative_to': 'pylon'}]}}
    (tmp_path / 'sweep.yaml').write_text(yaml.safe_dump(sweep))
    spec = load_sweep(str(tmp_path / 'sweep.yaml'))
    rows = run_rows(spec, range(len(extra)))
    for d, row in zip(extra, rows):
        assert row['status'] == 'ok', row['message']
        roll = math.radians(row['store_at_0.1_roll_deg'])
        want = linear_roll([base + d, base, base, base], 5.0e6, 2.0e3, 0.1)
        if d == 0.0:
            assert abs(roll) < 1e-12
        else:
            # linearised: the neglected terms are of the order of the roll (1e-6 rad)
            assert abs(roll - want) < 1e-5 * abs(want), (d, roll, want)
    assert abs(math.radians(rows[-1]['store_at_0.1_roll_deg'])) > 1e-6   # a roll to measure


@pytest.mark.parametrize('change, key, words', [
    (('preload', -1.0), 'sway_braces[1].preload', '>= 0'),
    (('stiffness', -5.0), 'sway_braces[1].stiffness', '>= 0'),
    (('damping', -1.0), 'sway_braces[1].damping', '>= 0'),
    (('direction', [0, 0, 0]), 'sway_braces[1].direction', 'zero length'),
    (('point', [0.45, -0.1434, -0.6]), 'sway_braces[1].point', 'from the surface'),
    (('point', [0.0, 0.0, 0.0]), 'sway_braces[1].point', 'inside the surface'),
    (('body', 'pylon'), 'sway_braces[1].body', 'fixed'),
    (('carrier', 'store'), 'sway_braces[1].carrier', 'another body'),
    (('carrier', 'wing'), 'sway_braces[1].carrier', 'not a body'),
    # a list or a mapping is no name: refused, not a TypeError (reliability campaign)
    (('carrier', ['pylon']), 'sway_braces[1].carrier', 'not a body'),
    (('body', {'store': 1}), 'sway_braces[1].body', 'not a body'),
    (('name', 'fwd_left'), 'sway_braces[1].name', 'already names'),
])
def test_bad_braces_are_refused_with_the_key_path(change, key, words):
    doc = copy.deepcopy(store_on_hooks())
    doc['sway_braces'][1][change[0]] = change[1]
    with pytest.raises(ScenarioError) as err:
        parse_scenario(doc, source='braces.yaml')
    assert key in str(err.value) and words in str(err.value), str(err.value)


def test_check_lists_the_braces(tmp_path, capsys):
    import yaml

    path = tmp_path / 'braces.yaml'
    path.write_text(yaml.safe_dump(store_on_hooks()))
    assert cli.main(['check', str(path)]) == 0
    printed = capsys.readouterr().out
    for name in NAMES:
        assert f'sway brace {name}: pylon pushes store' in printed
    assert 'preload 2000 N, stiffness 5e+06 N/m' in printed
