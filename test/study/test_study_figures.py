# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Sweep figures people read: names with units, a grid of panels, rounding, limits, envelopes."""

import copy
import glob
import json
import os

from cfem_ros import cli, study_plots
from cfem_ros.study import Sweep
from cfem_ros.study.criteria import parse_rule
from cfem_ros.study.labels import label
from matplotlib.collections import LineCollection
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from sweeps import STORE, write_sweep

EJECTORS = {'bodies': {'pylon': {'fixed': True}, 'store': {'mass': 907.2}},
            'wrenches': [{'name': 'forward_ejector', 'body': 'store'},
                         {'name': 'aft_ejector', 'body': 'store'}]}


@pytest.mark.parametrize('column,want', [
    ('bodies.store.mass', 'store mass [kg]'),
    ('bodies.store.inertia[1]', 'store inertia Iyy [kg m^2]'),
    ('joints.pivot.release.angle_deg', 'pivot release angle [deg]'),
    ('joints.pivot.anchor[0]', 'pivot anchor x [m]'),
    ('wrenches[1].force[2]', 'wrench aft_ejector force z [N]'),
    ('dt', 'time step dt [s]'),
    ('clearance_store_pylon_min', 'min clearance store-pylon [m]'),
    ('clearance_store_pylon_min_time', 'time of min clearance store-pylon [s]'),
    ('distance_store_pylon_min', 'min shape distance store-pylon [m]'),
    ('release_pivot_time', 'pivot release time [s]'),
    ('peak_moment_pivot', 'peak moment in pivot [N m]'),
    ('store_at_0.5_z', 'store z at 0.5 s [m]'),
    ('store_at_0.5_pitch_deg', 'store pitch at 0.5 s [deg]'),
    ('stroke_aft_ejector_q', 'aft_ejector q at end of stroke [deg/s]'),
])
def test_columns_read_as_names_with_units(column, want):
    assert label(column, EJECTORS) == want


def _table(n=40, parameters=6, seed=1):
    rng = np.random.default_rng(seed)
    names = ['bodies.store.mass', 'bodies.store.inertia[1]', 'bodies.store.inertia[2]',
             'wrenches[0].force[2]', 'wrenches[1].force[2]', 'dt'][:parameters]
    table = pd.DataFrame({'run': np.arange(n), 'status': ['ok'] * n, 'message': [''] * n})
    for name in names:
        table[name] = rng.normal(size=n)
    table['store_at_0.5_z'] = 0.4 + 0.01 * rng.normal(size=n)
    table['store_at_0.5_y'] = 9e-18 * rng.choice([-1.0, 1.0], size=n)
    table['store_at_0.5_pitch_deg'] = 25 + rng.normal(size=n)
    table['store_at_0.5_yaw_deg'] = 7e-15 * rng.choice([-1.0, 1.0], size=n)
    table.loc[3, 'status'] = 'failed'
    return table, names


def test_six_parameters_make_a_readable_grid_with_names_and_units():
    table, names = _table()
    criteria = [parse_rule('deep', 'store_at_0.5_z >= 0.39')]
    from cfem_ros.study.criteria import judge
    table = judge(table, criteria)
    fig = study_plots.scatter_figure(table, 'store_at_0.5_z', names, criteria, EJECTORS)
    width, height = fig.get_size_inches() * study_plots.DPI
    assert width < 1500 and height > 500           # 2 rows of 3, not one long strip
    visible = [ax for ax in fig.axes if ax.get_visible()]
    assert len(visible) == 6
    assert all(ax.get_xlabel().endswith(']') for ax in visible)
    assert visible[0].get_ylabel() == 'store z at 0.5 s [m]'
    # failing runs are orange triangles, unfinished ones red crosses, the limit drawn
    labels = [line.get_label() for line in visible[0].lines]
    failing = int((~table['pass']).sum()) - 1
    assert f'fail a criterion ({failing})' in labels and 'did not finish (1)' in labels
    assert any(list(line.get_ydata()) == [0.39, 0.39] for line in visible[0].lines)
    plt.close(fig)


def test_a_zero_by_symmetry_metric_is_one_value_beside_its_family():
    table, _ = _table()
    for column in ('store_at_0.5_y', 'store_at_0.5_yaw_deg'):
        fig = study_plots.histogram_figure(table, column, document=EJECTORS)
        assert not fig.axes[0].patches, column   # no histogram of rounding noise
        assert 'in every run' in ' '.join(t.get_text() for t in fig.axes[0].texts)
        plt.close(fig)
    # alone, without a family to compare with, it is its own scale: still a histogram
    alone = table[['run', 'status', 'message', 'store_at_0.5_y']]
    fig = study_plots.histogram_figure(alone, 'store_at_0.5_y')
    assert fig.axes[0].patches
    plt.close(fig)
    # a real spread of the same family stays a histogram
    fig = study_plots.histogram_figure(table, 'store_at_0.5_pitch_deg', document=EJECTORS)
    assert fig.axes[0].patches and fig.axes[0].get_xlabel() == 'store pitch at 0.5 s [deg]'
    plt.close(fig)


def test_criteria_are_limit_lines_on_histograms():
    table, _ = _table()
    criteria = [parse_rule('pitch', 'abs(store_at_0.5_pitch_deg) <= 26')]
    fig = study_plots.histogram_figure(table, 'store_at_0.5_pitch_deg', criteria, EJECTORS)
    ax = fig.axes[0]
    verticals = sorted(line.get_xdata()[0] for line in ax.lines if line.get_color() == 'black')
    assert verticals == [-26.0, 26.0]
    fails = int((np.abs(table['store_at_0.5_pitch_deg']) > 26).sum()) + 1   # + unfinished
    assert f'pitch: abs(store_at_0.5_pitch_deg) <= 26 ({fails} of 40 runs fail)' in [
        t.get_text() for t in ax.get_legend().get_texts()]
    plt.close(fig)


def test_a_body_with_no_joint_has_an_envelope_from_its_release_point(tmp_path):
    """A store dropped with no joint and no carrier: z from the release point is g t^2 / 2."""
    scenario = {'name': 'drop', 'gravity': [0, 0, 9.80665], 'duration': 0.3, 'dt': 0.002,
                'bodies': {'store': {'mass': 900.0, 'inertia': [27.0, 488.0, 488.0],
                                     'position': [1.0, 0.0, 2.0]}}}
    path = write_sweep(tmp_path, runs=2, scenario=scenario,
                       vary={'bodies.store.mass': {'uniform': [890.0, 910.0]}},
                       metrics={'at': [{'time': 0.3, 'body': 'store'}]})
    out = str(tmp_path / 'sweep')
    Sweep.from_file(path).run(None, out, record='all')
    with open(os.path.join(out, 'sweep.json')) as stream:
        manifest = json.load(stream)
    assert study_plots.released_pair(manifest) == ('', None, 'store')
    fig = study_plots.envelope_figure(sorted(glob.glob(os.path.join(out, 'runs', '*.mcap'))),
                                      None, 'store')
    (runs,) = [c for c in fig.axes[1].collections if isinstance(c, LineCollection)]
    t, z = runs.get_segments()[0].T
    np.testing.assert_allclose(z, 0.5 * 9.80665 * t ** 2, atol=1e-9)
    assert 'release point' in fig.axes[1].get_ylabel()
    plt.close(fig)
    # with a fixed carrier the envelope is relative to it (the ejector sweep's case)
    with_pylon = copy.deepcopy(manifest)
    with_pylon['resolved']['document']['bodies']['pylon'] = {'fixed': True}
    assert study_plots.released_pair(with_pylon) == ('', 'pylon', 'store')
    figures = tmp_path / 'figures'
    assert cli.main(['plot', out, '-o', str(figures)]) == 0
    assert 'envelope_store_release.png' in os.listdir(figures)


def test_plot_prints_and_draws_the_failure_fractions(tmp_path, capsys):
    path = write_sweep(tmp_path, runs=4, scenario=dict(STORE, duration=0.5),
                       vary={'joints.pivot.release.angle_deg': {'uniform': [8, 12]}},
                       criteria={'early': 'release_pivot_time <= 0.28'})
    out = str(tmp_path / 'sweep')
    table = Sweep.from_file(path).run(None, out)
    figures = tmp_path / 'figures'
    assert cli.main(['plot', out, '-o', str(figures)]) == 0
    printed = capsys.readouterr().out
    failed = int((~table['pass']).sum())
    assert f'early: {failed} failures in 4 runs' in printed
    assert 'criteria.png' in os.listdir(figures)
