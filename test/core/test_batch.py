# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Batch runs: each copy is exactly the run it stands for, whatever the threads do."""

import pathlib

from cfem_ros import cli, load_scenario, Simulator
from cfem_ros.core.engine import startcheck
from cfem_ros.core.run import batch
import numpy as np
import pytest
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'


def test_copies_equal_single_runs_and_keep_their_own_releases():
    model = load_scenario(str(CONFIG / 'store_separation.yaml'), duration=0.5)
    pushes = [0.0, 5e3, 2e4, -3e3]
    copies = [{'loads': {'store': ([0.0, 0.0, f], [0.0, 0.0, 0.0])}} for f in pushes]
    results = batch.run(model, copies, workers=2)
    release_times = []
    for push, result in zip(pushes, results):
        sim = Simulator(model)
        sim.set_wrench('store', [0.0, 0.0, push], [0.0, 0.0, 0.0])
        assert sim.advance_to(0.5)
        assert result.status == 'ok' and result.t == 0.5
        np.testing.assert_array_equal(result.y, sim.y)
        assert result.events == sim.events
        release_times.append(result.events[0]['time'])
    # a harder push rotates the store off the pylon sooner (the pivot is aft of the CG)
    assert release_times[2] < release_times[1] < release_times[0] < release_times[3]


def test_initial_states_and_a_failing_copy():
    model = load_scenario(str(CONFIG / 'double_pendulum.yaml'), duration=0.2)
    base = Simulator(model).y
    tilted = base.copy()
    bad = base.copy()
    bad[0] = np.nan
    results = batch.run(model, [{'y0': base}, {'y0': bad}, {}], workers=2)
    assert results[0].status == 'ok' and results[2].status == 'ok'
    np.testing.assert_array_equal(results[0].y, results[2].y)
    assert results[1].status == 'failed' and results[1].message.startswith('at t = 0 s')
    assert results[1].t == 0.0
    np.testing.assert_array_equal(tilted, base)   # inputs are not modified


def test_a_model_check_refuses_is_refused_with_its_words_before_any_copy(tmp_path, capsys):
    # a double pendulum whose second body is 1e9 m from its elbow (issue 46.4): check
    # refuses it; a batch of it is refused with the same reason, instead of copies failing
    document = yaml.safe_load((CONFIG / 'double_pendulum.yaml').read_text())
    document['bodies']['B']['position'] = [-1e9, 0, 0]
    path = tmp_path / 'far.yaml'
    path.write_text(yaml.safe_dump(document))
    assert cli.main(['check', str(path)]) == 2
    line = capsys.readouterr().err
    with pytest.raises(startcheck.CannotStart) as refused:
        batch.run(load_scenario(str(path)), [{}, {}], workers=1)
    why = line.removeprefix(f'ERROR: {path}: ')
    assert str(refused.value) + '\n' == f"scenario 'double_pendulum': {why}"
    assert why.startswith('cannot start: ') and "joint 'elbow'" in why
