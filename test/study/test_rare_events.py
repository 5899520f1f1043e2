# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Rare-event estimates where the exact probability is known.

The failure is a threshold of one normal parameter: on the scenario-free
path a metric is a linear function of the release angle (the rows of a
batch computed from its values, through the same ``Evaluator``, criteria,
OpenTURNS and folder as a sweep); on the store scenario the release time
grows with the release angle, so "released before T" fails exactly when
the angle exceeds the angle that releases at T. Either way P(fail) =
P(angle > a*) from the normal distribution. The seeds are fixed, so each
check is deterministic; the long variants (1e-5 by subset, plain MC at
1e-2 with many runs) run with CFEM_LONG_TESTS=1.
"""

import json
import os

from cfem_ros.study import load_sweep
from cfem_ros.study.methods import run_study
from cfem_ros.study.runs import run_one
import numpy as np
import pytest
from scipy.stats import norm
from sweeps import ANGLE, linear_rows, linear_sweep, MEAN, SIGMA, STORE, write_sweep

LONG = os.environ.get('CFEM_LONG_TESTS') == '1'


def _linear_sweep(folder, probability, runs, seed=5):
    """Return a sweep whose clearance 0.1 - 0.01 (angle - 10) fails beyond a quantile."""
    return linear_sweep(folder, norm.isf(probability), runs, seed)


def _check(found, probability, outdir, method):
    estimate = found['estimate']
    assert estimate.method == method
    assert estimate.ci_low <= probability <= estimate.ci_high, estimate.sentence()
    assert estimate.ci_high - estimate.ci_low < 2 * probability   # not a vacuous interval
    table = found['table']
    assert len(table) == estimate.runs and table['run'].tolist() == list(range(len(table)))
    # every evaluated run is in the table, judged: failures exactly beyond the quantile
    beyond = table[ANGLE].to_numpy() > MEAN + SIGMA * norm.isf(probability)
    np.testing.assert_array_equal(~table['pass'].to_numpy(), beyond)
    with open(os.path.join(outdir, 'estimate.json')) as stream:
        held = json.load(stream)
    assert set(held) >= {'probability', 'cov', 'ci_low', 'ci_high', 'runs', 'method'}
    assert held['probability'] == pytest.approx(estimate.probability)


CASES = [('form', 1e-2, 200), ('form', 1e-5, 200), ('nais', 1e-2, 1000),
         ('nais', 1e-5, 1000), ('subset', 1e-2, 2000), ('mc', 1e-2, 3000)]
LONG_CASES = [('subset', 1e-5, 4000), ('mc', 1e-2, 100000)]


@pytest.mark.parametrize('method,probability,runs', CASES + (LONG_CASES if LONG else []))
def test_each_method_s_interval_holds_the_exact_probability(tmp_path, method, probability,
                                                            runs):
    spec = _linear_sweep(tmp_path, probability, runs)
    out = str(tmp_path / method)
    found = run_study(spec, out, method=method, rows=linear_rows, log=lambda line: None)
    _check(found, probability, out, method)


def test_a_study_resumes_without_running_again(tmp_path):
    spec = _linear_sweep(tmp_path, 1e-3, 100)
    out = str(tmp_path / 'form')
    calls = []

    def rows(part, runs):
        calls.append(len(runs))
        return linear_rows(part, runs)

    first = run_study(spec, out, method='form', rows=rows, log=lambda line: None)
    ran = sum(calls)
    assert ran == first['estimate'].runs
    os.remove(os.path.join(out, 'results.parquet'))
    again = run_study(spec, out, method='form', rows=rows, log=lambda line: None)
    assert sum(calls) == ran   # every run read back from the parts
    assert again['estimate'] == first['estimate']
    # another method in the same folder is refused
    with pytest.raises(Exception, match='holds another study'):
        run_study(spec, out, method='nais', rows=rows, log=lambda line: None)


@pytest.mark.parametrize('probability', [1e-2] + ([1e-5] if LONG else []))
def test_form_on_the_store_scenario_finds_the_release_angle_s_tail(tmp_path, probability):
    """The store on its hinge: released after T s exactly when the angle exceeds a*."""
    scenario = dict(STORE, duration=0.35, dt=0.002)
    sigma, tail = 0.5, norm.isf(probability)
    path = write_sweep(tmp_path, runs=1, scenario=scenario, vary={
        ANGLE: {'normal': [MEAN, sigma]}}, metrics={'at': []},
        criteria={'early': 'release_pivot_time <= 1.0'})
    spec = load_sweep(path)
    # the release time at the angle a* = 10 + tail sigma is the threshold
    at_edge = dict(spec.values)
    at_edge[ANGLE] = [MEAN + sigma * tail]
    import dataclasses
    edge = run_one(dataclasses.replace(spec, values=at_edge), 0)['release_pivot_time']
    path = write_sweep(tmp_path, runs=60, seed=3, scenario=scenario, vary={
        ANGLE: {'normal': [MEAN, sigma]}}, metrics={'at': []},
        criteria={'early': f'release_pivot_time <= {edge!r}'})
    spec = load_sweep(path)
    out = str(tmp_path / 'form')
    found = run_study(spec, out, method='form', threads=2, log=lambda line: None)
    estimate = found['estimate']
    assert estimate.ci_low <= probability <= estimate.ci_high, estimate.sentence()
    table = found['table']
    assert (table['status'] == 'ok').all()
    beyond = table[ANGLE].to_numpy() > MEAN + sigma * tail
    # a run that never releases within the duration (NaN: the tail check's heavier tails
    # reach angles the pivot does not swing to) released after the edge too
    release = table['release_pivot_time'].to_numpy()
    np.testing.assert_array_equal(~(release <= edge), beyond)


def test_plot_of_a_study_prints_its_estimate_not_the_fractions_of_its_runs(tmp_path, capsys):
    from cfem_ros import study_plots
    spec = _linear_sweep(tmp_path, 1e-3, 200)
    out = str(tmp_path / 'nais')
    found = run_study(spec, out, method='nais', rows=linear_rows, log=lambda line: None)
    capsys.readouterr()
    paths = study_plots.write_sweep_figures(out, str(tmp_path / 'figures'))
    printed = capsys.readouterr().out.splitlines()
    assert printed == ['the runs of --method nais are not drawn from the inputs: their failure '
                       'fractions are not P(fail)', found['estimate'].sentence()]
    assert any(p.endswith('criteria.png') for p in paths)


def test_form_on_a_criterion_that_hardly_changes_says_so_and_keeps_its_runs(tmp_path):
    """The clearance moves 1e-9 m per degree: FORM names the cause, not OpenTURNS."""
    from cfem_ros.study.resources import MethodFailed
    spec = _linear_sweep(tmp_path, 1e-3, 10)

    def flat_rows(spec, runs):
        rows = linear_rows(spec, runs)
        for row in rows:
            row['clearance_store_pylon_min'] = 0.2 - 1e-9 * (row[ANGLE] - MEAN)
        return rows

    out = str(tmp_path / 'form')
    with pytest.raises(MethodFailed) as raised:
        run_study(spec, out, method='form', rows=flat_rows, log=lambda line: None)
    message = str(raised.value)
    assert 'hardly changes with the inputs' in message and 'OpenTURNS' not in message
    assert '--method mc' in message
