# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""A sweep's runs: the same metrics as cfem-sim run's recordings, failures as rows."""

import copy
import logging
import math
import os

from cfem_ros import cli
from cfem_ros.core.engine.dynamics import REDUNDANT_WARNING
from cfem_ros.core.model.model import STANDARD_GRAVITY
from cfem_ros.study import Sweep
from cfem_ros.study.metrics import compute, from_run
import numpy as np
import pandas as pd
import pytest
from sweeps import STORE, write_sweep
import yaml


def metric_columns(sweep):
    return sweep.spec.metrics.columns()


def test_sweep_rows_match_cfem_sim_run_recordings_summarized(tmp_path):
    sweep = Sweep.from_file(write_sweep(tmp_path, runs=2))
    table = sweep.run(None, str(tmp_path / 'sweep'), record='all')
    assert list(table['run']) == [0, 1, 2, 3]
    assert (table['status'] == 'ok').all()
    assert table['release_pivot_cause'].eq('angle').all()
    recordings = []
    for k in range(sweep.total):
        scenario = tmp_path / f'run_{k}.yaml'
        scenario.write_text(yaml.safe_dump(sweep.scenario(k)))
        out = str(tmp_path / f'run_{k}.mcap')
        assert cli.main(['run', str(scenario), '-o', out]) == 0
        recordings.append(out)
    summary = str(tmp_path / 'summary.parquet')
    assert cli.main(['summarize', *recordings, '--metrics', sweep.spec.path,
                     '-o', summary]) == 0
    from_runs = pd.read_parquet(summary)
    names = metric_columns(sweep)
    pd.testing.assert_frame_equal(from_runs[names], table[names], check_exact=True)
    # the sweep's own recordings give the same numbers again
    own = [str(tmp_path / 'sweep' / 'runs' / f'run_{k}.mcap') for k in range(4)]
    from cfem_ros.study import summarize
    pd.testing.assert_frame_equal(summarize(own, sweep.spec.metrics)[names], table[names],
                                  check_exact=True)
    # different draws give different metrics (the values were applied)
    assert table['clearance_store_pylon_min'].nunique() == 4


def test_an_invalid_drawn_scenario_is_an_invalid_row_not_the_end(tmp_path):
    # SPEC section 12: a draw the scenario's checks refuse is not run and is no failure
    path = write_sweep(tmp_path, runs=1, vary={
        'bodies.store.mass': {'grid': [907.1848, -5.0, 'heavy']}})
    table = Sweep.from_file(path).run(None)
    assert list(table['status']) == ['ok', 'invalid', 'invalid']
    assert 'bodies.store.mass: is -5' in table['message'][1]
    assert "bodies.store.mass: is 'heavy'" in table['message'][2]
    assert '(run 1)' in table['message'][1]
    assert math.isnan(table['clearance_store_pylon_min'][1])
    assert table['clearance_store_pylon_min'][0] > 0


def test_a_diverging_run_is_a_failed_row_with_its_reason(tmp_path):
    # a store swinging at 5000 deg/s on its hinge: RK4 holds it at dt = 2 ms, not at 50 ms
    scenario = copy.deepcopy(STORE)
    del scenario['joints']['pivot']['release']
    scenario['bodies']['store']['angular_velocity_deg'] = [0, 5000, 0]
    scenario['baumgarte'] = 0.0
    path = write_sweep(tmp_path, runs=1, vary={'dt': {'grid': [0.002, 0.05]}},
                       scenario=scenario)
    table = Sweep.from_file(path).run(None)
    assert table['status'][0] == 'ok'
    assert table['status'][1] == 'failed', table.loc[1].to_dict()
    assert table['message'][1].startswith('the run failed at t = ')
    assert 'diverged' in table['message'][1]


def test_metrics_of_a_falling_body_are_analytic(tmp_path):
    # a free store falls from rest beside a pylon turned 90 deg in yaw: z = g t^2 / 2
    # (RK4 is exact on it); relative to the pylon, world x is -y and the yaw -90 deg
    scenario = copy.deepcopy(STORE)
    scenario['joints'] = {}
    scenario['bodies']['pylon']['orientation_rpy_deg'] = [0, 0, 90]
    scenario['bodies']['store']['position'] = [1.0, 0, 0]
    metrics = {'clearance': [{'bodies': ['store', 'pylon']}],
               'at': [{'time': 0.5, 'body': 'store', 'relative_to': 'pylon'},
                      {'time': 0.25, 'body': 'store'}]}
    path = write_sweep(tmp_path, runs=1, vary={}, metrics=metrics, scenario=scenario)
    row = Sweep.from_file(path).run(None).iloc[0]
    g = STANDARD_GRAVITY
    assert row['clearance_store_pylon_min'] == pytest.approx(1.0, abs=1e-12)
    assert row['clearance_store_pylon_min_time'] == 0.0
    z = 0.5 * g * 0.5 ** 2
    position = [row[f'store_at_0.5_{c}'] for c in 'xyz']
    assert position == pytest.approx([0.0, -1.0, z], abs=1e-9)
    assert row['store_at_0.5_yaw_deg'] == pytest.approx(-90.0, abs=1e-9)
    assert row['store_at_0.25_z'] == pytest.approx(0.5 * g * 0.25 ** 2, abs=1e-9)
    assert row['store_at_0.25_x'] == pytest.approx(1.0, abs=1e-12)


def test_peak_load_of_the_hinge_is_its_weight_at_the_start(tmp_path):
    # released at once, the hinge only ever holds the store at rest: the sample at
    # t = 0 has the static load; check it against m g on the recorded samples
    metrics = {'clearance': [], 'at': []}
    scenario = copy.deepcopy(STORE)
    scenario['joints']['pivot']['anchor'] = [0, 0, -0.25]   # above the CG: no moment arm
    scenario['joints']['pivot']['release'] = {'time': 0.1}
    path = write_sweep(tmp_path, runs=1, vary={}, metrics=metrics, scenario=scenario)
    sweep = Sweep.from_file(path)
    row = sweep.run(None, str(tmp_path / 'out'), record='all').iloc[0]
    weight = 907.1848 * STANDARD_GRAVITY
    assert row['peak_force_pivot'] == pytest.approx(weight, rel=1e-9)
    assert row['release_pivot_time'] == 0.1
    assert row['release_pivot_cause'] == 'time'
    from cfem_ros.recording.analysis import open_run
    run = open_run(str(tmp_path / 'out' / 'runs' / 'run_0.mcap'))
    assert compute(from_run(run), sweep.spec.metrics)['peak_force_pivot'] \
        == row['peak_force_pivot']
    assert np.all(run.joints['pivot'].time < 0.1 + 1e-12)


def test_summarize_reports_a_truncated_or_foreign_file_as_a_row(tmp_path, capsys):
    sweep = Sweep.from_file(write_sweep(tmp_path, runs=1, vary={}))
    good = str(tmp_path / 'good.mcap')
    scenario = tmp_path / 'scenario.yaml'
    assert cli.main(['run', str(scenario), '-o', good]) == 0
    cut = tmp_path / 'cut.mcap'
    data = open(good, 'rb').read()
    cut.write_bytes(data[:len(data) // 3])
    foreign = tmp_path / 'notes.mcap'
    foreign.write_text('not a recording')
    out = str(tmp_path / 'table.parquet')
    code = cli.main(['summarize', good, str(cut), str(foreign), '--metrics',
                     sweep.spec.path, '-o', out, '--workers', '1'])
    assert code == 1
    table = pd.read_parquet(out)
    assert list(table['file']) == ['good.mcap', 'cut.mcap', 'notes.mcap']
    assert list(table['status']) == ['ok', 'failed', 'failed']
    assert table['start_stamp_ns'][0] == 0
    assert 'cut.mcap' in table['message'][1] and 'notes.mcap' in table['message'][2]
    assert table['clearance_store_pylon_min'][0] > 0
    assert os.path.exists(out)


def test_the_redundant_joint_warning_comes_once_per_sweep(tmp_path, caplog):
    scenario = copy.deepcopy(STORE)
    scenario['joints']['pin'] = {k: v for k, v in scenario['joints']['pivot'].items()
                                 if k != 'release'}
    path = write_sweep(tmp_path, runs=4, vary={'bodies.store.mass': {'normal': [907.0, 5.0]}},
                       scenario=scenario)
    with caplog.at_level(logging.WARNING, logger='cfem_ros'):
        table = Sweep.from_file(path).run(None, str(tmp_path / 'out'))
    assert (table['status'] == 'ok').all() and len(table) == 4
    redundant = [r for r in caplog.records if r.msg == REDUNDANT_WARNING]
    assert len(redundant) == 1 and 'pin, pivot' in redundant[0].getMessage()


def test_summarize_relative_paths_on_a_cluster_elsewhere_and_no_silent_replace(
        tmp_path, monkeypatch, capsys):
    from dask.distributed import Client, LocalCluster
    sweep = Sweep.from_file(write_sweep(tmp_path, runs=1, vary={}))
    monkeypatch.chdir(tmp_path)
    assert cli.main(['run', 'scenario.yaml', '-o', 'good.mcap']) == 0
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=':0') as cluster, Client(cluster) as client:
        # the worker's working directory is another one, as on a remote machine
        client.run(os.chdir, '/')
        code = cli.main(['summarize', 'good.mcap', '--metrics', sweep.spec.path,
                         '-o', 'table.parquet', '--scheduler', cluster.scheduler_address])
    assert code == 0, capsys.readouterr().err
    table = pd.read_parquet('table.parquet')
    assert list(table['status']) == ['ok'] and table['clearance_store_pylon_min'][0] > 0
    assert table['path'][0] == str(tmp_path / 'good.mcap')
    # an existing table is replaced only with --overwrite
    before = (tmp_path / 'table.parquet').read_bytes()
    capsys.readouterr()
    assert cli.main(['summarize', 'good.mcap', '--metrics', sweep.spec.path,
                     '-o', 'table.parquet']) == 2
    err = capsys.readouterr().err
    assert err.startswith('ERROR: table.parquet: already exists') and '--overwrite' in err
    assert (tmp_path / 'table.parquet').read_bytes() == before
    assert cli.main(['summarize', 'good.mcap', '--metrics', sweep.spec.path,
                     '-o', 'table.parquet', '--overwrite']) == 0


def test_plot_of_a_sweep_folder_draws_spreads_scatters_and_the_envelope(tmp_path, capsys):
    path = write_sweep(tmp_path, runs=3, vary={
        'bodies.store.mass': {'normal': [907.1848, 10.0]},
        'joints.pivot.release.angle_deg': {'choice': [8, 12, -1]}})
    out = str(tmp_path / 'sweep')
    table = Sweep.from_file(path).run(None, out, record='all')
    assert (table['status'] == 'invalid').any() and (table['status'] == 'ok').any()
    figures = str(tmp_path / 'figures')
    assert cli.main(['plot', out, '-o', figures]) == 0
    names = sorted(os.listdir(figures))
    assert 'hist_clearance_store_pylon_min.png' in names
    assert 'scatter_clearance_store_pylon_min.png' in names
    assert 'envelope_store_pylon.png' in names
    assert 'hist_store_at_0.5_y.png' not in names   # no spread, no histogram
    assert cli.main(['plot', out, '-o', figures, '--metric', 'nope']) == 2
    assert "--metric: 'nope' is not a column" in capsys.readouterr().err


def test_collected_samples_are_the_recordings_numbers_at_any_rate(tmp_path):
    # at 30 Hz the sample times k / 30 are not whole nanoseconds: the collector must
    # give them back as a recording does (stamped in ns), and every number alike
    from cfem_ros.core.engine.simulator import Simulator
    from cfem_ros.core.run.session import Session
    from cfem_ros.core.scenario.parse import parse_scenario
    from cfem_ros.recording.analysis import open_run
    from cfem_ros.recording.container import Recorder
    from cfem_ros.recording.recorder import run_metadata, StateRecorder
    from cfem_ros.study.metrics import Collector
    sweep = Sweep.from_file(write_sweep(tmp_path, runs=1, vary={}, rate_hz=30))
    model = parse_scenario(sweep.scenario(0))
    sim = Simulator(model)
    path = str(tmp_path / 'run.mcap')
    with Recorder(path, metadata=run_metadata(model, 'scenario.yaml', 30.0, 0)) as recorder:
        collector = Collector(sim, forward=StateRecorder(recorder, sim))
        Session(sim, rate_hz=30.0, duration=model.duration, outputs=[collector]).run()
    mine, theirs = collector.samples(), from_run(open_run(path))
    assert sorted(mine.bodies) == sorted(theirs.bodies)
    assert sorted(mine.joints) == sorted(theirs.joints) == ['pivot']
    for name in mine.bodies:
        for a, b in zip(mine.bodies[name], theirs.bodies[name]):
            np.testing.assert_array_equal(a, b)
    for a, b in zip(mine.joints['pivot'], theirs.joints['pivot']):
        np.testing.assert_array_equal(a, b)
    assert mine.releases == theirs.releases and len(mine.releases) == 1
    assert not np.array_equal(mine.bodies['store'][0], np.arange(19) / 30.0)


def test_a_dated_scenario_gives_dated_sweep_recordings(tmp_path):
    # the scenario's start_time dates a sweep's recordings as it dates cfem-sim run's
    start = '2026-03-14T09:30:00.123456789Z'
    dated = {**STORE, 'start_time': start}
    sweep = Sweep.from_file(write_sweep(tmp_path, runs=1, scenario=dated,
                                        vary={'bodies.store.mass': {'grid': [907.0]}}))
    sweep.run(None, str(tmp_path / 'sweep'), record='all')
    scenario = tmp_path / 'run_0.yaml'
    scenario.write_text(yaml.safe_dump(sweep.scenario(0)))
    alone = str(tmp_path / 'run_0.mcap')
    assert cli.main(['run', str(scenario), '-o', alone]) == 0
    from cfem_ros.recording.analysis import open_run
    from cfem_ros.core.fileio.instants import instant_ns
    ours, theirs = open_run(str(tmp_path / 'sweep' / 'runs' / 'run_0.mcap')), open_run(alone)
    assert ours.start_ns == theirs.start_ns == instant_ns(start) > 0
    for name, body in ours.bodies.items():
        np.testing.assert_array_equal(body.stamp_ns, theirs.bodies[name].stamp_ns)


def test_a_folder_whose_parts_have_other_columns_is_refused_not_resumed(tmp_path):
    # a part written by another version (here: without a metric's column) holds rows that
    # would not agree with this version's: resuming is refused, naming the part and column
    import pyarrow.parquet as pq
    from cfem_ros.study.errors import SweepError
    sweep = Sweep.from_file(write_sweep(tmp_path, runs=1))
    outdir = str(tmp_path / 'sweep')
    sweep.run(None, outdir)
    parts = sorted((tmp_path / 'sweep' / 'parts').glob('*.parquet'))
    assert parts
    dropped = metric_columns(sweep)[-1]
    table = pq.read_table(str(parts[0]))
    pq.write_table(table.drop([dropped]), str(parts[0]))
    os.remove(os.path.join(outdir, 'results.parquet'))
    with pytest.raises(SweepError) as refused:
        Sweep.from_file(write_sweep(tmp_path, runs=1)).run(None, outdir)
    said = str(refused.value)
    assert f'{parts[0].name} was written by another version of cfem_ros' in said
    assert f'it lacks {dropped}' in said and 'a new folder' in said
