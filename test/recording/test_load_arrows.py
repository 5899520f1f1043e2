# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Every load is drawn where it acts, at every sample and at each load event, at one scale.

The near-pylon example for 0.12 s (hooks until 0.05 s, two ejectors, aero)
with a wrench held on the store by an input at a point: each arrow, read
back with rosbags, against the loads the same recording publishes (the
applied topics in body axes, the joint's in its frame). The two-hook example
released at 0.05 s (hooks, ejectors reacting on a free pylon, four sway
braces): an arrow message at each event's stamp showing what acts from then
on, every arrow from its point of action computed here from the scenario's
geometry and the recorded poses. One scale for the whole recording, fixed at
t = 0 and computed here from the scenario's stated loads and the loads the
recording holds at t = 0 (the 2 g pull-up, whose hook load at t = 0 is
twice the store's weight), or stated in the scenario (``load_scale``).
"""

import pathlib

from cfem_ros import cli, parse_scenario
from cfem_ros.core.errors import ScenarioError
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.loadarrows import COLORS
from cfem_ros.recording.schema import WRENCH_TYPE
import numpy as np
import pytest
from recordings import read_rosbags
from scipy.spatial.transform import Rotation
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
HELD_AT = np.array([1.0, 0.0, 0.0])   # body axes, from the CG, m
HELD = np.array([0.0, 3000.0, 0.0])   # N, world axes
STORE_LENGTH = {'store_release_near_pylon.yaml': 3.0}   # m, else 2.5 (the shapes' length)


@pytest.fixture(scope='module')
def near(tmp_path_factory):
    folder = tmp_path_factory.mktemp('load_arrows')
    inputs = folder / 'inputs.mcap'
    with Recorder(str(inputs)) as recorder:
        recorder.write('/cfem/bodies/store/wrench', WRENCH_TYPE, {
            'header': {'stamp': {'sec': 0, 'nanosec': 0}, 'frame_id': 'world@1.0,0,0'},
            'wrench': {'force': dict(zip('xyz', HELD))}}, 0)
    out = folder / 'near.mcap'
    assert cli.main(['run', str(CONFIG / 'store_release_near_pylon.yaml'), '-o', str(out),
                     '--duration', '0.12', '--inputs', str(inputs)]) == 0
    messages, _ = read_rosbags(out)
    return messages


def _vector(v):
    return np.array([v.x, v.y, v.z])


def _arrays(messages) -> list:
    """Return (stamp, {label: arrow}, N per m) of each load_markers message, in file order."""
    out = []
    for topic, t, array in messages:
        if topic != '/cfem/load_markers':
            continue
        arrows = {}
        for m in array.markers:
            if m.action == 0:
                label = f'{m.text.split(":")[0]} on {m.header.frame_id}'
                assert label not in arrows
                arrows[label] = m
        scales = {float(m.text.rsplit('= ', 1)[1].split()[0]) for m in arrows.values()}
        assert len(scales) <= 1   # one scale per sending, stated in every text
        out.append((t, arrows, scales.pop() if scales else None))
    return out


def _stamp(seconds: float) -> int:
    return int(round(seconds * 1e9))


def test_each_load_from_where_it_acts_along_its_force(near):
    arrays = _arrays(near)
    samples = sorted({t for topic, t, _ in near if topic == '/cfem/bodies/store/pose'})
    assert len(samples) == 13
    events = [yaml.safe_load(m.data) for topic, _, m in near if topic == '/cfem/events']
    stamps = sorted(samples + [_stamp(e['time']) for e in events
                               if e['event'] in ('release', 'stroke_end')])
    assert sorted(t for t, _, _ in arrays) == stamps   # every sample, each load event
    pose = {t: m.pose.orientation for topic, t, m in near if topic == '/cfem/bodies/store/pose'}
    (per_metre,) = {scale for _, _, scale in arrays}   # one scale for the recording
    ends = {e['wrench']: _stamp(e['time']) for e in events if e['event'] == 'stroke_end'}
    largest = 0.0
    seen = set()
    for t, arrows, _ in arrays:
        if t not in samples or t in seen:
            continue   # the events' arrows: test_arrows_at_each_load_event
        seen.add(t)
        # the hooks until their release; the input from just after the sample at 0
        expected = {f'{w} ejector on store' for w in ('forward_ejector', 'aft_ejector')
                    if t < ends[w]} | {'aero aero on store'} | (
            {'hooks joint on hooks'} if t <= _stamp(0.05) else set()) | (
            {'store input on store'} if t > 0 else set())
        assert set(arrows) == expected
        for label, arrow in arrows.items():
            source, kind = label.split()[:2]
            assert arrow.frame_locked and arrow.type == 0
            assert (arrow.color.r, arrow.color.g, arrow.color.b) == pytest.approx(
                COLORS[kind][:3])
            start, end = (_vector(p) for p in arrow.points)
            drawn = (end - start) * per_metre   # the force, N, in the frame's axes
            largest = max(largest, np.linalg.norm(drawn))
            if kind == 'joint':
                load = [m.wrench for topic, s, m in near   # the sample's (then zero: released)
                        if topic == '/cfem/joints/hooks/wrench' and s == t][0]
                assert not start.any()
                np.testing.assert_allclose(drawn, _vector(load.force), rtol=1e-9)
                continue
            if kind == 'input':
                q = pose[t]
                turn = Rotation.from_quat([q.x, q.y, q.z, q.w])
                np.testing.assert_array_equal(start, HELD_AT)
                np.testing.assert_allclose(drawn, turn.inv().apply(HELD), rtol=1e-9)
                continue
            (load,) = [m.wrench for topic, s, m in near
                       if topic == f'/cfem/bodies/store/applied/{source}' and s == t]
            force, moment = _vector(load.force), _vector(load.torque)
            np.testing.assert_allclose(drawn, force, rtol=1e-9)
            if kind == 'ejector':   # at the scenario's point (its x station, on the top)
                assert start[2] == -0.25 and start[0] in (0.1798, -0.3292)
            else:   # aero: on its line of action (the moment about the CG is start x force)
                along = moment @ force / (force @ force) * force
                np.testing.assert_allclose(np.cross(start, force), moment - along,
                                           atol=1e-9 * np.linalg.norm(moment))
                assert 0 < np.linalg.norm(start) <= 1.5   # on the store (3 m long)
    # the largest force of the run (the hooks' just before their release, more than the aft
    # ejector's 42,703 N) is drawn longer than the store's 3 m: the scale is that of t = 0
    assert largest > 42703.0
    texts = [float(m.text.split(': ')[1].split(' N')[0]) for _, arrows, _ in arrays
             for m in arrows.values()]
    assert largest == pytest.approx(max(texts), rel=1e-3)
    document = yaml.safe_load((CONFIG / 'store_release_near_pylon.yaml').read_text())
    assert per_metre == _start_scale(document, near, 3.0)[0] == 2e4


# ------------------------------------------------------------ the two-hook example

TWO_HOOKS = yaml.safe_load((CONFIG / 'store_release_two_hooks.yaml').read_text())
RELEASE = 0.05


@pytest.fixture(scope='module')
def two_hooks(tmp_path_factory):
    folder = tmp_path_factory.mktemp('two_hooks_arrows')
    scenario = dict(TWO_HOOKS, duration=0.2)
    scenario['release_groups'] = {'station_1': {'joints': ['fwd_hook', 'aft_hook'],
                                                'release': {'time': RELEASE}}}
    (folder / 'two.yaml').write_text(yaml.safe_dump(scenario))
    out = folder / 'two.mcap'
    assert cli.main(['run', str(folder / 'two.yaml'), '-o', str(out)]) == 0
    messages, _ = read_rosbags(out)
    return messages


def _poses(messages, body) -> dict:
    """Return stamp -> (CG, Rotation body to world) of a body's recorded poses."""
    out = {}
    for topic, t, m in messages:
        if topic == f'/cfem/bodies/{body}/pose':
            p, q = m.pose.position, m.pose.orientation
            out[t] = (np.array([p.x, p.y, p.z]), Rotation.from_quat([q.x, q.y, q.z, q.w]))
    return out


def test_arrows_at_each_load_event(two_hooks):
    events = [yaml.safe_load(m.data) for topic, _, m in two_hooks if topic == '/cfem/events']
    kinds = {e['event'] for e in events}
    assert {'release', 'stroke_end', 'brace_contact'} <= kinds
    arrays = _arrays(two_hooks)
    stamps = [t for t, _, _ in arrays]
    samples = sorted(_poses(two_hooks, 'store'))
    assert len(samples) == 21 and set(samples) <= set(stamps)   # every sample
    gone, ended = set(), set()
    for event in events:
        stamp = _stamp(event['time'])
        assert stamp in stamps, event   # a message at each load event, at its stamp
        # the last message at that stamp: what acts from the event on
        arrows = [a for t, a, _ in arrays if t == stamp][-1]
        if event['event'] == 'release':
            gone.add(f'{event["joint"]} joint on {event["joint"]}')
        elif event['event'] == 'stroke_end':
            ended.add(event['wrench'])
        else:
            assert not event['contact']   # the pads let go
            gone |= {f'{event["brace"]} brace on store', f'{event["brace"]} brace on pylon'}
        drawn = set(arrows)
        assert not drawn & gone
        assert not {label for label in drawn if label.split()[0] in ended}
        # the ejectors and their reactions act from the release to their stroke ends
        for wrench in ('forward_ejector', 'aft_ejector'):
            acting = wrench not in ended
            assert (f'{wrench} ejector on store' in drawn) == acting
            assert (f'{wrench} reaction on pylon' in drawn) == acting
    # before the release, the sample at 0.05 s still shows the hooks and not the ejectors
    before = [a for t, a, _ in arrays if t == _stamp(RELEASE)][0]
    assert {'fwd_hook joint on fwd_hook', 'aft_hook joint on aft_hook'} <= set(before)
    assert not any('ejector' in label for label in before)


def test_arrows_start_at_the_points_of_action(two_hooks):
    store, pylon = _poses(two_hooks, 'store'), _poses(two_hooks, 'pylon')
    braces = {b['name']: np.array(b['point'], dtype=float) for b in TWO_HOOKS['sway_braces']}
    ejectors = {w['name']: np.array(w['point'], dtype=float) for w in TWO_HOOKS['wrenches']}

    def in_pylon(stamp, point):   # a point fixed on the store, in the pylon's axes
        (s, s_turn), (p, p_turn) = store[stamp], pylon[stamp]
        return p_turn.inv().apply(s + s_turn.apply(point) - p)

    # the ejectors on the pylon: where the store's points were at the release
    on_pylon = {name: in_pylon(_stamp(RELEASE), point) for name, point in ejectors.items()}
    checked = set()
    for t, arrows, _ in _arrays(two_hooks):
        if t not in store:
            continue   # events: their poses are not recorded
        for label, arrow in arrows.items():
            source, kind, _, frame = label.split()
            start = _vector(arrow.points[0])
            if kind == 'joint':
                assert frame == source and not start.any()   # at the joint's frame
            elif kind == 'brace' and frame == 'store':   # at the pad, on the skin
                np.testing.assert_array_equal(start, braces[source])
            elif kind == 'brace':   # the pylon takes it at the same point
                np.testing.assert_allclose(start, in_pylon(t, braces[source]), atol=1e-9)
                assert np.linalg.norm(start - in_pylon(0, braces[source])) < 1e-3
            elif kind == 'ejector':
                np.testing.assert_array_equal(start, ejectors[source])
            elif kind == 'reaction':
                assert frame == 'pylon'
                np.testing.assert_allclose(start, on_pylon[source], atol=1e-9)
            else:
                assert kind == 'aero'
            checked.add((kind, frame))
    assert checked >= {('joint', 'fwd_hook'), ('brace', 'store'), ('brace', 'pylon'),
                       ('ejector', 'store'), ('reaction', 'pylon')}


def _start_scale(document: dict, messages, size: float) -> tuple:
    """
    Return the scale the arrows should have (N per m) and the two loads it comes from (N).

    From the documented rule: the largest of the loads the scenario states
    (each free body's weight m |g|, each wrench's force, each brace's
    preload) and the loads the recording holds at t = 0 (each joint's and
    each applied load's force), drawn about size m long at 1, 2 or 5 times
    a power of ten N per m.
    """
    g = np.linalg.norm(document.get('gravity', [0.0, 0.0, -9.80665]))
    carrier = document.get('flight', {}).get('carrier')
    stated = [body['mass'] * g for name, body in document['bodies'].items()
              if name != carrier and not body.get('fixed') and 'motion' not in body]
    stated += [np.linalg.norm(w['force']) for w in document.get('wrenches', [])]
    stated += [b['preload'] for b in document.get('sway_braces', [])]
    first = [np.linalg.norm(_vector(m.wrench.force)) for topic, t, m in messages
             if t == 0 and (topic.endswith('/wrench_world') or '/applied/' in topic)]
    largest = max(stated + first)
    steps = [step * 10.0 ** k for k in range(-6, 12) for step in (1, 2, 5)]
    return min(s for s in steps if s * size >= largest), max(stated), max(first)


def _scales(messages) -> set:
    """Return the scales (N per m) the arrows state, checking each arrow's length by it."""
    scales = set()
    for _, arrows, _ in _arrays(messages):
        for arrow in arrows.values():
            start, end = (_vector(p) for p in arrow.points)
            per_metre = float(arrow.text.rsplit('= ', 1)[1].split()[0])
            force = float(arrow.text.split(': ')[1].split(' N')[0])
            assert np.linalg.norm(end - start) * per_metre == pytest.approx(force, rel=1e-3)
            scales.add(per_metre)
    return scales


@pytest.fixture(scope='module')
def pullup(tmp_path_factory):
    """Run the 2 g pull-up for 0.1 s (the hook holds the store), and again at a stated scale."""
    folder = tmp_path_factory.mktemp('pullup_arrows')
    document = yaml.safe_load((CONFIG / 'store_release_from_pullup.yaml').read_text())
    out = {}
    for name, extra in (('found', {}), ('stated', {'load_scale': 5e3})):
        (folder / f'{name}.yaml').write_text(yaml.safe_dump(dict(document, **extra)))
        assert cli.main(['run', str(folder / f'{name}.yaml'), '-o', str(folder / f'{name}.mcap'),
                         '--duration', '0.1']) == 0
        out[name] = read_rosbags(folder / f'{name}.mcap')[0]
    return document, out


def test_one_scale_fixed_at_the_start(two_hooks, pullup):
    # the two hooks: the aft ejector's stated 42,703 N rules (at t = 0 the largest load is a
    # hook's, about 10 kN); the largest force later (the pylon mount at the release, about
    # 58 kN) is drawn at that scale, longer than the store
    (per_metre,) = _scales(two_hooks)
    expected, stated, first = _start_scale(TWO_HOOKS, two_hooks, 2.5)
    assert stated == 42703.0 and 5e3 < first < stated
    assert per_metre == expected == 2e4
    forces = [float(m.text.split(': ')[1].split(' N')[0]) for _, arrows, _ in _arrays(two_hooks)
              for m in arrows.values()]
    assert max(forces) > 5e4
    # the pull-up: the hook's load at t = 0 (the store at 2 g, twice its weight) rules
    document, runs = pullup
    (per_metre,) = _scales(runs['found'])
    expected, stated, first = _start_scale(document, runs['found'], 2.5)
    assert first == pytest.approx(2 * stated, rel=1e-3)
    assert per_metre == expected == 1e4
    # a scale stated in the scenario is the scale of every arrow
    assert _scales(runs['stated']) == {5e3}


@pytest.mark.parametrize('value, words', [
    (3000, 'load_scale: is 3000 N per m; expected 1, 2 or 5 times a power of ten '
           '(e.g. 2000 or 5000)'),
    (0, 'load_scale: is 0; expected a number > 0'),
    ('big', "load_scale: is 'big'; expected a number"),
])
def test_a_stated_scale_is_one_each_arrow_can_state(value, words):
    document = dict(TWO_HOOKS, load_scale=value)
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(document, source='two.yaml')
    assert str(caught.value).startswith(f'two.yaml: {words}')
    assert parse_scenario(dict(TWO_HOOKS, load_scale=2e-3)).load_scale == 2e-3
