# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
One start check at every entry point (issue 46.4): check's words wherever a run starts.

A double pendulum whose second body is 1e9 m from its elbow: ``cfem-sim
check`` refuses it (the first step cannot be solved). The Python API (a
``Simulator`` run), ``batch.run``, a sweep's row and a fit give the same
line after the scenario's name: the API, sweeps and fits ask the start
check only as the run ends within its first step, so a run that starts
fine never pays for it.
"""

import copy
import pathlib

from cfem_ros import cli, load_scenario, Simulator
from cfem_ros.core.engine import startcheck
from cfem_ros.core.engine.events import Status
from cfem_ros.core.errors import ArgumentError, CfemError
from cfem_ros.core.run import batch
from cfem_ros.study import Sweep
import numpy as np
import pandas as pd
import pytest
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
PENDULUM = yaml.safe_load((CONFIG / 'double_pendulum.yaml').read_text())
PENDULUM['duration'] = 0.05
FAR = -1e9   # B's CG, m along x: its elbow's anchor is then 1e9 body sizes away


def write(path, document) -> str:
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    return str(path)


def far_pendulum():
    document = copy.deepcopy(PENDULUM)
    document['bodies']['B']['position'] = [FAR, 0, 0]
    return document


@pytest.fixture
def refused(tmp_path, capsys):
    """Return (the scenario file check refuses, check's words after its file name)."""
    path = write(tmp_path / 'far.yaml', far_pendulum())
    assert cli.main(['check', path]) == 2
    line = capsys.readouterr().err
    assert line.startswith(f'ERROR: {path}: cannot start: ') and line.count('\n') == 1
    assert "joint 'elbow': its anchor is 1e+09 m from the CG of B" in line
    return path, line.removeprefix(f'ERROR: {path}: ').rstrip('\n')


def test_the_api_batch_sweep_and_fit_give_checks_words(refused, tmp_path, capsys):
    path, words = refused
    expected = f"scenario 'double_pendulum': {words}"
    # the Python API: the run fails at its start, and says it as check does
    sim = Simulator(load_scenario(path))
    assert not sim.advance_to(0.01)
    assert sim.status is Status.FAILED and sim.t == 0.0 and sim.failure is not None
    assert sim.message == sim.refusal == expected
    # batch.run asks before any copy
    with pytest.raises(startcheck.CannotStart) as batch_refused:
        batch.run(load_scenario(path), [{}], workers=1)
    assert str(batch_refused.value) == expected
    # a sweep: the draw check refuses is invalid (SPEC 12), with check's line; the other runs
    base = write(tmp_path / 'pendulum.yaml', PENDULUM)
    sweep_file = write(tmp_path / 'sweep.yaml', {
        'scenario': base, 'runs': 1, 'seed': 1,
        'vary': {'bodies.B.position[0]': {'grid': [2.5, FAR]}},
        'metrics': {'at': [{'time': 0.05, 'body': 'B'}]}})
    sweep = Sweep.from_file(sweep_file)
    fine, far = sweep.run_one(0), sweep.run_one(1)
    assert fine['status'] == Status.OK and fine['message'] == ''
    assert far['status'] == Status.INVALID and far['message'] == expected
    assert np.isnan(far['B_at_0.05_x']) and np.isfinite(fine['B_at_0.05_x'])
    # a fit whose parameters make the scenario one check refuses: a FitError with its words
    times = np.linspace(0.0, 0.05, 11)
    columns = {'time': times}
    columns.update({f'B_{q}': np.zeros_like(times) for q in
                    ('x', 'y', 'z', 'roll_deg', 'pitch_deg', 'yaw_deg')})
    measured = tmp_path / 'measured.csv'
    pd.DataFrame(columns).to_csv(measured, index=False)
    fit = write(tmp_path / 'fit.yaml', {
        'scenario': base,
        'measured': {'file': str(measured), 'body': 'B', 'relative_to': 'O',
                     'sigma': {'position': 0.01, 'attitude_deg': 1.0}},
        'parameters': {'bodies.B.position[0]': {'start': FAR, 'bounds': [2 * FAR, 10.0]}}})
    capsys.readouterr()
    # exit 1, as for any parameter values that make the scenario invalid (not the file's form)
    assert cli.main(['fit', fit, '-o', str(tmp_path / 'fitted')]) == 1
    err = capsys.readouterr().err
    assert err.startswith('ERROR: ') and err.count('\n') == 1, err
    assert err.rstrip('\n').endswith(f'make the scenario invalid: {expected}; expected bounds '
                                     'that keep the scenario valid'), err


def test_a_run_that_starts_fine_never_asks_the_start_check(monkeypatch):
    asked = []
    real = startcheck.start_problems
    monkeypatch.setattr(startcheck, 'start_problems', lambda sim: asked.append(sim) or real(sim))
    model = load_scenario(str(CONFIG / 'double_pendulum.yaml'))
    sim = Simulator(model)
    assert sim.advance_to(0.05) and sim.refusal == '' and not asked
    # a run that fails after its first step is the run's own failure: not asked either
    late = Simulator(model)
    assert late.advance_to(0.01)
    with np.errstate(invalid='ignore'):   # the braces' watch normalises the quaternions
        late.set_state(np.full_like(late.y, np.inf))
    assert not late.advance_to(0.02) and late.status is Status.FAILED
    assert late.t > late.dt and late.refusal == '' and not asked
    assert late.message.startswith('at t = 0.01 s: ')
    # one that fails at its start of a scenario check passes keeps the run's message
    copy_ = Simulator(model)
    with np.errstate(invalid='ignore'):
        copy_.set_state(np.full_like(copy_.y, np.nan), start=True)
    assert not copy_.advance_to(0.01) and copy_.t == 0.0
    assert len(asked) == 1 and copy_.refusal == '' and copy_.message.startswith('at t = 0 s: ')


def test_the_apis_refusals_are_cfem_errors():
    # the API page: every error the package raises on purpose is a CfemError
    sim = Simulator(load_scenario(str(CONFIG / 'double_pendulum.yaml')))
    calls = [lambda: sim.set_state(np.zeros(3)),
             lambda: sim.advance_to(float('nan')),
             lambda: sim.advance_to(-1.0),
             lambda: sim.advance_to(1.0, limit=float('nan')),
             lambda: sim.release('nowhere'),
             lambda: sim.set_wrench('nobody', [0, 0, 1], [0, 0, 0]),
             lambda: sim.set_wrench('O', [0, 0, 1], [0, 0, 0]),
             lambda: sim.set_wrench('B', [0, 1], [0, 0, 0]),
             lambda: sim.body_index('nobody'),
             lambda: sim.model.joint_index('nowhere'),
             lambda: batch.run(sim.model, [{'y0': np.zeros(2)}], workers=1)]
    for call in calls:
        with pytest.raises(CfemError) as refused:
            call()
        # and still a ValueError, for the callers that catch one
        assert isinstance(refused.value, (ArgumentError, ValueError)), refused.value
    sim.advance_to(0.01)
    with pytest.raises(CfemError, match='start: the run has taken'):
        sim.set_state(sim.y, start=True)


def test_a_run_a_table_stops_as_it_starts_says_checks_words(tmp_path, capsys):
    # Mach 0.45 against a table from Mach 0.8 with outside: stop: the run ends at t = 0
    document = yaml.safe_load((CONFIG / 'store_clearance_aero.yaml').read_text())
    document['aero']['store'].update(freestream=[-153, 0, 0], outside='stop')
    path = write(tmp_path / 'start.yaml', document)
    assert cli.main(['check', path]) == 2
    line = capsys.readouterr().err.rstrip('\n').splitlines()[-1]
    assert line.startswith(f'ERROR: {path}: cannot start: the run would end as it starts')
    words = line.removeprefix(f'ERROR: {path}: ')
    sim = Simulator(load_scenario(path))
    assert sim.status is Status.AERO_OUTSIDE and sim.t == 0.0
    assert sim.message == sim.refusal == f"scenario {document['name']!r}: {words}"
    assert not sim.advance_to(0.01) and sim.t == 0.0
