# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Criteria on a sweep table, exact intervals of failure fractions, and run plans."""

import json
import os

from cfem_ros import cli
from cfem_ros.study import load_sweep, Sweep
from cfem_ros.study.confidence import clopper_pearson, fractions, runs_needed, upper_bound
from cfem_ros.study.criteria import judge, margins, parse_rule
import numpy as np
import pandas as pd
import pytest
from scipy import stats
from sweeps import write_sweep


@pytest.mark.parametrize('failures,runs', [(0, 1), (1, 1), (0, 59), (59, 59), (0, 1000),
                                           (3, 100), (1, 2), (999, 1000)])
@pytest.mark.parametrize('level', [0.9, 0.95, 0.99])
def test_clopper_pearson_is_scipy_s_exact_binomial_interval(failures, runs, level):
    want = stats.binomtest(failures, runs).proportion_ci(confidence_level=level,
                                                         method='exact')
    low, high = clopper_pearson(failures, runs, level)
    assert low == pytest.approx(want.low, rel=1e-9, abs=1e-15)
    assert high == pytest.approx(want.high, rel=1e-9, abs=1e-15)
    # one-sided: the two-sided interval at 2 level - 1 has the same upper end
    one = stats.binomtest(failures, runs, alternative='less').proportion_ci(
        confidence_level=level, method='exact')
    assert upper_bound(failures, runs, level) == pytest.approx(one.high, rel=1e-9)


def test_59_runs_without_failure_show_95_percent_at_95_percent():
    assert runs_needed(0.95, 0.95) == 59
    assert 0.95 ** 58 > 0.05 >= 0.95 ** 59
    assert upper_bound(0, 59, 0.95) <= 0.05 < upper_bound(0, 58, 0.95)
    assert runs_needed(0.99, 0.95) == 299
    # with one failure allowed: the least n with P(<= 1 failure | p = 0.05) <= 0.05
    n = runs_needed(0.95, 0.95, failures=1)
    assert stats.binom.cdf(1, n, 0.05) <= 0.05 < stats.binom.cdf(1, n - 1, 0.05)


def test_cfem_sim_sweep_plan_prints_the_run_count(capsys):
    assert cli.main(['sweep', '--plan', '0.95,0.95']) == 0
    assert capsys.readouterr().out.startswith('59 runs without a failure')
    assert cli.main(['sweep', '--plan', '1.5,0.95']) == 2
    assert 'ERROR: --plan' in capsys.readouterr().err


def _table():
    return pd.DataFrame({
        'run': [0, 1, 2, 3, 4],
        'status': ['ok', 'ok', 'failed', 'ok', 'contact'],
        'message': ['', '', 'the run failed at t = 0.3 s', '', 'contact at 0.2 s'],
        'gap': [0.05, 0.01, 0.2, np.nan, 0.3],
        'rate': [-0.1, 0.5, 0.0, 0.0, 0.0]})


def test_rules_judge_each_run_nan_and_unfinished_runs_fail():
    miss, rate = parse_rule('miss', 'gap >= 0.0254'), parse_rule('rate', 'abs(rate) <= 0.35')
    assert (miss.column, miss.op, miss.threshold, miss.absolute) == ('gap', '>=', 0.0254, False)
    assert rate.absolute and rate.text == 'abs(rate) <= 0.35'
    table = judge(_table(), [miss, rate])
    assert table['pass'].tolist() == [True, False, False, False, False]
    # the first failed rule, the status of a run that did not finish, NaN failing its rule
    assert table['failed_criterion'].tolist() == ['', 'miss', 'failed', 'miss', 'contact']
    got = {f.name: (f.failures, f.runs) for f in fractions(table, [miss, rate])}
    assert got == {'miss': (4, 5), 'rate': (3, 5), 'any': (4, 5)}
    least = margins(table, [miss, rate])
    assert least[0] == pytest.approx(min((0.05 - 0.0254) / 0.0254, (0.35 - 0.1) / 0.35))
    assert (least[1:] < 0).all() and least[0] > 0


@pytest.mark.parametrize('text', ['gap => 1', 'gap >= ', 'abs(gap >= 1', 'gap == 1',
                                  'gap >= nan', 'gap >= 1 m', 3])
def test_a_bad_rule_is_refused(text):
    with pytest.raises(ValueError, match='is not'):
        parse_rule('r', text)


def test_a_sweep_s_criteria_are_checked_with_the_key_path(tmp_path):
    path = write_sweep(tmp_path, criteria={'miss': 'clearance_store_pilon_min >= 0.1'})
    with pytest.raises(Exception, match='criteria.miss.*not a number column.*'
                       'clearance_store_pylon_min'):
        load_sweep(path)
    path = write_sweep(tmp_path, confidence=95)
    with pytest.raises(Exception, match='confidence: is 95; expected a confidence level'):
        load_sweep(path)


def test_a_sweep_table_gains_pass_and_failed_criterion(tmp_path, capsys):
    scenario_runs = {'bodies.store.mass': {'normal': [907.1848, 10.0]},
                     'joints.pivot.release.angle_deg': {'uniform': [8, 12]}}
    path = write_sweep(tmp_path, runs=6, vary=scenario_runs,
                       criteria={'early': 'release_pivot_time <= 0.28',
                                 'pitch': 'abs(store_at_0.5_pitch_deg) <= 90'},
                       confidence=0.9)
    out = str(tmp_path / 'out')
    table = Sweep.from_file(path).run(None, out)
    released = table['release_pivot_time'].to_numpy()
    assert table['pass'].tolist() == list(released <= 0.28)
    assert set(table['failed_criterion']) <= {'', 'early'}
    with open(os.path.join(out, 'criteria.json')) as stream:
        held = json.load(stream)
    assert held['confidence'] == 0.9 and held['criteria'][0]['rule'] == \
        'release_pivot_time <= 0.28'
    # the command line prints each criterion's fraction and writes the estimate
    assert cli.main(['sweep', path, '-o', out, '--workers', '1']) == 0
    printed = capsys.readouterr().out
    failed = int((released > 0.28).sum())
    assert f'early: {failed} failures in 6 runs' in printed
    assert 'pitch: 0 failures in 6 runs: P(fail) <= ' in printed
    with open(os.path.join(out, 'estimate.json')) as stream:
        estimate = json.load(stream)
    low, high = clopper_pearson(failed, 6, 0.9)
    assert estimate['method'] == 'mc' and estimate['runs'] == 6
    assert (estimate['ci_low'], estimate['ci_high']) == pytest.approx((low, high))
