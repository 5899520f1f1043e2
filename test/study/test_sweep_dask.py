# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Sweeps on Dask: any number of workers, a separate scheduler, resume after a kill."""

import glob
import os
import signal
import socket
import subprocess
import sys
import time

from cfem_ros import cli
from cfem_ros.study import Sweep
import pandas as pd
import pytest
from sweeps import write_sweep

distributed = pytest.importorskip('dask.distributed')

#: Bounded waits, s.
STARTUP = 60
SWEEP = 120


def test_the_table_is_the_same_with_1_and_2_workers(tmp_path):
    sweep = Sweep.from_file(write_sweep(tmp_path, runs=6))
    tables = []
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        for workers in (2, 1):
            if workers == 1:
                client.retire_workers([sorted(client.scheduler_info()['workers'])[0]])
            assert len(client.scheduler_info()['workers']) == workers
            out = str(tmp_path / f'w{workers}')
            tables.append(sweep.run(client, out))
            parts = glob.glob(os.path.join(out, 'parts', '*.parquet'))
            assert len(parts) > 1   # many tasks, each a part
    pd.testing.assert_frame_equal(tables[0], tables[1], check_exact=True)
    here = sweep.run(None)
    pd.testing.assert_frame_equal(tables[0], here, check_exact=True)
    assert len(here) == 12 and (here['status'] == 'ok').all()


def _free_port():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def _stop(process):
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGTERM)
        try:
            process.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait(10)


def test_a_sweep_runs_on_a_separate_scheduler_and_workers(tmp_path):
    dask = os.path.join(os.path.dirname(sys.executable), 'dask')
    address = f'tcp://127.0.0.1:{_free_port()}'
    processes = []
    try:
        processes.append(subprocess.Popen(
            [dask, 'scheduler', '--host', '127.0.0.1', '--port', address.rsplit(':', 1)[1],
             '--no-dashboard'], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            start_new_session=True))
        processes.append(subprocess.Popen(
            [dask, 'worker', address, '--nworkers', '2', '--nthreads', '1',
             '--no-dashboard', '--host', '127.0.0.1'], stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL, start_new_session=True))
        with distributed.Client(address, timeout=STARTUP) as client:
            client.wait_for_workers(2, timeout=STARTUP)
        path = write_sweep(tmp_path, runs=4)
        out = str(tmp_path / 'out')
        assert cli.main(['sweep', path, '-o', out, '--scheduler', address, '--csv']) == 0
        table = pd.read_parquet(os.path.join(out, 'results.parquet'))
        pd.testing.assert_frame_equal(table, Sweep.from_file(path).run(None), check_exact=True)
        assert os.path.exists(os.path.join(out, 'results.csv'))
    finally:
        for process in reversed(processes):
            _stop(process)


@pytest.mark.parametrize('sig', [signal.SIGKILL, signal.SIGINT], ids=['SIGKILL', 'SIGINT'])
def test_a_killed_sweep_resumes_without_losing_or_repeating_runs(tmp_path, sig):
    path = write_sweep(tmp_path, runs=50)
    out = str(tmp_path / 'out')
    command = [sys.executable, '-m', 'cfem_ros.cli', 'sweep', path, '-o', out,
               '--workers', '1']
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               start_new_session=True)
    parts = os.path.join(out, 'parts', '*.parquet')
    deadline = time.monotonic() + SWEEP
    try:
        while not glob.glob(parts) and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        # to the whole group, as a terminal's Ctrl-C: the client, its cluster and workers
        os.killpg(process.pid, sig)
        status = process.wait(STARTUP)
    finally:
        try:
            os.killpg(process.pid, signal.SIGKILL)   # whatever is left of the group
        except ProcessLookupError:
            pass
        process.wait(10)
    time.sleep(0.5)   # anything the workers or the resource tracker would still say
    stderr = process.stderr.read().decode()
    assert glob.glob(parts), stderr
    assert not os.path.exists(os.path.join(out, 'results.parquet'))
    done = sum(len(pd.read_parquet(p)) for p in glob.glob(parts))
    assert 0 < done < 100
    if sig == signal.SIGINT:   # stopped cleanly: what is kept and how to go on, nothing else
        assert status == 130, stderr
        assert stderr.splitlines()[-1] == (
            f'interrupted by SIGINT: {done} of 100 runs are saved in {out}; '
            'run the same command again to resume'), stderr
        assert 'Traceback' not in stderr and 'leaked' not in stderr, stderr
    # a different sweep is refused in that folder
    os.makedirs(tmp_path / 'other')
    other = write_sweep(tmp_path / 'other', runs=50, seed=8)
    assert cli.main(['sweep', other, '-o', out]) == 2
    # the same sweep again does only the runs not done
    sweep = Sweep.from_file(path)
    counted = []
    table = sweep.run(None, out, progress=lambda runs, failed: counted.append(runs))
    assert sum(counted) == 100 - done
    rows = sum(len(pd.read_parquet(p)) for p in glob.glob(parts))
    assert rows == len(table) == 100   # no run done twice, none lost
    pd.testing.assert_frame_equal(table, pd.read_parquet(os.path.join(out, 'results.parquet')))
    pd.testing.assert_frame_equal(table, sweep.run(None), check_exact=True)
