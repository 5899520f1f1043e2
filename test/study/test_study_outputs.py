# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""What a study's commands may write over, and what a full disk leaves (issue 41.1, 41.9)."""

import contextlib
import os
import resource

from cfem_ros import cli
from cfem_ros.study import Sweep
from cfem_ros.study.report import write_report
from cfem_ros.study.resources import ResourceFailure
import pandas as pd
import pytest
from sweeps import STORE, write_sweep


@pytest.fixture(scope='module')
def folder(tmp_path_factory):
    base = tmp_path_factory.mktemp('outputs')
    path = write_sweep(base, runs=2, seed=3, scenario=dict(STORE, duration=0.2),
                       vary={'bodies.store.mass': {'uniform': [900, 910]}},
                       metrics={'at': [{'time': 0.1, 'body': 'store'}]})
    out = str(base / 'sweep')
    Sweep.from_file(path).run(None, out, threads=1)
    return base, out, path


@contextlib.contextmanager
def file_size_limit(size: int):
    """Let this process write files of at most size bytes (Python ignores SIGXFSZ: EFBIG)."""
    previous = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (size, previous[1]))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, previous)


def test_report_refuses_an_existing_file_without_overwrite(folder, capsys):
    base, out, sweep_file = folder
    results = os.path.join(out, 'results.parquet')
    before = {p: open(p, 'rb').read() for p in (results, sweep_file)}
    for target in (results, sweep_file):
        assert cli.main(['report', out, '-o', target]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f'ERROR: {target}: already exists; pass --overwrite')
        assert open(target, 'rb').read() == before[target]
    # the folder still reads
    assert len(pd.read_parquet(results)) == 2
    page = base / 'report.html'
    page.write_text('old')
    assert cli.main(['report', out, '-o', str(page), '--overwrite']) == 0
    assert page.read_text().startswith('<!DOCTYPE html>')


def test_report_never_replaces_a_fifo_or_folder(folder, capsys):
    base, out, _ = folder
    fifo = base / 'pipe.html'
    os.mkfifo(fifo)
    for target in (str(fifo), str(base)):
        assert cli.main(['report', out, '-o', target, '--overwrite']) == 2
        assert 'not even with --overwrite' in capsys.readouterr().err
    assert fifo.is_fifo()


def test_a_report_that_does_not_fit_leaves_no_temporary_file(folder):
    base, out, _ = folder
    target = base / 'limited' / 'report.html'
    target.parent.mkdir()
    with file_size_limit(2000), pytest.raises(OSError):
        write_report(out, str(target))
    assert os.listdir(target.parent) == []


def test_rerun_that_cannot_be_written_says_so_on_stderr(folder, capsys):
    base, out, _ = folder
    target = base / 'rerun' / 'run_0.mcap'
    with file_size_limit(3000):
        status = cli.main(['rerun', out, '0', '-o', str(target)])
    printed = capsys.readouterr()
    assert status == 1
    assert printed.err.startswith(f'ERROR: {target}: run 0 of {out} could not be recorded')
    assert printed.err.count('ERROR:') == 1
    assert not target.exists()
    # rerun, like run, never writes over a file
    target.parent.mkdir(exist_ok=True)
    target.write_bytes(b'keep')
    assert cli.main(['rerun', out, '0', '-o', str(target)]) == 2
    assert target.read_bytes() == b'keep'


def test_a_recording_that_cannot_be_written_is_no_failed_run_and_is_redone(folder):
    # issue 41.9: on a full disk the runs whose recordings failed became failed rows
    # (P(fail) = 1, kept on resume); here run 1's recording path is taken by a folder
    base, _, sweep_file = folder
    out = base / 'recorded'
    (out / 'runs' / 'run_1.mcap').mkdir(parents=True)
    with pytest.raises(ResourceFailure, match=r'1 run\(s\) \(1\) could not be written: .*'
                       r'run the same command again'):
        Sweep.from_file(sweep_file).run(None, str(out), record='all', threads=1)
    assert not (out / 'results.parquet').exists()
    (out / 'runs' / 'run_1.mcap').rmdir()
    table = Sweep.from_file(sweep_file).run(None, str(out), record='all', threads=1)
    assert table['status'].tolist() == ['ok', 'ok']
    assert sorted(os.listdir(out / 'runs')) == ['run_0.mcap', 'run_1.mcap']


def test_a_sweep_whose_table_cannot_be_written_fails_with_its_path_and_keeps_the_runs(
        folder, capsys):
    # the final table's write failing was reported as the cluster's fault, exit 2
    base, _, sweep_file = folder
    out = base / 'table_taken'
    (out / 'results.parquet').mkdir(parents=True)
    status = cli.main(['sweep', str(sweep_file), '-o', str(out), '--workers', '1'])
    err = capsys.readouterr().err
    assert status == 1, err
    assert f'ERROR: {out / "results.parquet"}: cannot write (Is a directory); the runs done ' \
           'are saved' in err
    assert 'cluster' not in err
    assert len(os.listdir(out / 'parts')) == 2
