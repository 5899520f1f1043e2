# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Kill ``cfem-sim run`` at random moments and check what it leaves.

Each kill starts ``cfem-sim run config/double_pendulum.yaml --duration 300
--rate RATE --overwrite`` over an existing good recording and sends
SIGINT, SIGTERM or SIGKILL (in turn) a random delay after the process has
installed its handlers (the interpreter's first tenth of a second is not
cfem-sim's): during start-up (imports, compilation, scenario loading) or
mid-run. Then:

- SIGINT exits 130 and SIGTERM 143, with one line on stderr and no
  traceback; OUT is the old recording (stopped before recording) or a new
  complete one: indexed, read by mcap's indexed reader (CRCs checked) and by
  rosbags, message counts equal to its statistics; no partial file is left;
- after SIGKILL, OUT is the old recording, byte for byte; the partial file
  (if recording had begun) is recovered by ``cfem-sim recover``: its samples
  are contiguous from t = 0, and less than one chunk (with its indexes) of
  the file on disk is lost.

``make test`` makes 6 kills (at 100 samples a second); ``CFEM_LONG_TESTS=1`` makes 300
(``CFEM_KILLS=N`` to choose) and prints the figures.
"""

import collections
import os
import pathlib
import random
import shutil
import signal
import subprocess
import sys
import time

from cfem_ros.recording.chunks import CHUNK_SIZE
from cfem_ros.recording.recover import recover
from mcap.reader import make_reader
import pytest
from rosbags.rosbag2.storage_mcap import McapReader

ROOT = pathlib.Path(__file__).resolve().parents[2]
CFEM_SIM = str(pathlib.Path(sys.executable).with_name('cfem-sim'))
LONG = os.environ.get('CFEM_LONG_TESTS') == '1'
# 9: each signal both during start-up and mid-run (k % 3, k % 2)
KILLS = int(os.environ.get('CFEM_KILLS', 300 if LONG else 6))
#: Samples a second: the quick run's files are smaller, as quick to check as to write.
RATE = 1000 if LONG else 100
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGKILL)


def _counts(path):
    """Return (messages read by mcap's indexed reader, by rosbags, the statistics' count)."""
    with open(path, 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None and summary.chunk_indexes is not None
        ours = sum(1 for _ in reader.iter_messages())
    bag = McapReader(pathlib.Path(path))
    bag.open()
    try:
        theirs = sum(1 for _ in bag.messages(bag.connections))
    finally:
        bag.close()
    return ours, theirs, summary.statistics.message_count


def _check_recovered(partial, tmp_path):
    """Recover a partial file; return the bytes lost at its end; check the samples."""
    fixed = tmp_path / 'fixed.mcap'
    if fixed.exists():
        fixed.unlink()
    report = recover(str(partial), str(fixed))
    assert not report.complete
    lost = report.size - report.cut_at
    assert lost < 2 * CHUNK_SIZE + 16 * 1024, report
    with open(fixed, 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        stamps = [m.log_time for _, c, m in reader.iter_messages(
            topics=['/cfem/bodies/B/pose'])]
    assert stamps == [k * 1_000_000_000 // RATE for k in range(len(stamps))]
    return lost, len(stamps)


def _wait_for_handlers(pid: int, timeout: float = 60.0):
    """
    Wait until cfem-sim's own code runs: the process catches SIGTERM.

    Before that, the Python interpreter is starting (a tenth of a second),
    and a signal ends it as it ends any Python program.
    """
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            with open(f'/proc/{pid}/status') as status:
                caught = next(int(line.split()[1], 16) for line in status
                              if line.startswith('SigCgt:'))
        except (OSError, StopIteration):
            return
        if caught >> (signal.SIGTERM - 1) & 1:
            return
        time.sleep(0.002)
    raise AssertionError('cfem-sim did not start within 60 s')


def _kill_once(sig, delay, out, old, tmp_path):
    # a replaced OUT is a new file (the partial renamed onto it), whatever its bytes: two
    # runs stopped at the same batch of samples write the same bytes
    inode = os.stat(out).st_ino
    process = subprocess.Popen(
        [CFEM_SIM, 'run', str(ROOT / 'config' / 'double_pendulum.yaml'), '-o', str(out),
         '--duration', '300', '--rate', str(RATE), '--overwrite'],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for_handlers(process.pid)
    time.sleep(delay)
    finished = process.poll() is not None   # the whole run done before the signal
    if not finished:
        process.send_signal(sig)
    try:
        stdout, stderr = process.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        process.kill()
        process.communicate()
        raise
    partials = list(tmp_path.glob(f'.{out.name}.partial-*'))
    if finished or process.returncode == 0:   # or the signal came as it was exiting
        assert process.returncode == 0 and '300 s simulated' in stdout, (stdout, stderr)
        assert not partials and _counts(out)[0] == 9 * (300 * RATE + 1) + 2
        return 'finished', 300 * RATE + 1, 0
    if sig == signal.SIGKILL:
        assert process.returncode == -signal.SIGKILL
        assert out.read_bytes() == old and os.stat(out).st_ino == inode, \
            'the old recording was damaged'
        if not partials:
            return 'start-up', 0, 0
        assert partials == [tmp_path / f'.{out.name}.partial-{process.pid}']
        head = partials[0].read_bytes()[:8]
        if head != b'\x89MCAP0\r\n':   # killed as the file was opened: nothing written yet
            assert b'\x89MCAP0\r\n'.startswith(head), head
            partials[0].unlink()
            return 'start-up', 0, 0
        lost, samples = _check_recovered(partials[0], tmp_path)
        partials[0].unlink()
        return 'mid-run', samples, lost
    name = signal.Signals(sig).name
    assert process.returncode == 128 + sig, (process.returncode, stderr)
    assert 'Traceback' not in stderr and stderr.count('\n') == 1, stderr
    assert name in stderr, stderr
    assert not partials, partials
    if os.stat(out).st_ino == inode:
        assert out.read_bytes() == old, 'the old recording was damaged'
        assert 'start-up' in stderr or 'interrupted' in stderr, stderr
        return 'start-up', 0, 0
    ours, theirs, stated = _counts(out)
    assert ours == theirs == stated, (ours, theirs, stated)
    assert f'({stated} messages) in {out}, complete' in stderr, stderr
    return 'mid-run', stated // 9, 0   # 9 messages a sample (poses, twists, wrenches, /tf)


@pytest.mark.skipif(shutil.which(CFEM_SIM) is None, reason='needs the cfem-sim script')
def test_kills_leave_complete_or_recoverable_files(tmp_path):
    out = tmp_path / 'run.mcap'
    # the old recording that --overwrite must not damage before the new one is complete
    subprocess.run([CFEM_SIM, 'run', str(ROOT / 'config' / 'double_pendulum.yaml'), '-o',
                    str(out), '--duration', '0.1'], check=True, capture_output=True)
    old = out.read_bytes()
    started = time.monotonic()
    subprocess.run([CFEM_SIM, 'check', str(ROOT / 'config' / 'double_pendulum.yaml')],
                   capture_output=True, check=True)
    start_up = time.monotonic() - started   # imports, compilation from the cache
    rng = random.Random(int(os.environ.get('CFEM_KILL_SEED', '2026')))
    figures = collections.Counter()
    lost_most, samples_most = 0, 0
    for k in range(KILLS):
        sig = SIGNALS[k % 3]
        # half during start-up, half in the run's first moments (seconds if LONG)
        delay = (rng.uniform(0.0, start_up) if k % 2
                 else start_up + rng.uniform(0.0, 2.0 if LONG else 0.6))
        when, samples, lost = _kill_once(sig, delay, out, old, tmp_path)
        figures[signal.Signals(sig).name, when] += 1
        if LONG:
            print(f'kill {k + 1}: {signal.Signals(sig).name} after {delay:.2f} s, {when}, '
                  f'{samples} samples, {lost} bytes cut', flush=True)
        lost_most = max(lost_most, lost)
        samples_most = max(samples_most, samples)
        if out.read_bytes() != old:   # a complete new recording: the next run replaces it
            old = out.read_bytes()
    assert sum(figures.values()) == KILLS
    # the runs did get stopped mid-run (a signal ignored while recording would not)
    assert figures['SIGINT', 'mid-run'] + figures['SIGTERM', 'mid-run'] >= KILLS // 6
    if LONG or KILLS > 6:
        print(f'\n{KILLS} kills (start-up {start_up:.2f} s):')
        for (name, when), count in sorted(figures.items()):
            print(f'  {name:<8} {when:<9} {count}')
        print(f'  most samples in one killed run: {samples_most}; most bytes after the last '
              f'complete record of a SIGKILLed file: {lost_most}')
