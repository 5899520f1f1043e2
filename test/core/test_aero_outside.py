# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Leaving a table at its edges (issue 52 items 5, 6): still air, t = 0, and what is recorded."""

import pathlib

from cfem_ros import cli, Simulator
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.recording.analysis import open_run
import pytest
import yaml

G0 = 9.80665
CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'


def at_rest(alpha_deg, outside='stop', gravity=G0, **aero) -> dict:
    """Return a store at rest in still air at sea level: it falls through the air from t = 0."""
    return {'gravity': [0, 0, gravity], 'duration': 0.2, 'dt': 0.001,
            'bodies': {'store': {'mass': 230.0, 'inertia': [4.1, 95.0, 95.0]}},
            'aero': {'store': {'area': 0.03, 'length': 0.2, 'altitude': 0.0,
                               'alpha_deg': alpha_deg, 'CX': -0.3,
                               'CZ': [0.5 * (len(alpha_deg) // 2 - i)
                                      for i in range(len(alpha_deg))],
                               'zero': ['CY', 'Cl', 'Cm', 'Cn'], 'outside': outside, **aero}}}


def aero_events(sim):
    return [e for e in sim.events if e['event'].startswith('aero_')]


def test_alpha_at_zero_airspeed_is_not_outside_and_the_fall_is_told_with_its_angle():
    # the case: "alpha_deg = 0 outside [-20, 20]", and outside: stop ended the run
    # at t = 0 on that value, inside the table. At rest in still air alpha is undefined; the
    # store falls straight down at once: the air comes from below, alpha = 90 deg exactly
    sim = Simulator(parse_scenario(at_rest([-20, 0, 20])))
    assert not aero_events(sim) and sim.status == 'running'
    assert not sim.advance_to(0.2) and sim.status == 'aero_outside'
    event, = aero_events(sim)
    assert (event['axis'], event['time'], event['low'], event['high']) == (
        'alpha_deg', 0.0, -20.0, 20.0)
    assert event['value'] == pytest.approx(90.0, abs=1e-6)
    assert 'alpha_deg = 90 outside [-20, 20]' in sim.message


@pytest.mark.parametrize('alpha_deg, gravity, told', [
    ([5, 10, 20], 0.0, []),                  # at rest for good: never outside
    ([5, 10, 20], G0, [90.0]),               # 0 is below the table, 90 above: told once
    ([-20, 0, 100], G0, []),                 # 90 is inside: nothing to tell
])
def test_a_table_without_zero_is_left_only_once_the_store_moves_through_the_air(
        alpha_deg, gravity, told):
    sim = Simulator(parse_scenario(at_rest(alpha_deg, 'hold', gravity)))
    assert not aero_events(sim)
    assert sim.advance_to(0.2) and sim.status == 'running'
    events = aero_events(sim)
    assert [e['event'] for e in events] == ['aero_outside'] * len(told)
    assert [e['value'] for e in events] == pytest.approx(told, abs=1e-6)


def clearance(change) -> dict:
    doc = yaml.safe_load((CONFIG / 'store_clearance_aero.yaml').read_text())
    change(doc['aero']['store'])
    return doc


@pytest.mark.parametrize('doc, said', [
    # the guide's case: Mach 0.45 against a table from 0.8 exited 1 with 0 messages
    (clearance(lambda a: a.update(freestream=[-153, 0, 0], outside='stop')),
     'mach = 0.445687 outside [0.8, 0.95] (aero.store.outside: stop)'),
    (at_rest([-20, 0, 20]), 'alpha_deg = 90 outside [-20, 20] (aero.store.outside: stop)'),
])
def test_check_refuses_a_run_that_outside_stop_ends_as_it_starts(tmp_path, capsys, doc, said):
    path = tmp_path / 'start.yaml'
    path.write_text(yaml.safe_dump(doc))
    for command in (['check', str(path)], ['run', str(path), '-o', str(tmp_path / 'r.mcap')]):
        assert cli.main(command) == 2
        line, = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith('ERROR')]
        assert 'the run would end as it starts' in line and said in line, line
        assert 'or outside: hold' in line
    assert not (tmp_path / 'r.mcap').exists()


def test_check_refuses_a_delta_that_diverges_within_the_first_step(tmp_path, capsys):
    # the case: a delta Cn of 1e30 passed check and the run failed in its first step
    path = tmp_path / 'delta.yaml'
    path.write_text(yaml.safe_dump(clearance(lambda a: a.update(delta={'Cn': 1e30}))))
    assert cli.main(['check', str(path)]) == 2
    line, = capsys.readouterr().err.splitlines()
    assert line.startswith(f'ERROR: {path}: cannot start: ') and 'first step' in line, line


def test_outside_stop_mid_run_records_the_error_event(tmp_path, capsys):
    # the case: exit 1 without the error event every exit-1 recording promises
    doc = at_rest([-20, 0, 20], outside='stop')
    doc['bodies']['store']['velocity'] = [100.0, 0, 0]   # alpha reaches 20 deg at 3.7 s
    doc['duration'] = 4.0
    path = tmp_path / 'mid.yaml'
    path.write_text(yaml.safe_dump(doc))
    assert cli.main(['check', str(path)]) == 0
    assert cli.main(['run', str(path), '-o', str(tmp_path / 'mid.mcap')]) == 1
    assert 'alpha_deg = 20 outside [-20, 20]' in capsys.readouterr().err
    run = open_run(str(tmp_path / 'mid.mcap'))
    kinds = [e['event'] for e in run.events]
    assert kinds[-2:] == ['aero_outside', 'error']
    error = run.events[-1]
    assert error['time'] == run.events[-2]['time'] > 3.0
    assert 'aero.store.outside: stop' in error['message']
