# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The release envelope (SPEC section 14): its table, chart, command line and report."""

import json
import math
import os

from cfem_ros import cli
from cfem_ros.study import envelope
from cfem_ros.study.errors import SweepError
from cfem_ros.study.methods import write_estimate
from cfem_ros.study.reliability import mc_estimate
from cfem_ros.study.spec import load_sweep
from cfem_ros.study.sweep import Sweep
import pandas as pd
import pytest
from sweeps import write_sweep
import yaml

#: A store on a hook under an aircraft flying a condition, released at a dispersed time.
SCENARIO = {
    'name': 'envelope_test', 'duration': 0.15, 'dt': 0.002,
    'flight': {'carrier': 'aircraft', 'mach': 0.8, 'altitude': 3000.0, 'load_factor': 2.0},
    'bodies': {'aircraft': {'position': [0.0, 0.0, 0.0]},
               'store': {'mass': 907.1848, 'inertia': [27.1164, 488.0944, 488.0944],
                         'position': [0.0, 0.0, 1.0]}},
    'joints': {'hook': {'type': 'fixed', 'parent': 'aircraft', 'child': 'store',
                        'anchor': [0.0, 0.0, 0.8], 'release': {'time': 0.02}}},
}
GRIDS = {'flight.mach': {'grid': [0.6, 0.9]}, 'flight.load_factor': {'grid': [1.0, 3.0]}}
DISPERSIONS = {'joints.hook.release.time': {'uniform': [0.01, 0.05]},
               'bodies.store.mass': {'uniform': [890.0, 925.0]}}
#: The store falls 0.5 n g t^2 below the pulling-up aircraft: n = 1 fails, n = 3 does not.
EXTRA = {'rate_hz': 100, 'criteria': {'drop': 'store_at_0.15_z >= 1.15'}, 'target': 0.6}
METRICS = {'at': [{'time': 0.15, 'body': 'store', 'relative_to': 'aircraft'}]}
AXES = ['flight.mach', 'flight.load_factor']


def _sweep(folder, runs=4):
    return write_sweep(folder, runs=runs, seed=3, scenario=SCENARIO,
                       vary={**GRIDS, **DISPERSIONS}, metrics=METRICS, **EXTRA)


def test_the_envelope_table_is_the_same_sweeps_run_one_by_one(tmp_path):
    """Each point's row and runs equal a sweep file written with the point's condition."""
    (tmp_path / 'env').mkdir()
    found = envelope.load_envelope(_sweep(tmp_path / 'env'), AXES)
    assert len(found.points) == 4
    table = envelope.run_envelope(found, str(tmp_path / 'out'))
    assert table.equals(pd.read_parquet(tmp_path / 'out' / envelope.ENVELOPE))
    assert set(table['decision']) >= {'does_not_meet'} and len(set(table['decision'])) > 1
    for k, values in enumerate(found.points):
        folder = tmp_path / f'alone_{k}'
        folder.mkdir()
        scenario = json.loads(json.dumps(SCENARIO))
        scenario['flight'].update(mach=values[0], load_factor=values[1])
        alone = load_sweep(write_sweep(folder, runs=4, seed=3, scenario=scenario,
                                       vary=DISPERSIONS, metrics=METRICS, **EXTRA))
        runs = Sweep(alone).run(None, str(folder / 'out'), threads=1)
        estimate = mc_estimate(alone, runs)
        write_estimate(str(folder / 'out'), estimate, alone.target)
        point = pd.read_parquet(tmp_path / 'out' / table['folder'][k] / 'results.parquet')
        pd.testing.assert_frame_equal(point, runs)
        row = table.iloc[k]
        assert (row['flight.mach'], row['flight.load_factor']) == values
        assert row['probability'] == estimate.probability
        assert row['p_upper'] == estimate.p_upper
        assert row['decision'] == estimate.decision
        assert row['runs'] == 4 and row['failed_runs'] == round(4 * estimate.probability)
        assert row['pass_fraction'] == 1.0 - estimate.probability


def test_a_folder_cut_short_resumes_to_the_table_of_an_uncut_run(tmp_path):
    """Points done, a point with some runs saved, points not started: the same table."""
    import glob
    found = envelope.load_envelope(_sweep(tmp_path, runs=3), AXES)
    whole = envelope.run_envelope(found, str(tmp_path / 'whole'))
    cut = str(tmp_path / 'cut')
    envelope.write_manifest(found, cut, 'mc')
    envelope.run_point(found, 0, cut)
    envelope.run_point(found, 1, cut)
    parts = sorted(glob.glob(os.path.join(envelope.point_folder(cut, 1), 'parts', '*')))
    assert len(parts) == 3   # a part per run in this process: drop all but one, and point 1's
    for path in parts[1:]:   # table and estimate, as a kill in the middle of it would
        os.remove(path)
    for name in ('results.parquet', 'estimate.json'):
        os.remove(os.path.join(envelope.point_folder(cut, 1), name))
    assert not envelope.point_done(cut, 1) and envelope.point_done(cut, 0)
    resumed = envelope.run_envelope(found, cut)
    pd.testing.assert_frame_equal(resumed, whole)


def test_a_condition_the_method_cannot_answer_is_undecided_with_why_and_no_number(
        tmp_path, monkeypatch):
    """A rare-event method that finds nothing at one point: NaN, undecided, the reason."""
    from cfem_ros.separation.envelope_chart import envelope_figure
    from cfem_ros.study.resources import MethodFailed
    import matplotlib.pyplot as plt
    found = envelope.load_envelope(_sweep(tmp_path, runs=2), AXES)
    real = envelope.run_point

    def fails_at_one(env, k, outdir, **options):
        if k == 1:
            raise MethodFailed('sweep.yaml', '--method form', 'found no design point', 'nais')
        return real(env, k, outdir)
    monkeypatch.setattr(envelope, 'run_point', fails_at_one)
    lines = []
    table = envelope.run_envelope(found, str(tmp_path / 'out'), method='form', log=lines.append)
    row = table.iloc[1]
    assert row['decision'] == 'undecided' and 'found no design point' in row['note']
    assert all(math.isnan(row[c]) for c in ('probability', 'p_upper', 'pass_fraction'))
    assert (table.drop(index=1)['note'] == '').all()
    assert table.drop(index=1)['probability'].notna().all()
    assert any('point 2/4' in line and 'no estimate' in line for line in lines)
    fig = envelope_figure(table, AXES, target=0.6)
    assert 'no estimate' in [t.get_text() for t in fig.axes[0].texts]
    plt.close(fig)


def test_an_axis_that_is_not_a_grid_of_vary_is_refused_before_any_run(tmp_path):
    path = _sweep(tmp_path)
    with pytest.raises(SweepError, match=r'vary\.bodies\.store\.mass: is varied as uniform '
                       r'\(--y bodies\.store\.mass\).*grids here: flight\.mach, '
                       r'flight\.load_factor'):
        envelope.load_envelope(path, ['flight.mach', 'bodies.store.mass'])
    with pytest.raises(SweepError, match=r'vary\.flight\.altitude: is not in vary'):
        envelope.load_envelope(path, ['flight.mach', 'flight.altitude'])


def test_a_condition_the_scenario_refuses_is_named_before_any_run(tmp_path):
    path = write_sweep(tmp_path, runs=2, seed=3, scenario=SCENARIO, metrics=METRICS,
                       vary={'flight.mach': {'grid': [0.6, 12.0]},
                             'flight.load_factor': {'grid': [1.0]}, **DISPERSIONS}, **EXTRA)
    with pytest.raises(SweepError, match=r'the point flight\.mach = 12\.0, '
                       r'flight\.load_factor = 1\.0 gives a scenario that is refused: .*'
                       r'flight\.mach'):
        envelope.load_envelope(path, AXES)


def _chart_table(target=0.3, loads=(1.0, 3.0)):
    rows = []
    for n in loads:
        for mach in (0.6, 0.95):
            for altitude in (1500.0, 9000.0):
                p = min(1.0, 0.1 * altitude / 1500.0 / n)
                decision = 'does_not_meet' if p >= target else 'meets'
                rows.append({'flight.mach': mach, 'flight.altitude': altitude,
                             'flight.load_factor': n, 'probability': p,
                             'p_upper': min(1.0, p + 0.05), 'pass_fraction': 1.0 - p,
                             'runs': 20, 'decision': decision})
    return pd.DataFrame(rows)


def test_the_chart_has_a_panel_per_third_axis_value_and_the_target_line_where_crossed():
    from cfem_ros.separation.envelope_chart import envelope_figure
    from matplotlib.contour import ContourSet
    import matplotlib.pyplot as plt
    fig = envelope_figure(_chart_table(), ['flight.mach', 'flight.altitude',
                                           'flight.load_factor'], target=0.3)
    panels = fig.axes
    assert [ax.get_title() for ax in panels] == ['load factor n = 1 g', 'load factor n = 3 g']
    assert panels[0].get_xlabel() == 'Mach number'
    assert panels[0].get_ylabel() == 'altitude [m]'
    # n = 1: P from 0.1 to 0.6 crosses 0.3; n = 3: P from 0.033 to 0.2 never reaches it
    lines = [[c for c in ax.get_children() if isinstance(c, ContourSet)] for ax in panels]
    assert len(lines[0]) == 2 and not lines[1]
    assert 'not crossed' in ' '.join(t.get_text() for t in panels[1].texts)
    plt.close(fig)
    plain = _chart_table(loads=(1.0,)).assign(decision='no_target')
    fig = envelope_figure(plain, ['flight.mach', 'flight.altitude'])   # no target
    assert fig.axes[-1].get_ylabel() == 'pass fraction (no target: no decision)'
    assert 'pass 0.90' in ' '.join(t.get_text() for t in fig.axes[0].texts)
    plt.close(fig)
    one = _chart_table(loads=(1.0,))
    one = one[one['flight.mach'] == 0.6]
    fig = envelope_figure(one, ['flight.mach', 'flight.altitude'], target=0.3)
    assert 'one value on an axis' in ' '.join(t.get_text() for t in fig.axes[0].texts)
    plt.close(fig)


def test_cfem_sim_envelope_runs_resumes_and_reports(tmp_path, capsys):
    path = _sweep(tmp_path, runs=2)
    out = str(tmp_path / 'out')
    args = ['envelope', path, '-o', out, '--x', 'flight.mach', '--y', 'flight.load_factor',
            '--workers', '1']
    assert cli.main(args) == 0
    said = capsys.readouterr()
    for k, where in enumerate(('0.6, flight.load_factor = 1', '0.6, flight.load_factor = 3',
                               '0.9, flight.load_factor = 1', '0.9, flight.load_factor = 3')):
        assert f'point {k + 1}/4 (flight.mach = {where})' in said.err
    assert 'envelope: 8/8 runs, 0 failed' in said.err   # one progress line for all
    assert os.path.getsize(os.path.join(out, 'envelope.png')) > 10_000
    first = pd.read_parquet(os.path.join(out, 'envelope.parquet'))
    here = envelope.run_envelope(envelope.load_envelope(path, AXES), str(tmp_path / 'here'))
    pd.testing.assert_frame_equal(first, here)   # the points at once on Dask: the same table
    assert cli.main(args) == 0
    assert '4 conditions (flight.mach x flight.load_factor), 2 runs each (mc), 4 already ' \
        'in' in capsys.readouterr().err
    pd.testing.assert_frame_equal(first, pd.read_parquet(os.path.join(out, 'envelope.parquet')))
    figures = str(tmp_path / 'figures')   # cfem-sim plot of the folder draws its chart
    assert cli.main(['plot', out, '-o', figures]) == 0
    assert os.listdir(figures) == ['envelope.png']
    page = str(tmp_path / 'report.html')
    assert cli.main(['report', out, '-o', page]) == 0
    text = open(page, encoding='utf-8').read()
    assert '<h2>Release envelope</h2>' in text and 'data:image/png;base64,' in text
    assert text.count('<code>points/point_000') == 4
    run = str(tmp_path / 'run.mcap')   # a run of a point, again alone, with its condition
    assert cli.main(['rerun', os.path.join(out, 'points', 'point_0003'), '1', '-o', run]) == 0
    assert 'status ok' in capsys.readouterr().out
    with open(path) as stream:   # another grid in the same folder: refused, nothing run
        sweep = yaml.safe_load(stream)
    sweep['vary']['flight.mach'] = {'grid': [0.6, 0.7]}
    with open(path, 'w') as stream:
        yaml.safe_dump(sweep, stream)
    capsys.readouterr()
    assert cli.main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith('ERROR: ') and 'holds another envelope' in err
    assert err.count('\n') == 1


def test_cfem_sim_envelope_refuses_an_axis_with_one_error_line(tmp_path, capsys):
    path = _sweep(tmp_path)
    status = cli.main(['envelope', path, '-o', str(tmp_path / 'out'), '--x', 'flight.mach',
                       '--y', 'flight.altitude'])
    err = capsys.readouterr().err
    assert status == 2 and err.count('\n') == 1
    assert err.startswith('ERROR: ') and 'vary.flight.altitude: is not in vary' in err
    assert not os.path.exists(tmp_path / 'out')
