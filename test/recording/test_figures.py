# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Run figures read right: releases together, long flights, markers not hidden, A and B named."""

import pathlib

from cfem_ros import cli, plots
from cfem_ros.recording import analysis
import matplotlib.pyplot as plt
import pytest
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'

TWO_HOOKS = {
    'name': 'two_hooks', 'gravity': [0, 0, 9.80665], 'duration': 0.3,
    'bodies': {
        'pylon': {'fixed': True},
        'store': {'mass': 907.1848, 'inertia': [27.1164, 488.0944, 488.0944]},
    },
    'joints': {
        'fwd_hook': {'type': 'ball', 'parent': 'pylon', 'child': 'store',
                     'anchor': [0.25, 0, -0.25], 'release': {'time': 0.1}},
        'aft_hook': {'type': 'ball', 'parent': 'pylon', 'child': 'store',
                     'anchor': [-0.25, 0, -0.25], 'release': {'time': 0.1}},
    },
}


def _run(tmp_path, document, name):
    scenario = tmp_path / f'{name}.yaml'
    scenario.write_text(yaml.safe_dump(document))
    out = tmp_path / f'{name}.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out)]) == 0
    return analysis.open_run(str(out))


def test_joints_released_together_get_one_label(tmp_path):
    run = _run(tmp_path, TWO_HOOKS, 'two')
    assert len(run.releases()) == 2
    assert [(t, joints) for t, joints, _ in plots.release_groups(run)] == [
        (pytest.approx(0.1, abs=1e-12), 'aft_hook, fwd_hook')]
    fig = plots.body_figure(run, 'store')
    labels = [text.get_text() for text in fig.axes[0].texts]
    assert labels == ['aft_hook, fwd_hook released (time) t = 0.1000 s']
    plt.close(fig)


def test_a_long_flight_keeps_the_separation_visible(tmp_path):
    document = yaml.safe_load((CONFIG / 'store_release_from_pullup.yaml').read_text())
    document['joints']['hook']['release'] = {'time': 0.3}
    run = _run(tmp_path, document, 'flight')
    aircraft, store = run.bodies['aircraft'], run.bodies['store']
    assert aircraft.position[-1, 0] - aircraft.position[0, 0] > 400        # 500 m of flight
    drop = store.position[-1, 2] - aircraft.position[-1, 2]
    assert drop > 10                                                         # metres apart
    fig = plots.trajectory_figure(run)
    ax = fig.axes[0]
    low, high = sorted(ax.get_zlim())
    assert high - low < 2 * drop       # at one scale for all axes it would be 500 m or more
    assert 'scales differ' in ax.get_title()
    plt.close(fig)
    fig = plots.relative_trajectory_figure(run)
    side = fig.axes[0]
    # the legend is below the panels, the start and end marks above the release star
    assert side.get_legend() is None and len(fig.legends) == 1
    drawn = [c for c in side.collections if len(c.get_offsets())]
    hollow = [c.get_zorder() for c in drawn if not len(c.get_facecolors())]   # start, end
    stars = [c.get_zorder() for c in drawn if len(c.get_facecolors())]
    assert len(hollow) == 2 and len(stars) == 1 and min(hollow) > max(stars)
    plt.close(fig)


def test_compare_figures_name_the_two_files(tmp_path):
    a = _run(tmp_path, TWO_HOOKS, 'first')
    b = _run(tmp_path, dict(TWO_HOOKS, duration=0.2), 'second')
    for fig in (plots.compare_body_figure(a, b, 'store'),
                plots.compare_joint_figure(a, b, 'fwd_hook')):
        title = fig.get_suptitle()
        assert 'A (solid) = first.mcap' in title and 'B (dashed) = second.mcap' in title
        plt.close(fig)
