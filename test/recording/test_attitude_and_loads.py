# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Analysis that tells the truth near pitch 90 deg, and load plots without rounding noise.

A body spinning steadily about its principal y axis (no gravity) pitches
through +-90 deg again and again. A second run starts rolled by a small angle
a about its own x axis: its attitude is q_A(t) r, so the rotation from A to B
is exp(-w t) r exp(w t), whose angle is a at every instant. Euler angles of
the two runs differ by up to 360 deg near pitch 90 deg (roll and yaw jump
by 180 deg); the quaternion angle must report a.
"""

import pathlib

from cfem_ros import cli, plots
from cfem_ros.recording import analysis
import numpy as np
import pytest
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
OFFSET_DEG = 0.09


def spinner(roll_deg):
    return {
        'name': 'spinner', 'gravity': [0, 0, 0], 'duration': 2.0, 'dt': 0.001,
        'bodies': {
            'ground': {'fixed': True},
            'store': {'mass': 10.0, 'inertia': [1.0, 2.0, 3.0],
                      'orientation_rpy_deg': [roll_deg, 0, 0],
                      'angular_velocity_deg': [0, 200, 0]},
        },
    }


def run(tmp_path, document, name):
    scenario = tmp_path / f'{name}.yaml'
    scenario.write_text(yaml.safe_dump(document, sort_keys=False))
    out = tmp_path / f'{name}.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out)]) == 0
    return out


@pytest.fixture(scope='module')
def spinners(tmp_path_factory):
    folder = tmp_path_factory.mktemp('spinners')
    return run(folder, spinner(0.0), 'a'), run(folder, spinner(OFFSET_DEG), 'b')


def test_compare_reports_the_angle_between_attitudes(spinners, tmp_path, capsys):
    a, b = (analysis.open_run(str(p)) for p in spinners)
    pitch = a.bodies['store'].euler_continuous_deg[:, 1]
    assert pitch.max() > 360.0   # pitched through +-90 deg several times
    euler_gap = np.abs(a.bodies['store'].euler_deg - b.bodies['store'].euler_deg).max()
    assert euler_gap > 90.0      # what a comparison of Euler angles would report
    rows, _, _ = analysis.compare_runs(a, b)
    attitude = next(r for r in rows if r.quantity == 'store attitude')
    assert attitude.unit == 'deg'
    assert attitude.max_abs == pytest.approx(OFFSET_DEG, rel=1e-6)
    t, angle = analysis.attitude_difference_deg(a.bodies['store'], b.bodies['store'])
    assert len(t) == len(a.bodies['store'].time)
    np.testing.assert_allclose(angle, OFFSET_DEG, rtol=1e-6)
    assert cli.main(['compare', str(spinners[0]), str(spinners[1]),
                     '-o', str(tmp_path / 'cmp')]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines()
                if x.startswith('store attitude'))
    assert float(line.split()[2]) == pytest.approx(OFFSET_DEG, rel=1e-4)


def test_comparison_figure_has_an_a_minus_b_panel(spinners):
    a, b = (analysis.open_run(str(p)) for p in spinners)
    fig = plots.compare_body_figure(a, b, 'store')
    titles = [ax.get_title(loc='left') for ax in fig.axes]
    assert any(title.startswith('A - B') for title in titles)
    twin = next(ax for ax in fig.axes if ax.get_ylabel() == 'attitude angle [deg]')
    np.testing.assert_allclose(twin.get_lines()[0].get_ydata(), OFFSET_DEG, rtol=1e-6)


def test_euler_angles_are_shown_only_where_they_are_defined(spinners):
    a, b = (analysis.open_run(str(p)) for p in spinners)
    pure, offset = a.bodies['store'], b.bodies['store']
    # a pure pitch through 90 deg: roll and yaw stay put, pitch grows continuously
    assert not pure.euler_singular
    np.testing.assert_allclose(pure.euler_continuous_deg[:, [0, 2]], 0.0, atol=1e-6)
    assert np.abs(np.diff(pure.euler_continuous_deg[:, 1])).max() < 2.5   # 200 deg/s, 100 Hz
    # rolled by 0.09 deg: near pitch 90 deg roll and yaw swing by ~180 deg
    assert offset.euler_singular
    fig = plots.body_figure(b, 'store')
    assert fig.axes[1].get_ylabel() == 'quaternion'
    q = offset.quaternion_continuous
    assert np.abs(np.diff(q, axis=0)).max() < 0.05   # no sign flips in the plotted lines
    assert plots.body_figure(a, 'store').axes[1].get_ylabel() == 'angle [deg]'


def test_load_plots_show_rounding_as_zero(tmp_path):
    store = analysis.open_run(str(run(tmp_path, yaml.safe_load(
        (CONFIG / 'store_separation.yaml').read_text()), 'store')))
    pivot = store.joints['pivot']
    weight = 907.1848 * 9.80665
    # a pitch-plane swing on a hinge: the moment about the joint point is zero but
    # for rounding, and the force is real
    assert 0.0 < np.abs(pivot.moment).max() < 1e-9 * weight
    assert np.abs(pivot.force).max() > 0.5 * weight
    fig = plots.joint_figure(store, 'pivot')
    force_ax, moment_ax = fig.axes
    for line in moment_ax.get_lines():
        if line.get_label() in ('x', 'y', 'z', 'magnitude'):
            assert not np.any(line.get_ydata()), line.get_label()
    low, high = moment_ax.get_ylim()
    assert high - low >= 2e-6 * weight   # not autoscaled onto the rounding
    drawn_z = next(line for line in force_ax.get_lines() if line.get_label() == 'z')
    np.testing.assert_array_equal(drawn_z.get_ydata(), pivot.force[:, 2])
