# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Study outputs of SPEC section 12: compound criteria, windowed metrics, invalid draws.

Criteria with and/or/parentheses against a truth table written out by
hand (and against text that is not a criterion: 1,000 terms, deep nesting,
Python); ``at ... after`` and ``extremes`` against the exported time
histories of the same run; a sweep with 10 % invalid draws against the
same sweep without them.
"""

import itertools
import os
import re

from cfem_ros import cli
from cfem_ros.study import load_sweep
from cfem_ros.study.criteria import judge, margins
from cfem_ros.study.errors import SweepError
from cfem_ros.study.expressions import MAX_DEPTH, parse_criterion
from cfem_ros.study.reliability import mc_estimate
from cfem_ros.study.runs import run_one
from cfem_ros.study.sweep import Sweep
import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation, Slerp
import yaml

#: Three rules, each true exactly when its column is 1 (a NaN fails).
RULES = {'A': 'a >= 0.5', 'B': 'abs(b) > 0.5', 'C': 'c <= -0.5'}
CASES = [
    ('A and B or C', lambda a, b, c: (a and b) or c),
    ('A or B and C', lambda a, b, c: a or (b and c)),
    ('(A or B) and C', lambda a, b, c: (a or b) and c),
    ('A and (B or (C))', lambda a, b, c: a and (b or c)),
    ('((A)) or ((B) and (C or A))', lambda a, b, c: a or (b and (c or a))),
]


def _table():
    """One run per row of the truth table of A, B, C, then a failed run and a NaN run."""
    rows = []
    for a, b, c in itertools.product((False, True), repeat=3):
        rows.append({'a': 1.0 if a else 0.0, 'b': -1.0 if b else 0.2, 'c': -1.0 if c else 0.0,
                     'status': 'ok'})
    rows.append({'a': 1.0, 'b': 1.0, 'c': -1.0, 'status': 'failed'})
    rows.append({'a': np.nan, 'b': 1.0, 'c': -1.0, 'status': 'ok'})
    return pd.DataFrame(rows)


@pytest.mark.parametrize('text,truth', CASES)
def test_criteria_combine_rules_as_the_truth_table_says(text, truth):
    written = text
    for name, rule in RULES.items():
        written = written.replace(name, rule)
    criterion = parse_criterion('c', written)
    table = _table()
    expected = [truth(*bits) for bits in itertools.product((False, True), repeat=3)]
    expected += [False, truth(False, True, True)]   # failed: fails; NaN: rule A fails
    assert list(criterion.passes_of(table)) == expected
    judged = judge(table, [criterion])
    assert list(judged['pass']) == expected
    # the margin is below 0 exactly where the criterion fails: the rare-event limit state
    ok = (table['status'] == 'ok').to_numpy()
    assert list(margins(table, [criterion]) >= 0) == [e and o for e, o in zip(expected, ok)]
    assert criterion.columns == ['a', 'b', 'c']


def test_a_thousand_terms_parse_and_judge_without_recursion():
    columns = [f'm{i}' for i in range(1000)]
    table = pd.DataFrame({c: [float(i), float(i) - 1.0] for i, c in enumerate(columns)})
    table['status'] = 'ok'
    every = parse_criterion('all', ' and '.join(f'{c} >= {i}' for i, c in enumerate(columns)))
    assert len(every.columns) == 1000
    assert list(every.passes_of(table)) == [True, False]
    one = parse_criterion('any', ' or '.join(f'{c} >= {i}' for i, c in enumerate(columns)))
    assert list(one.passes_of(table)) == [True, False]
    nested = '(' * MAX_DEPTH + 'm0 >= 0' + ')' * MAX_DEPTH
    assert list(parse_criterion('deep', nested).passes(table['m0'])) == [True, False]


@pytest.mark.parametrize('text,where', [
    ("__import__('os').system('touch HACKED') >= 0", "unexpected \"'\""),
    ('a >= 1; import os', "unexpected ';'"),
    ('a >= 1 and', 'expected'),
    ('a >= 1 or or b < 2', 'expected'),
    ('abs(a >= 1', "')'"),
    ('a >= b', 'a number'),
    ('a == 1', "unexpected '='"),
    ('(a >= 1', "')'"),
    ('a >= 1)', "'and', 'or' or the end"),
    ('a >= 1e999', 'finite'),
    ('(' * (MAX_DEPTH + 1) + 'a >= 1' + ')' * (MAX_DEPTH + 1), 'nested deeper'),
    ('(' * 100_000, 'nested deeper'),
    ('a >= 1 and ' * 20_000 + 'a >= 1', 'characters long'),
])
def test_text_that_is_not_a_criterion_is_refused_and_never_run(text, where, tmp_path):
    os.chdir(tmp_path)
    with pytest.raises(ValueError, match=re.escape(where)):
        parse_criterion('x', text)
    assert not (tmp_path / 'HACKED').exists()


SCENARIO = {
    'name': 'drop', 'gravity': [0, 0, 9.80665], 'duration': 0.3, 'dt': 0.001,
    'bodies': {
        'aircraft': {'motion': {'velocity': [250.0, 0, 0]}},
        'store': {'mass': 900.0, 'inertia': [27.0, 480.0, 480.0], 'position': [0, 0, 1.5],
                  'velocity': [250.0, 0, 0]}},
    'joints': {
        'fwd': {'type': 'ball', 'parent': 'aircraft', 'child': 'store',
                'anchor': [0.4, 0, 1.25]},
        'aft': {'type': 'ball', 'parent': 'aircraft', 'child': 'store',
                'anchor': [-0.4, 0, 1.25]}},
    'release_groups': {'station_1': {'joints': ['fwd', 'aft'], 'release': {'time': 0.0525}}},
    'wrenches': [{'name': 'aft_ejector', 'body': 'store', 'point': [-0.33, 0, -0.25],
                  'force': [0, 0, 40000], 'stroke': 0.1, 'reacts_on': 'aircraft',
                  'start': {'release': 'station_1'}}]}
WINDOW = {'from': {'release': 'station_1'}, 'to': {'release': 'station_1', 'delay': 0.15}}
METRICS = {'at': [{'time': 0.1, 'after': 'station_1', 'body': 'store',
                   'relative_to': 'aircraft'}],
           'extremes': [dict(body='store', relative_to='aircraft', **WINDOW)]}


def _sweep(folder, grid, runs=2, criteria=None) -> str:
    folder.mkdir(exist_ok=True)
    (folder / 'scenario.yaml').write_text(yaml.safe_dump(SCENARIO, sort_keys=False))
    sweep = {'scenario': 'scenario.yaml', 'runs': runs, 'seed': 5, 'rate_hz': 100,
             'vary': {'wrenches[0].force[2]': {'uniform': [20000, 60000]},
                      'bodies.store.inertia[0]': {'grid': grid}},
             'metrics': METRICS}
    if criteria:
        sweep['criteria'] = criteria
    path = folder / 'sweep.yaml'
    path.write_text(yaml.safe_dump(sweep, sort_keys=False))
    return str(path)


def test_windowed_metrics_are_the_exported_histories_at_the_release_s_times(tmp_path):
    spec = load_sweep(_sweep(tmp_path, [27.0], runs=1))
    recording = str(tmp_path / 'run.mcap')
    row = run_one(spec, 0, record=recording)
    assert row['status'] == 'ok'
    assert cli.main(['export', recording, '-o', str(tmp_path / 'h.parquet'),
                     '--relative-to', 'aircraft']) == 0
    table = pd.read_parquet(tmp_path / 'h.parquet')
    since = table['time_from_release'].to_numpy()
    # the release falls between two samples: the state 0.1 s after it too
    assert 0.0 < since[np.isfinite(since)][0] < 0.01
    for c in ('x', 'y', 'z'):
        want = np.interp(0.1, since[np.isfinite(since)], table[f'store_{c}'][np.isfinite(since)])
        assert row[f'store_at_0.1r_{c}'] == pytest.approx(want, abs=1e-12)
    after = np.isfinite(since)
    k = int(np.searchsorted(since[after], 0.1))
    euler = table[['store_yaw_deg', 'store_pitch_deg', 'store_roll_deg']].to_numpy()[after]
    turn = Slerp(since[after][k - 1:k + 1],
                 Rotation.from_euler('ZYX', euler[k - 1:k + 1], degrees=True))(0.1)
    want = turn.as_euler('ZYX', degrees=True)[::-1]
    got = [row[f'store_at_0.1r_{c}_deg'] for c in ('roll', 'pitch', 'yaw')]
    np.testing.assert_allclose(got, want, atol=1e-9)
    assert abs(got[1]) > 1.0   # it pitched
    inside = (since >= 0) & (since <= 0.15 + 1e-9)
    for q in ('x', 'z', 'pitch_deg', 'q'):
        column = table[f'store_{q}'][inside]
        assert row[f'store_min_{q}'] == pytest.approx(column.min(), abs=1e-12)
        assert row[f'store_max_{q}'] == pytest.approx(column.max(), abs=1e-12)
    assert row['store_max_q'] > 10.0   # deg/s: the ejector pitched it


def test_invalid_draws_are_left_out_of_p_and_its_interval(tmp_path, capsys):
    valid = [27.0, 26.0, 25.0, 28.0, 29.0, 30.0, 31.0, 32.0, 33.0]
    criteria = {'deep': 'store_at_0.1r_z >= 1.74 and abs(store_max_pitch_deg) <= 60'}
    with_invalid = _sweep(tmp_path / 'a', valid + [2000.0], criteria=criteria)
    alone = _sweep(tmp_path / 'b', valid, criteria=criteria)
    a = Sweep.from_file(with_invalid).run(None, str(tmp_path / 'a' / 'out'), threads=1)
    b = Sweep.from_file(alone).run(None, str(tmp_path / 'b' / 'out'), threads=1)
    invalid = a[a['status'] == 'invalid']
    assert len(a) == 20 and list(invalid['run']) == [18, 19]   # the last grid point
    assert invalid['message'].str.contains('triangle').all()
    assert invalid['pass'].isna().all() and (invalid['failed_criterion'] == 'invalid').all()
    ran = a[a['status'] != 'invalid'].reset_index(drop=True)
    assert ran.drop(columns='run').equals(b.drop(columns='run'))   # the same draws, run alike
    failing = int((~b['pass'].to_numpy(dtype=bool)).sum())
    assert 0 < failing < len(b)
    ea, eb = (mc_estimate(load_sweep(p), t) for p, t in ((with_invalid, a), (alone, b)))
    assert (ea.probability, ea.ci_low, ea.ci_high, ea.runs) == \
        (eb.probability, eb.ci_low, eb.ci_high, eb.runs) == \
        (failing / 18, eb.ci_low, eb.ci_high, 18)
    # a method that would need them says so
    from cfem_ros.study.evaluate import refuse_invalid
    with pytest.raises(SweepError, match='subset drew run 18.*--method mc'):
        refuse_invalid(load_sweep(with_invalid), 'subset', a.to_dict('records'))


def test_the_envelope_is_the_median_and_band_of_the_recorded_runs(tmp_path):
    from cfem_ros.separation import envelopes
    path = _sweep(tmp_path, [27.0], runs=3,
                  criteria={'deep': 'store_at_0.1r_z >= 1.74 and abs(store_max_pitch_deg) <= 60'})
    outdir = str(tmp_path / 'out')
    table = Sweep.from_file(path).run(None, outdir, record='all', threads=1)
    histories = []
    for k in range(3):
        out = tmp_path / f'run_{k}.parquet'
        assert cli.main(['export', f'{outdir}/runs/run_{k}.mcap', '-o', str(out),
                         '--relative-to', 'aircraft']) == 0
        history = pd.read_parquet(out)
        release = (history['time'] - history['time_from_release']).dropna().iloc[0]
        histories.append((history['time'] - release, history['store_z']))   # all samples
    grid, median, low, high = envelopes.envelope(
        [envelopes.history(f'{outdir}/runs/run_{k}.mcap', 'store', 'aircraft')
         for k in range(3)], 0.01)
    assert grid[0] == 0.0 and grid[-1] > 0.2
    z = np.array([np.interp(grid, since, values) for since, values in histories])
    np.testing.assert_allclose(median[:, 2], np.median(z, axis=0), atol=1e-12)
    np.testing.assert_allclose(low[:, 2], np.percentile(z, 5, axis=0), atol=1e-12)
    np.testing.assert_allclose(high[:, 2], np.percentile(z, 95, axis=0), atol=1e-12)
    assert np.ptp(z[:, -1]) > 0.01   # the runs differ
    # the worst run by the first criterion: the least margin
    judged = judge(table, load_sweep(path).criteria)
    worst, name = envelopes.worst_run(outdir, range(3))
    assert name == 'deep' and worst == int(np.argmin(margins(judged, load_sweep(path).criteria)))
    figures = envelopes.report_figures(outdir, str(tmp_path))
    assert [os.path.basename(p) for p in figures] == ['envelope_relative_aircraft.png',
                                                      f'snapshots_run_{worst}.png']
