# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The figures of a sweep folder: z down as in a run's figures, rounding drawn as rounding."""

import copy
import glob
import json
import os

from cfem_ros import cli, study_plots
from cfem_ros.recording.analysis import open_run
from cfem_ros.study import Sweep
from matplotlib.collections import LineCollection
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation
from sweeps import STORE, write_sweep


def test_the_envelope_draws_z_down_when_gravity_is_plus_z(tmp_path):
    scenario = copy.deepcopy(STORE)
    scenario['duration'] = 0.2
    path = write_sweep(tmp_path, runs=1, scenario=scenario,
                       vary={'gravity[2]': {'grid': [9.80665, -9.80665]}})
    out = str(tmp_path / 'sweep')
    table = Sweep.from_file(path).run(None, out, record='all')
    assert (table['status'] == 'ok').all()
    down, up = sorted(glob.glob(os.path.join(out, 'runs', 'run_*.mcap')))
    for recording, inverted in ((down, True), (up, False)):
        fig = study_plots.envelope_figure([recording], 'pylon', 'store')
        assert [ax.yaxis_inverted() for ax in fig.axes] == [inverted, inverted]
        # the store falls along gravity: with z down it is drawn going down the page
        z = _run_lines(fig.axes[1])[0][:, 1]
        assert np.sign(z[-1] - z[0]) == np.sign(9.80665 if inverted else -9.80665)
        plt.close(fig)
    # the envelope's edges are drawn over the runs' lines, which are the whole read's
    fig = study_plots.envelope_figure([down, up], 'pylon', 'store')
    (runs,) = [c for c in fig.axes[1].collections if isinstance(c, LineCollection)]
    edges = [line for line in fig.axes[1].lines if line.get_color() == 'tab:orange']
    assert len(runs.get_segments()) == 2 and len(edges) == 2
    assert min(e.get_zorder() for e in edges) > runs.get_zorder()
    for panel, columns in ((fig.axes[0], (0, 2)), (fig.axes[1], (None, 2))):
        for drawn, path in zip(_run_lines(panel), (down, up)):
            run = open_run(path)
            store, pylon = run.bodies['store'], run.bodies['pylon']
            rel = Rotation.from_quat(pylon.quaternion).inv().apply(store.position
                                                                   - pylon.position)
            want = np.column_stack([store.time if k is None else rel[:, k] for k in columns])
            np.testing.assert_allclose(drawn, want, rtol=0, atol=1e-12)
    plt.close(fig)


def _run_lines(ax):
    """Return the runs' lines of an envelope panel: its LineCollection's (n, 2) arrays."""
    (runs,) = [c for c in ax.collections if isinstance(c, LineCollection)]
    return runs.get_segments()


def _hinge_table(moment):
    n = len(moment)
    return pd.DataFrame({'run': np.arange(n), 'status': ['ok'] * n, 'message': [''] * n,
                         'peak_force_pivot': np.linspace(8896.0, 8950.0, n),
                         'peak_moment_pivot': np.asarray(moment, dtype=float)})


def _texts(fig):
    return ' '.join(t.get_text() for ax in fig.axes for t in ax.texts)


def test_a_hinge_s_rounding_moment_is_one_value_zero_not_a_histogram():
    table = _hinge_table(np.linspace(4.5e-13, 1.4e-12, 20))
    np.testing.assert_array_equal(study_plots.drawn_values(table, 'peak_moment_pivot'), 0.0)
    fig = study_plots.histogram_figure(table, 'peak_moment_pivot')
    ax = fig.axes[0]
    assert not ax.patches                      # no bars
    assert 'P50' not in _texts(fig)
    assert 'peak_moment_pivot = 0 in every run' in _texts(fig)
    assert [line.get_xdata()[0] for line in ax.lines] == [0.0]
    plt.close(fig)
    # the table keeps its numbers
    assert table['peak_moment_pivot'].iloc[0] == 4.5e-13


def test_a_real_spread_is_a_histogram_and_a_rounding_one_a_single_value():
    table = _hinge_table(np.linspace(10.0, 30.0, 20))   # a real moment: kept
    np.testing.assert_array_equal(study_plots.drawn_values(table, 'peak_moment_pivot'),
                                  table['peak_moment_pivot'])
    fig = study_plots.histogram_figure(table, 'peak_moment_pivot')
    assert fig.axes[0].patches and 'P50 = 20' in _texts(fig)
    plt.close(fig)
    # any metric whose spread is 1e-9 of its size is one value
    table['clearance_store_pylon_min'] = 0.75 + np.linspace(0.0, 5e-10, 20)
    fig = study_plots.histogram_figure(table, 'clearance_store_pylon_min')
    assert not fig.axes[0].patches
    assert 'clearance_store_pylon_min = 0.75 in every run' in _texts(fig)
    plt.close(fig)
    table['clearance_store_pylon_min'] = 0.75 + np.linspace(0.0, 1e-6, 20)
    fig = study_plots.histogram_figure(table, 'clearance_store_pylon_min')
    assert fig.axes[0].patches
    plt.close(fig)


def _sweep_folder(folder, clearance):
    """Write a sweep folder's table and manifest (the files cfem-sim plot reads)."""
    n = len(clearance)
    table = pd.DataFrame({'run': np.arange(n), 'status': ['ok'] * n, 'message': [''] * n,
                          'bodies.store.mass': np.linspace(900.0, 910.0, n),
                          'clearance_store_pylon_min': np.asarray(clearance, dtype=float),
                          'peak_force_pivot': np.linspace(8896.0, 8950.0, n)})
    os.makedirs(folder)
    table.to_parquet(os.path.join(folder, 'results.parquet'))
    with open(os.path.join(folder, 'sweep.json'), 'w') as stream:
        json.dump({'resolved': {'vary': [['bodies.store.mass', {'uniform': [900, 910]}]]}},
                  stream)


def test_plot_says_when_the_default_clearance_does_not_vary(tmp_path, capsys):
    _sweep_folder(tmp_path / 'same', [0.75] * 6)
    figures = tmp_path / 'figures'
    assert cli.main(['plot', str(tmp_path / 'same'), '-o', str(figures)]) == 0
    err = capsys.readouterr().err
    assert err.splitlines() == [
        'cfem-sim plot: clearance_store_pylon_min is the same in every run (0.75); '
        'the scatter figure draws peak_force_pivot instead (choose with --metric)']
    assert sorted(os.listdir(figures)) == ['hist_peak_force_pivot.png',
                                           'scatter_peak_force_pivot.png']
    # a clearance that varies is drawn without a word
    _sweep_folder(tmp_path / 'varies', np.linspace(0.7, 0.8, 6))
    assert cli.main(['plot', str(tmp_path / 'varies'), '-o', str(tmp_path / 'f2')]) == 0
    assert capsys.readouterr().err == ''
    assert 'scatter_clearance_store_pylon_min.png' in os.listdir(tmp_path / 'f2')
