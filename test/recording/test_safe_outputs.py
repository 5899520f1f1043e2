# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Outputs that are safe: a regular file or a new path, and a full disk that loses nothing.

Devices, FIFOs, directories, an empty name and a path under a regular file
are refused before anything runs (exit 2, nothing written), even with
``--overwrite``; missing folders are made, ``sub/..`` included. A file
size limit (``RLIMIT_FSIZE``, what a full disk looks like to a writer:
EFBIG instead of ENOSPC) ends ``run`` and ``recover`` with exit 1 and one
``ERROR:`` line saying how far they got, no partial file left and an
existing output untouched.
"""

import os
import pathlib
import resource
import stat
import subprocess
import sys

from cfem_ros import cli
import pytest

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
SCENARIO = CONFIG / 'store_separation.yaml'


def one_error(capsys) -> str:
    captured = capsys.readouterr()
    assert captured.err.startswith('ERROR: ') and captured.err.count('\n') == 1, captured.err
    assert not captured.out      # nothing ran
    return captured.err


@pytest.mark.parametrize('command', ['run', 'recover'])
def test_devices_fifos_folders_and_empty_names_are_refused_before_anything_runs(
        command, tmp_path, capsys):
    folder = tmp_path / 'adir'
    folder.mkdir()
    fifo = tmp_path / 'pipe'
    os.mkfifo(fifo)
    regular = tmp_path / 'file.mcap'
    regular.write_bytes(b'old')
    source = str(SCENARIO) if command == 'run' else str(CONFIG / 'nothing.mcap')
    cases = {os.devnull: 'is a device', str(folder): 'is a directory',
             str(fifo): 'is a named pipe (FIFO)', '': 'is empty',
             str(regular / 'x.mcap'): 'is a regular file, not a folder',
             str(folder) + os.sep: 'names a folder'}
    for output, words in cases.items():
        argv = [command, source, '-o', output] + (['--overwrite'] if command == 'run' else [])
        assert cli.main(argv) == 2, output
        assert words in one_error(capsys), output
    assert stat.S_ISCHR(os.stat(os.devnull).st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ['adir', 'file.mcap', 'pipe']
    assert not list(folder.iterdir()) and regular.read_bytes() == b'old'


def test_tables_and_sweep_folders_never_replace_a_device_or_file(tmp_path, capsys):
    fifo = tmp_path / 'table.parquet'
    os.mkfifo(fifo)
    sweep = CONFIG / 'sweeps' / 'store_separation_sweep.yaml'
    assert cli.main(['summarize', str(SCENARIO), '--metrics', str(sweep), '-o', str(fifo)]) == 2
    assert 'is a named pipe (FIFO); a table is written only to' in one_error(capsys)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    regular = tmp_path / 'file'
    regular.write_bytes(b'old')
    assert cli.main(['sweep', str(sweep), '-o', str(regular)]) == 2
    assert 'is not a folder' in one_error(capsys) and regular.read_bytes() == b'old'


def test_missing_folders_are_made_also_through_dotdot(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(['run', str(SCENARIO), '-o', 'sub/../out.mcap', '--duration', '0.05']) == 0
    assert (tmp_path / 'out.mcap').is_file() and (tmp_path / 'sub').is_dir()
    assert cli.main(['run', str(SCENARIO), '-o', 'a/b/c.mcap', '--duration', '0.05']) == 0
    assert (tmp_path / 'a' / 'b' / 'c.mcap').is_file()


def _limited(argv, limit_bytes, cwd):
    """Run cfem-sim in a subprocess whose files may not grow beyond limit_bytes."""
    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))
    return subprocess.run([sys.executable, '-m', 'cfem_ros.cli', *argv], cwd=cwd,
                          preexec_fn=limit, capture_output=True, text=True, timeout=300)


def test_a_full_disk_ends_the_run_with_exit_1_and_no_partial_file(tmp_path):
    out = tmp_path / 'out.mcap'
    out.write_bytes(b'the previous recording')
    done = _limited(['run', str(SCENARIO), '-o', str(out), '--rate', '1000', '--overwrite'],
                    200_000, tmp_path)
    assert done.returncode == 1, done.stderr
    assert done.stderr.count('ERROR: ') == 1 and 'Traceback' not in done.stderr
    assert 'File too large' in done.stderr and 'the recording failed at t = ' in done.stderr
    assert 'was removed' in done.stderr and 'is untouched' in done.stderr
    assert out.read_bytes() == b'the previous recording'
    assert sorted(p.name for p in tmp_path.iterdir()) == ['out.mcap']


def test_a_full_disk_ends_recover_with_exit_1_and_no_output(tmp_path):
    whole = tmp_path / 'whole.mcap'
    assert cli.main(['run', str(SCENARIO), '-o', str(whole), '--rate', '1000']) == 0
    size = whole.stat().st_size
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(whole.read_bytes()[:size * 2 // 3])
    fixed = tmp_path / 'fixed.mcap'
    done = _limited(['recover', str(cut), '-o', str(fixed)], size // 3, tmp_path)
    assert done.returncode == 1, done.stderr
    assert done.stderr.count('ERROR: ') == 1 and 'Traceback' not in done.stderr
    assert 'File too large' in done.stderr and 'removed' in done.stderr
    assert not fixed.exists()
