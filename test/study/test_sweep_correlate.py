# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Correlated draws (a Gaussian copula over ``correlate`` pairs): statistics, compatibility."""

import json
import math
import os

from cfem_ros import cli
from cfem_ros.study import Sweep
from cfem_ros.study.spec import load_sweep
import numpy as np
import pandas as pd
import pytest
from scipy import stats
from sweeps import VARY, write_sweep

#: Draws for the statistical tests (drawing only, no run).
N = 20000
#: A p-value below this rejects a marginal (fixed seeds: the tests are deterministic).
P_MIN = 1e-3
MASS = 'bodies.store.mass'
ANGLE = 'joints.pivot.release.angle_deg'
ANCHOR = 'joints.pivot.anchor[0]'
#: A new key under an existing mapping, so a fourth random path (a release time trigger).
TIME = 'joints.pivot.release.time'


def _previous_draw(vary, runs, seed):
    """Draw as the sweep code did before ``correlate``: one generator per key path."""
    sequences = np.random.SeedSequence(seed).spawn(len(vary))
    drawn = {}
    for (path, spec), sequence in zip(vary.items(), sequences):
        rng = np.random.default_rng(sequence)
        (kind, p), = spec.items()
        if kind == 'uniform':
            drawn[path] = rng.uniform(p[0], p[1], size=runs).tolist()
        elif kind == 'normal':
            drawn[path] = rng.normal(p[0], p[1], size=runs).tolist()
        elif kind == 'truncnormal':
            a, b = (p[2] - p[0]) / p[1], (p[3] - p[0]) / p[1]
            drawn[path] = stats.truncnorm.rvs(a, b, loc=p[0], scale=p[1], size=runs,
                                              random_state=rng).tolist()
        elif kind == 'choice':
            drawn[path] = [p[i] for i in rng.integers(0, len(p), size=runs)]
    return drawn


def test_a_sweep_without_correlate_draws_exactly_as_before(tmp_path):
    vary = dict(VARY, duration={'choice': [0.5, 0.6]})
    spec = load_sweep(write_sweep(tmp_path, runs=50, seed=11, vary=vary))
    expected = _previous_draw(vary, 50, 11)
    for path, values in expected.items():
        assert spec.values[path] == values * 2, path   # bit for bit; the dt grid repeats them
    assert spec.correlations == []
    assert 'correlate' not in json.loads(spec.describe())   # its hash is the one it had
    # correlating two key paths leaves the others' draws alone
    joined = load_sweep(write_sweep(tmp_path, runs=50, seed=11, vary=vary,
                                    correlate=[[MASS, ANCHOR, 0.7]]))
    for path in (ANGLE, 'duration', 'dt'):
        assert joined.values[path] == spec.values[path]
    assert joined.values[ANCHOR] != spec.values[ANCHOR]
    assert joined.digest() != spec.digest()


def _spearman_bound(rho_s, n):
    """Four standard errors of Spearman's rho on Fisher's z scale (Bonett and Wright 2000)."""
    return 4 * math.sqrt((1 + rho_s ** 2 / 2) / (n - 3))


@pytest.mark.parametrize('rho', [0.9, -0.6, 0.0])
def test_correlated_normals_have_rho_and_keep_their_marginals(tmp_path, rho):
    spec = load_sweep(write_sweep(tmp_path, runs=N, seed=5, vary={
        MASS: {'normal': [907.1848, 10.0]}, ANCHOR: {'normal': [-0.3292, 0.01]}},
        correlate=[[MASS, ANCHOR, rho]]))
    mass, anchor = np.array(spec.values[MASS]), np.array(spec.values[ANCHOR])
    assert abs(np.corrcoef(mass, anchor)[0, 1] - rho) < 4 * (1 - rho ** 2) / math.sqrt(N)
    assert stats.kstest(mass, stats.norm(907.1848, 10.0).cdf).pvalue > P_MIN
    assert stats.kstest(anchor, stats.norm(-0.3292, 0.01).cdf).pvalue > P_MIN


@pytest.mark.parametrize('rho', [0.8, -0.4])
def test_uniforms_have_the_copula_s_spearman_rho(tmp_path, rho):
    spec = load_sweep(write_sweep(tmp_path, runs=N, seed=9, vary={
        ANGLE: {'uniform': [8, 12]}, TIME: {'uniform': [0.1, 0.2]}},
        correlate=[[ANGLE, TIME, rho]]))
    angle, time = np.array(spec.values[ANGLE]), np.array(spec.values[TIME])
    expected = 6 / math.pi * math.asin(rho / 2)
    measured = stats.spearmanr(angle, time).statistic
    assert abs(math.atanh(measured) - math.atanh(expected)) < _spearman_bound(expected, N)
    assert stats.kstest(angle, stats.uniform(8, 4).cdf).pvalue > P_MIN
    assert stats.kstest(time, stats.uniform(0.1, 0.1).cdf).pvalue > P_MIN
    assert angle.min() >= 8 and angle.max() < 12


def test_a_truncnormal_stays_in_its_bounds_with_its_distribution(tmp_path):
    low, high = -0.335, -0.31
    spec = load_sweep(write_sweep(tmp_path, runs=N, seed=2, vary={
        MASS: {'normal': [907.1848, 10.0]}, ANCHOR: {'truncnormal': [-0.33, 0.01, low, high]},
        ANGLE: {'uniform': [8, 12]}},
        correlate=[[MASS, ANCHOR, -0.95], [ANCHOR, ANGLE, 0.2]]))
    anchor = np.array(spec.values[ANCHOR])
    assert anchor.min() >= low and anchor.max() <= high
    assert anchor.min() < low + 0.001   # the lower bound is where the density is highest
    a, b = (low + 0.33) / 0.01, (high + 0.33) / 0.01
    assert stats.kstest(anchor, stats.truncnorm(a, b, loc=-0.33, scale=0.01).cdf).pvalue \
        > P_MIN
    # the copula's rank correlation survives the truncation (ranks follow the normals)
    mass = np.array(spec.values[MASS])
    expected = 6 / math.pi * math.asin(-0.95 / 2)
    measured = stats.spearmanr(mass, anchor).statistic
    assert abs(math.atanh(measured) - math.atanh(expected)) < _spearman_bound(expected, N)
    assert stats.kstest(mass, stats.norm(907.1848, 10.0).cdf).pvalue > P_MIN


def test_rho_1_moves_two_paths_together_and_a_choice_follows_in_its_order(tmp_path):
    choices = ['low', 'mid', 'high']
    spec = load_sweep(write_sweep(tmp_path, runs=N, seed=4, vary={
        MASS: {'normal': [907.1848, 10.0]}, ANCHOR: {'normal': [-0.3292, 0.01]},
        'name': {'choice': choices}},
        correlate=[[MASS, ANCHOR, 1], [MASS, 'name', 1], [ANCHOR, 'name', 1]]))
    mass, anchor = np.array(spec.values[MASS]), np.array(spec.values[ANCHOR])
    np.testing.assert_allclose((anchor + 0.3292) / 0.01, (mass - 907.1848) / 10.0,
                               rtol=0, atol=1e-9)
    index = np.array([choices.index(v) for v in spec.values['name']])
    order = np.argsort(mass)
    assert (np.diff(index[order]) >= 0).all()   # a choice's values in their listed order
    counts = np.bincount(index, minlength=3) / N
    assert np.all(np.abs(counts - 1 / 3) < 4 * math.sqrt(2 / 9 / N))   # still equally likely
    cut = stats.norm(907.1848, 10.0).ppf(1 / 3)   # the first third of the normal: 'low'
    assert (index[mass < cut - 1e-6] == 0).all() and (index[mass > cut + 1e-6] > 0).all()


def test_the_same_pair_twice_with_the_same_rho_is_one_pair(tmp_path):
    spec = load_sweep(write_sweep(tmp_path, runs=10, correlate=[
        [MASS, ANGLE, 0.5], [ANGLE, MASS, 0.5]]))
    assert spec.correlations == [(MASS, ANGLE, 0.5)]


def test_correlated_draws_are_the_same_with_1_and_2_workers(tmp_path):
    distributed = pytest.importorskip('dask.distributed')
    path = write_sweep(tmp_path, runs=3, correlate=[[MASS, ANCHOR, -0.8], [MASS, ANGLE, 0.6]])
    sweep = Sweep.from_file(path)
    tables = []
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        for workers in (2, 1):
            if workers == 1:
                client.retire_workers([sorted(client.scheduler_info()['workers'])[0]])
            assert len(client.scheduler_info()['workers']) == workers
            tables.append(sweep.run(client, str(tmp_path / f'w{workers}')))
    pd.testing.assert_frame_equal(tables[0], tables[1], check_exact=True)
    assert len(tables[0]) == 6 and (tables[0]['status'] == 'ok').all()
    assert tables[0][MASS].tolist() == load_sweep(path).values[MASS]   # drawn once, from seed


@pytest.mark.parametrize('correlate, key, words', [
    ({'a': 1}, 'correlate', 'is '),
    ([[MASS, ANGLE]], 'correlate[0]', 'is '),
    ([[MASS, ANGLE, 0.5, 1]], 'correlate[0]', 'is '),
    ([[f'{MASS}, {ANGLE}', 0.5]], 'correlate[0]', 'is '),
    ([[7, ANGLE, 0.5]], 'correlate[0][0]', 'not a key path under vary'),
    ([['bodies.store.mas', ANGLE, 0.5]], 'correlate[0][0]', 'not a key path under vary'),
    ([[MASS, 'duration', 0.5]], 'correlate[0][1]', 'not a key path under vary'),
    ([['dt', MASS, 0.5]], 'correlate[0][0]', 'is a grid, not a random draw'),
    ([[MASS, ANGLE, 1.5]], 'correlate[0][2]', 'is 1.5'),
    ([[MASS, ANGLE, -1.01]], 'correlate[0][2]', 'is -1.01'),
    ([[MASS, ANGLE, 'high']], 'correlate[0][2]', "is 'high'"),
    ([[MASS, ANGLE, float('nan')]], 'correlate[0][2]', 'is nan'),
    ([[MASS, ANGLE, True]], 'correlate[0][2]', 'is True'),
    ([[MASS, MASS, 0.5]], 'correlate[0]', 'with itself'),
    ([[MASS, ANGLE, 0.5], [ANCHOR, MASS, 0.2], [ANGLE, MASS, 0.6]], 'correlate[2]',
     'correlate[0] gave 0.5'),
    ([[MASS, ANGLE, 0.9], [ANGLE, ANCHOR, 0.9], [MASS, ANCHOR, -0.9]], 'correlate',
     f'the correlations of {MASS}, {ANGLE}, {ANCHOR} make a matrix that is not positive '
     'semi-definite (smallest eigenvalue -0.8)'),
])
def test_bad_correlations_exit_2_before_any_run(tmp_path, capsys, correlate, key, words):
    path = write_sweep(tmp_path, correlate=correlate)
    out = str(tmp_path / 'out')
    assert cli.main(['sweep', path, '-o', out]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith(f'ERROR: {path}: {key}: '), err
    assert words in err and '; expected ' in err, err
    assert not os.path.exists(os.path.join(out, 'parts'))
