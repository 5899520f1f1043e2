# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Release groups and wrenches tied to releases (SPEC section 7)."""

import copy

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.run.inputs import release_input
from cfem_ros.core.run.session import Session
from cfem_ros.core.scenario.parse import parse_scenario
import numpy as np
import pytest
from reference import normalized_error

G = 9.80665
EJECTORS = [
    {'name': 'forward_ejector', 'body': 'store', 'point': [0.1798, 0, -0.25],
     'force': [0, 0, 10676], 'frame': 'pylon', 'stroke': 0.1006, 'reacts_on': 'pylon',
     'start': {'release': 'station_1', 'delay': 0.0}},
    {'name': 'aft_ejector', 'body': 'store', 'point': [-0.3292, 0, -0.25],
     'force': [0, 0, 42703], 'frame': 'pylon', 'stroke': 0.1006, 'reacts_on': 'pylon',
     'start': {'release': 'station_1', 'delay': 0.0}},
]
#: The store swinging in roll on its hooks (free about the line between them),
#: 30 deg/s about the hook line 0.25 m above its CG: it rolls out to about 5.8 deg.
ROLLING = {'angular_velocity_deg': [30.0, 0, 0], 'velocity': [0, -0.25 * np.radians(30.0), 0]}


def document(release=None, *, delay=0.0, extra=(), group=True):
    """Return the Eglin store rolling on two ball hooks of a pylon, ejectors tied to station_1."""
    wrenches = copy.deepcopy(EJECTORS) + [copy.deepcopy(w) for w in extra]
    for w in wrenches[:2]:
        w['start']['delay'] = delay
        if not group:
            w['start']['release'] = 'fwd_hook'
    doc = {'gravity': [0, 0, G], 'dt': 0.001, 'duration': 0.3,
           'bodies': {'pylon': {'fixed': True},
                      'store': {'mass': 907.1848, 'inertia': [27.1164, 488.0944, 488.0944],
                                **ROLLING}},
           'joints': {name: {'type': 'ball', 'parent': 'pylon', 'child': 'store',
                             'anchor': [x, 0, -0.25]}
                      for name, x in (('fwd_hook', 0.381), ('aft_hook', -0.381))},
           'wrenches': wrenches}
    if group:
        doc['release_groups'] = {'station_1': {'joints': ['fwd_hook', 'aft_hook']}}
        if release is not None:
            doc['release_groups']['station_1']['release'] = release
    return doc


def simulator(doc):
    return Simulator(parse_scenario(doc, source='station.yaml'))


def releases(sim):
    return [e for e in sim.events if e['event'] == 'release']


def assert_one_instant(sim, cause):
    """Both hooks released at one time (bit-equal), by the group, with the cause."""
    events = releases(sim)
    assert [e['joint'] for e in events] in (['fwd_hook', 'aft_hook'], ['aft_hook', 'fwd_hook'])
    assert events[0]['time'] == events[1]['time']
    assert all(e['group'] == 'station_1' and e['cause'] == cause for e in events)
    return events[0]['time']


def assert_ejectors_start_at(sim, t_start):
    assert list(sim._scheduled.start[:2]) == [t_start, t_start]
    assert sim._scheduled.started[:2].all()
    assert sim.model.wrenches[0].start_release == 'station_1'


def test_a_group_is_released_by_its_time_in_one_instant():
    sim = simulator(document({'time': 0.0503}))
    assert sim.advance_to(0.3), sim.message
    assert assert_one_instant(sim, 'time') == 0.0503
    assert not sim.active.any()
    assert_ejectors_start_at(sim, 0.0503)


def roll_deg(sim):
    """Return the store's rotation from its start (about the hook line), deg."""
    return np.degrees(2.0 * np.arcsin(np.linalg.norm(sim.orientation[1][:3])))


def test_a_condition_on_any_joint_releases_the_group():
    sim = simulator(document({'angle_deg': 3.0}))
    assert sim.advance_to(0.3), sim.message
    t = assert_one_instant(sim, 'angle')
    assert abs(t / 0.001 - round(t / 0.001)) > 1e-6   # located inside a step
    assert_ejectors_start_at(sim, t)
    # the same store with no trigger, stopped there: rolled by 3 deg
    held = simulator(document(None))
    assert held.advance_to(t), held.message
    assert abs(roll_deg(held) - 3.0) < 1e-9


@pytest.mark.parametrize('command', ['station_1', 'fwd_hook', 'aft_hook'])
def test_a_command_naming_the_group_or_one_of_its_joints_releases_all(command):
    sim = simulator(document())
    assert sim.advance_to(0.0417)
    sim.release(command)
    assert assert_one_instant(sim, 'command') == 0.0417
    with pytest.raises(ValueError, match="release group 'station_1' is already released"):
        sim.release('station_1')


def test_several_names_in_one_command_are_released_in_one_instant():
    sim = simulator(document(group=False))
    assert sim.advance_to(0.02)
    events = sim.release_all('fwd_hook, aft_hook')
    assert [e['joint'] for e in events] == ['fwd_hook', 'aft_hook']
    assert events[0]['time'] == events[1]['time'] == 0.02 and 'group' not in events[0]
    refused = simulator(document(group=False))
    with pytest.raises(ValueError, match="unknown joint 'nope'"):
        refused.release('fwd_hook nope')
    assert refused.active.all() and not refused.events   # refused whole


def test_a_session_input_releases_the_group_at_its_time():
    sim = simulator(document())
    session = Session(sim, rate_hz=100.0, duration=0.3)
    session.submit(release_input('station_1', time=0.0731))
    session.run()
    assert assert_one_instant(sim, 'command') == 0.0731
    assert_ejectors_start_at(sim, 0.0731)


def fire(how, delay):
    """Run the station released by time, condition, command or input; return sim."""
    if how == 'time':
        sim = simulator(document({'time': 0.0377}, delay=delay))
    elif how == 'angle':
        sim = simulator(document({'angle_deg': 3.0}, delay=delay))
    else:
        sim = simulator(document(None, delay=delay))
    if how == 'command':
        assert sim.advance_to(0.0377)
        sim.release('station_1')
    if how == 'input':
        session = Session(sim, rate_hz=50.0, duration=0.3)
        session.submit(release_input('station_1', time=0.0377))
        session.run()
    assert sim.advance_to(0.3), sim.message
    return sim


@pytest.mark.parametrize('delay', [0.0, 0.0123])
@pytest.mark.parametrize('how', ['time', 'angle', 'command', 'input'])
def test_a_tied_wrench_starts_exactly_at_the_release_plus_its_delay(how, delay):
    sim = fire(how, delay)
    t_release = releases(sim)[0]['time']
    assert_ejectors_start_at(sim, t_release + delay)
    # the same run written with times: the release's and the ejectors' start
    doc = document({'time': t_release})
    for w in doc['wrenches'][:2]:
        w['start'] = t_release + delay
    timed = simulator(doc)
    assert timed.advance_to(0.3), timed.message
    assert normalized_error(sim.y, timed.y, 1.0) < 1e-10
    strokes = [e for e in sim.events if e['event'] == 'stroke_end']
    timed_strokes = [e for e in timed.events if e['event'] == 'stroke_end']
    assert [e['wrench'] for e in strokes] == [e['wrench'] for e in timed_strokes]
    assert len(strokes) == 2 and all(e['time'] > t_release + delay for e in strokes)
    for a, b in zip(strokes, timed_strokes):
        assert abs(a['time'] - b['time']) < 1e-12
        assert normalized_error(a['velocity'] + a['rates'], b['velocity'] + b['rates'],
                                1.0) < 1e-9


def test_a_carriage_load_ends_when_the_station_is_released():
    preload = {'name': 'sway_brace', 'body': 'store', 'force': [0, 0, -2000.0],
               'frame': 'pylon', 'end': {'release': 'station_1'}}
    sim = simulator(document({'time': 0.05}, extra=[preload]))
    before = sim.joint_wrenches()[0]
    assert sim.advance_to(0.3), sim.message
    assert sim._scheduled.done[2] and sim._scheduled.end[2] == 0.05
    # before the release the hooks carry weight, preload and the roll's centripetal load
    centripetal = 907.1848 * np.radians(30.0) ** 2 * 0.25
    assert abs(before[:, 2].sum() + 907.1848 * G - 2000.0 + centripetal) < 1e-6
    doc = document({'time': 0.05}, extra=[dict(preload, end=0.05)])
    timed = simulator(doc)
    assert timed.advance_to(0.3)
    assert normalized_error(sim.y, timed.y, 1.0) < 1e-12


@pytest.mark.parametrize('change, key, words', [
    (lambda d: d['release_groups']['station_1'].update(joints=['fwd_hook', 'nope']),
     'release_groups.station_1.joints[1]', 'is not a joint'),
    (lambda d: d['release_groups'].update(other={'joints': ['aft_hook']}),
     'release_groups.other.joints[0]', "already in group 'station_1'"),
    (lambda d: d['joints']['fwd_hook'].update(release={'time': 1.0}),
     'joints.fwd_hook.release', 'release group'),
    (lambda d: d['release_groups'].update(fwd_hook={'joints': []}),
     'release_groups.fwd_hook', 'also a joint'),
    (lambda d: d['wrenches'][0].update(start={'release': 'station_2'}),
     'wrenches[0].start.release', 'is not a joint or a release group'),
    (lambda d: d['wrenches'][0].update(start={'release': 'station_1', 'delay': -1}),
     'wrenches[0].start.delay', '>= 0'),
    (lambda d: d['wrenches'][0].update(start={'release': 'station_1', 'after': 1}),
     'wrenches[0].start.after', 'unknown key'),
])
def test_bad_groups_and_ties_are_refused_with_their_key(change, key, words):
    doc = document()
    change(doc)
    with pytest.raises(ScenarioError) as err:
        parse_scenario(doc, source='station.yaml')
    assert key in str(err.value) and words in str(err.value)
