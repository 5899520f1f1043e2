# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Statuses, event kinds and failures: enums with one text form, told apart by kind."""

import io
import json
import math
import pathlib
import pickle
import re

from cfem_ros.core.engine.events import (contact_label, describe_event, Event, Failure, Status,
                                         STOPS)
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.run.inputs import InputKind
from cfem_ros.core.run.session import Session
from cfem_ros.core.scenario.parse import parse_scenario
import pandas as pd
import pytest

G = 9.80665
PACKAGE = pathlib.Path(__file__).resolve().parents[2] / 'cfem_ros'


def ball_over_floor(height: float) -> dict:
    """Return a 0.1 m sphere height above a fixed box's top, the run stopped at contact."""
    return {'gravity': [0, 0, -G], 'dt': 0.001, 'duration': 1.0,
            'bodies': {'floor': {'fixed': True, 'shape': {'box': [4, 4, 0.2]}},
                       'ball': {'mass': 2.0, 'inertia': [0.1, 0.1, 0.1],
                                'position': [0, 0, 0.1 + 0.1 + height],
                                'shape': {'sphere': 0.1}}},
            'contacts': [{'bodies': ['ball', 'floor'], 'on_contact': 'stop'}]}


def two_links(dt: float) -> dict:
    return {'name': 'chain', 'duration': 3.0, 'dt': dt, 'bodies': {
        'ground': {'fixed': True},
        'a': {'mass': 1.0, 'inertia': [0.1] * 3, 'position': [0.5, 0, 0]},
        'b': {'mass': 1.0, 'inertia': [0.1] * 3, 'position': [1.5, 0, 0]}},
        'joints': {
            'j1': {'type': 'hinge', 'parent': 'ground', 'child': 'a', 'anchor': [0, 0, 0],
                   'axis': [0, 1, 0]},
            'j2': {'type': 'hinge', 'parent': 'a', 'child': 'b', 'anchor': [1, 0, 0],
                   'axis': [0, 1, 0]}}}


class _Sink:
    """A session output that keeps nothing (the session only needs somewhere to send)."""

    takes_rows = False

    def sample(self):
        pass

    def events(self):
        pass

    def received(self, item, t):
        pass


@pytest.mark.parametrize('kind', [Status, Event, Failure, InputKind])
def test_each_member_is_its_text_wherever_a_string_goes(kind):
    texts = [m.value for m in kind]
    assert len(set(texts)) == len(texts)   # one text form each, no two members alike
    for member in kind:
        text = member.value
        assert str(member) == text and f'{member}' == text and f'{member:>12}' == f'{text:>12}'
        assert json.dumps({'k': member}) == json.dumps({'k': text})   # recordings' JSON
        assert member == text and hash(member) == hash(text)
        assert text in {member} and member in {text}   # text read back from a file
        assert kind(text) is member and pickle.loads(pickle.dumps(member)) is member


def test_a_table_of_members_writes_the_bytes_of_a_table_of_text():
    statuses = [Status.OK, Status.FAILED, Status.CONTACT, Status.AERO_OUTSIDE, Status.INVALID]
    members = pd.DataFrame({'status': statuses, 'run': range(len(statuses))})
    texts = pd.DataFrame({'status': ['ok', 'failed', 'contact', 'aero_outside', 'invalid'],
                          'run': range(len(statuses))})
    assert members.to_csv() == texts.to_csv()
    written, expected = io.BytesIO(), io.BytesIO()
    members.to_parquet(written)
    texts.to_parquet(expected)
    assert written.getvalue() == expected.getvalue()
    assert (members['status'] == Status.OK).tolist() == (texts['status'] == 'ok').tolist()


def test_a_contact_stop_ends_the_session_without_failing_it():
    height = 0.3
    sim = Simulator(parse_scenario(ball_over_floor(height)))
    session = Session(sim, rate_hz=100.0, duration=1.0, outputs=[_Sink()])
    session.run()
    assert sim.status is Status.CONTACT and sim.status.stopped_by_scenario
    assert session.stopped and session.finished and not session.failed
    assert sim.failure is None and sim.reason == sim.message
    assert sim.t == pytest.approx(math.sqrt(2 * height / G), abs=1e-6)   # free fall, closed form
    (contact,) = [e for e in sim.events if e['event'] == Event.CONTACT]
    assert contact['event'] is Event.CONTACT
    assert describe_event(contact).startswith(f"contact ball floor at t = {contact['time']:.9f} s")


def test_a_diverging_run_fails_with_its_kind_and_the_reason_apart_from_the_time():
    sim = Simulator(parse_scenario(two_links(dt=0.2)))
    session = Session(sim, rate_hz=5.0, duration=3.0, outputs=[_Sink()])
    session.run()
    assert sim.status is Status.FAILED and not sim.status.stopped_by_scenario
    assert session.failed and session.stopped
    assert sim.failure is Failure.DIVERGED
    assert sim.message == f'at t = {sim.t:.9g} s: {sim.reason}'
    assert sim.reason.startswith('constraint violation')


def test_a_run_that_reaches_its_duration_neither_stopped_nor_failed():
    sim = Simulator(parse_scenario(two_links(dt=0.001)))
    session = Session(sim, rate_hz=10.0, duration=0.2, outputs=[_Sink()])
    session.run()
    assert sim.status is Status.RUNNING and session.finished
    assert not session.stopped and not session.failed and sim.failure is None


def test_the_scenario_stops_are_contact_and_aero_outside():
    assert STOPS == {Status.CONTACT, Status.AERO_OUTSIDE}
    assert [s for s in Status if s.stopped_by_scenario] == [Status.CONTACT, Status.AERO_OUTSIDE]


#: A status, an event kind or an input kind compared with a literal: ``x['status'] == 'ok'``,
#: ``e.get('event') in ('release', ...)``, ``sim.status != 'running'``, ``item.kind == 'odom'``.
LITERAL = re.compile(r"""(?:\[['"](?:status|event)['"]\]|\.get\(['"](?:status|event)['"]\)"""
                     r"""|\.status|\.kind)\)?\s*(?:==|!=|\bnot in\b|\bin\b|\bis not\b|\bis\b)"""
                     r"""\s*[\(\[\{]?\s*['"](\w+)['"]""")


def test_no_status_or_event_kind_is_compared_as_a_literal():
    kinds = {m.value for m in Status} | {m.value for m in Event} | {m.value for m in InputKind}
    found = []
    for path in sorted(PACKAGE.rglob('*.py')):
        for number, line in enumerate(path.read_text().splitlines(), 1):
            for match in LITERAL.finditer(line):
                if match.group(1) in kinds:
                    found.append(f'{path.relative_to(PACKAGE.parent)}:{number}: {line.strip()}')
    assert not found, 'compare with Status, Event or InputKind members:\n' + '\n'.join(found)


def test_the_pattern_finds_the_literals_it_is_meant_to():
    for line in ("if sim.status == 'contact':", "x = table['status'] != 'ok'",
                 "if e.get('event') in ('release', 'contact')", "if item.kind == 'odom':"):
        assert LITERAL.search(line), line
    assert not LITERAL.search('if sim.status is Status.CONTACT:')


def test_a_control_event_is_told_with_its_other_keys_and_a_contact_labelled_short():
    step = {'event': Event.STEP, 'time': 0.5, 'steps': 3, 'to': 0.503}
    assert describe_event(step) == 'step at t = 0.5 s (steps 3, to 0.503)'
    assert describe_event({'event': 'pause', 'time': 1.25}) == 'pause at t = 1.25 s'
    contact = {'event': 'contact', 'bodies': ['store', 'pylon'], 'time': 0.25,
               'point': [1.0, 0.0, -0.5]}
    assert contact_label(contact) == 'contact store pylon t=0.250000 s'
    assert describe_event(contact) == ('contact store pylon at t = 0.250000000 s, '
                                       'point [1, 0, -0.5] m (world)')
