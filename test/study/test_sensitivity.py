# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Sensitivity designs through the study pipeline, on the Ishigami function.

Three key paths of the sweep are drawn U(-pi, pi) and the metric is
Ishigami's f(x1, x2, x3) = sin x1 + 7 sin^2 x2 + 0.1 x3^4 sin x1 (a = 7,
b = 0.1), computed from each run's values (the scenario-free path: the
same Evaluator, folder and SALib analysis as a sweep); a fourth key path
is ignored. Published indices (Ishigami & Homma 1990; Saltelli et al.
2008): S1 = 0.3139, 0.4424, 0; ST = 0.5576, 0.4424, 0.2437.
"""

import os

from cfem_ros.study import load_sweep
from cfem_ros.study.methods import run_study
from cfem_ros.study.sweep import columns
import numpy as np
import pandas as pd
import pytest
from sweeps import write_sweep

PATHS = ['bodies.store.mass', 'bodies.store.inertia[0]', 'bodies.store.inertia[1]',
         'bodies.store.inertia[2]']   # the last is the dummy
S1 = [0.3139, 0.4424, 0.0]
ST = [0.5576, 0.4424, 0.2437]


def _ishigami(x1, x2, x3):
    return np.sin(x1) + 7.0 * np.sin(x2) ** 2 + 0.1 * x3 ** 4 * np.sin(x1)


def _rows(spec, runs):
    names = columns(spec)
    out = []
    for k in runs:
        values = spec.run_values(k)
        row = dict.fromkeys(names, float('nan'))
        row.update(run=k, status='ok', message='', **values)
        row['clearance_store_pylon_min'] = _ishigami(*(values[p] for p in PATHS[:3]))
        # a hinge's moment about its free axis: rounding beside its force, nothing to rank
        row['peak_force_pivot'] = 8000.0 + values[PATHS[0]]
        row['peak_moment_pivot'] = 1e-13 * (k % 3)
        out.append(row)
    return out


def _spec(folder, runs, **extra):
    return load_sweep(write_sweep(folder, runs=runs, seed=11, vary={
        p: {'uniform': [-np.pi, np.pi]} for p in PATHS}, **extra))


def test_sobol_indices_of_ishigami_hold_the_published_values(tmp_path):
    spec = _spec(tmp_path, 1024)
    out = str(tmp_path / 'sobol')
    found = run_study(spec, out, design='sobol', rows=_rows, log=lambda line: None)
    assert len(found['table']) == 1024 * (len(PATHS) + 2)
    held = pd.read_parquet(os.path.join(out, 'sensitivity.parquet'))
    rows = held[held['metric'] == 'clearance_store_pylon_min'].set_index('parameter')
    for name, s1, st in zip(PATHS, S1, ST):
        row = rows.loc[name]
        assert row['S1_low'] <= s1 <= row['S1_high'], (name, row.to_dict())
        assert row['ST_low'] <= st <= row['ST_high'], (name, row.to_dict())
        assert row['ST_high'] - row['ST_low'] < 0.2
    dummy = rows.loc[PATHS[3]]
    assert abs(dummy['S1']) < 1e-12 and abs(dummy['ST']) < 1e-12


def test_morris_ranks_ishigami_and_gives_the_dummy_nothing(tmp_path):
    spec = _spec(tmp_path, 40)
    out = str(tmp_path / 'morris')
    found = run_study(spec, out, design='morris', rows=_rows, log=lambda line: None)
    assert len(found['table']) == 40 * (len(PATHS) + 1)
    assert set(found['indices']['metric']) == {'clearance_store_pylon_min', 'peak_force_pivot'}
    rows = found['indices'].set_index('parameter')
    rows = rows[rows['metric'] == 'clearance_store_pylon_min']
    assert rows.loc[PATHS[3], 'mu_star'] == 0.0 and rows.loc[PATHS[3], 'sigma'] == 0.0
    for name in PATHS[:3]:
        assert rows.loc[name, 'mu_star'] > 1.0   # each of x1, x2, x3 matters
        # x3 acts only through its interaction with x1: sigma as large as mu*
    assert rows.loc[PATHS[2], 'sigma'] > 0.8 * rows.loc[PATHS[2], 'mu_star']


def test_correlated_inputs_are_refused_with_the_reason(tmp_path):
    spec = _spec(tmp_path, 8, correlate=[[PATHS[0], PATHS[1], 0.5]])
    with pytest.raises(Exception, match='correlate: --design sobol needs independent inputs'):
        run_study(spec, str(tmp_path / 'x'), design='sobol', rows=_rows)


@pytest.mark.parametrize('design,runs', [('morris', 3), ('sobol', 16)])
def test_indices_and_bounds_stay_within_what_the_index_can_be(tmp_path, design, runs,
                                                              monkeypatch):
    """Small designs: SALib's estimate +- half-width falls below 0 (and S above 1)."""
    from cfem_ros.study import sensitivity
    spec = _spec(tmp_path, runs)
    raw = []
    clip = sensitivity.within

    def kept(value, half, least, most):
        raw.append((value - half, value, value + half, least, most))
        return clip(value, half, least, most)

    monkeypatch.setattr(sensitivity, 'within', kept)
    found = run_study(spec, str(tmp_path / design), design=design, rows=_rows,
                      log=lambda line: None)
    # the case is one that needs it: some raw bound or estimate is outside the range
    assert any(low < least or high > most for low, _, high, least, most in raw)
    names = ['mu_star'] if design == 'morris' else ['S1', 'ST']
    for name in names:
        values = found['indices'][[f'{name}_low', name, f'{name}_high']].to_numpy()
        assert (values >= 0).all() and (np.diff(values, axis=1) >= 0).all(), name
        if design == 'sobol':
            assert (values <= 1).all(), name
    # moved into the range, not otherwise changed
    for (low, value, high, least, most), kept_row in zip(raw, _flat(found, names)):
        assert kept_row == pytest.approx([min(max(x, least), most) for x in (low, value, high)])


def _flat(found, names):
    for _, row in found['indices'].iterrows():
        for name in names:
            yield [row[f'{name}_low'], row[name], row[f'{name}_high']]
