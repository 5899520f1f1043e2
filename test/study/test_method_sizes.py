# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Each study method's smallest size, checked before any run; estimates without a failure."""

import json
import os

from cfem_ros.study.decision import up
from cfem_ros.study.errors import SweepError
from cfem_ros.study.methods import MINIMUM_RUNS, run_study
from cfem_ros.study.resources import MethodFailed
import pytest
from scipy.stats import norm
from sweeps import linear_rows, linear_sweep


@pytest.mark.parametrize('name, runs', [('subset', 10), ('subset', 11), ('subset', 5),
                                        ('subset', 105), ('nais', 1), ('nais', 99),
                                        ('form', 1), ('morris', 1), ('sobol', 4)])
def test_a_method_with_too_few_runs_is_refused_before_any_run(tmp_path, name, runs):
    # issue 41.5: subset at 10 runs answered P = 0.01 with no failure, 11 and 5 runs and
    # nais at 1 ended in OpenTURNS' TypeErrors, morris at 1 in sigma NaN
    spec = linear_sweep(tmp_path, norm.isf(1e-2), runs)
    asked = []

    def rows(part, chunk):
        asked.append(chunk)
        return linear_rows(part, chunk)

    design = name if name in ('morris', 'sobol') else None
    least, multiple = MINIMUM_RUNS[name]
    with pytest.raises(SweepError, match=rf'runs: is {runs} for {name} .*; expected at least '
                       rf'{least}'):
        run_study(spec, str(tmp_path / 'out'), method='mc' if design else name,
                  design=design, rows=rows, log=lambda line: None)
    assert not asked and not os.path.exists(tmp_path / 'out')


def test_an_estimate_without_any_failed_run_says_so(tmp_path):
    # a failure 9 standard deviations out: none of the 100 runs fails
    spec = linear_sweep(tmp_path, norm.isf(1e-19), 100)
    out = str(tmp_path / 'mc')
    found = run_study(spec, out, method='mc', rows=linear_rows, log=lambda line: None)
    estimate = found['estimate']
    assert estimate.failed_runs == 0 and found['table']['pass'].all()
    assert estimate.probability == 0.0
    # the one-sided bound of 0 failures in n runs: 1 - (1 - c)^(1 / n), said rounded upward
    assert estimate.p_upper == pytest.approx(1 - 0.05 ** (1 / 100), rel=1e-12)
    assert f'no run failed: P is at most {up(estimate.p_upper)}' in estimate.sentence()
    assert float(up(estimate.p_upper)) >= estimate.p_upper
    with open(os.path.join(out, 'estimate.json')) as stream:
        assert json.load(stream)['failed_runs'] == 0


def test_subset_at_its_smallest_size_finds_a_one_in_a_hundred_failure(tmp_path):
    spec = linear_sweep(tmp_path, norm.isf(1e-2), 100)
    found = run_study(spec, str(tmp_path / 'subset'), method='subset', rows=linear_rows,
                      log=lambda line: None)
    estimate = found['estimate']
    assert estimate.failed_runs > 0 and 'no run failed' not in estimate.sentence()
    assert 1e-3 < estimate.probability < 1e-1


def test_a_method_that_ran_and_found_nothing_is_a_failure_not_bad_input(tmp_path):
    # a criterion no value of the inputs fails: FORM stops on a zero gradient after its runs
    # (exit 1 on the command line, the runs saved), not a refusal of the input (exit 2)
    spec = linear_sweep(tmp_path, norm.isf(1e-2), 10)

    def never_failing(part, chunk):
        rows = linear_rows(part, chunk)
        for row in rows:
            row['clearance_store_pylon_min'] = 1.0
        return rows

    with pytest.raises(MethodFailed, match='does not change with the inputs') as found:
        run_study(spec, str(tmp_path / 'form'), method='form', rows=never_failing,
                  log=lambda line: None)
    assert not isinstance(found.value, SweepError)
    # the method's own reason and fix, not OpenTURNS' wrapping of them
    assert 'OpenTURNS' not in str(found.value) and '--method mc' in str(found.value)
