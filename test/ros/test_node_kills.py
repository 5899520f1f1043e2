# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Kill a recording ``cfem_node`` at random moments and check what its recording holds.

Each kill starts the node on the double pendulum, as fast as it can go
(``real_time_factor:=0``, 1 kHz samples, a recording), and sends SIGINT,
SIGTERM or SIGKILL (in turn) a random delay after start: during start-up
(imports, topics, the first sample) or mid-run. Then:

- SIGINT and SIGTERM: during the imports, before ROS 2 is initialised, the
  node ends at once with one line, exit 130 or 143, and has written nothing;
  afterwards it exits 0 (ROS 2's way) and its recording, if it had begun, is
  complete: indexed, read by mcap's indexed reader (CRCs checked) and by
  rosbags, message counts equal to its statistics;
- SIGKILL: what is on disk is recovered by ``cfem-sim recover`` (the mcap
  stream reader): the samples are contiguous from the start, and less than
  a chunk (with its indexes) of the file is lost.

``make test`` makes 6 kills; ``CFEM_LONG_TESTS=1`` makes 150
(``CFEM_NODE_KILLS=N`` to choose) and prints the figures.
"""

import collections
import os
import pathlib
import random
import signal
import time

from cfem_ros.recording.chunks import CHUNK_SIZE
from cfem_ros.recording.recover import recover
from mcap.reader import make_reader
from rosbags.rosbag2.storage_mcap import McapReader
from rosharness import NodeProcess

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
LONG = os.environ.get('CFEM_LONG_TESTS') == '1'
KILLS = int(os.environ.get('CFEM_NODE_KILLS', 150 if LONG else 6))
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGKILL)
POSE = '/cfem/bodies/B/pose'


def _complete(path):
    """Return the messages of a complete recording, read by both readers; check counts."""
    with open(path, 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None and summary.chunk_indexes, 'not indexed'
        ours = sum(1 for _ in reader.iter_messages())
    bag = McapReader(pathlib.Path(path))
    bag.open()
    try:
        theirs = sum(1 for _ in bag.messages(bag.connections))
    finally:
        bag.close()
    assert ours == theirs == summary.statistics.message_count
    return ours


def _recovered(path, tmp_path):
    """Recover a killed node's file; return (bytes lost, samples kept); check contiguity."""
    fixed = tmp_path / 'fixed.mcap'
    if fixed.exists():
        fixed.unlink()
    report = recover(str(path), str(fixed))
    lost = report.size - report.cut_at if not report.complete else 0
    assert lost < 2 * CHUNK_SIZE + 16 * 1024, report
    with open(fixed, 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        stamps = [m.log_time for _, _, m in reader.iter_messages(topics=[POSE])]
    if stamps:
        steps = {b - a for a, b in zip(stamps, stamps[1:])}
        assert steps <= {1_000_000}, sorted(steps)[:5]   # every 1 ms sample, none missing
    return lost, len(stamps)


def test_a_killed_node_leaves_a_complete_or_recoverable_recording(tmp_path):
    rng = random.Random(20261122)
    figures = collections.Counter()
    lost_bytes = []
    for k in range(KILLS):
        sig = SIGNALS[k % 3]
        folder = tmp_path / f'kill{k}'
        folder.mkdir()
        recording = folder / 'node.mcap'
        node = NodeProcess(folder, CONFIG / 'double_pendulum.yaml', record=recording,
                           real_time_factor=0.0, duration=0.0, rate_hz=1000.0)
        delay = rng.uniform(0.3, 6.0 if LONG else 4.0)
        time.sleep(delay)
        figures['mid-run' if recording.exists() else 'start-up'] += 1
        status = node.stop(sig, timeout=60)
        output = node.output
        assert 'Traceback' not in output, output[-2000:]
        if sig == signal.SIGKILL:
            assert status == -signal.SIGKILL
            if recording.exists() and recording.stat().st_size:
                lost, samples = _recovered(recording, folder)
                lost_bytes.append(lost)
                figures['SIGKILL recovered'] += 1
            continue
        if status == 128 + sig:   # during its imports: ended at once, nothing written
            assert f'interrupted by {signal.Signals(sig).name}' in output
            assert not recording.exists()
            figures['ended in start-up'] += 1
            continue
        assert status == 0, output[-2000:]
        if recording.exists():
            assert _complete(recording) > 0
            figures[f'{signal.Signals(sig).name} complete'] += 1
    if LONG:
        print(f'\n{KILLS} kills of a recording node: {dict(figures)}; bytes lost after '
              f'SIGKILL: at most {max(lost_bytes, default=0)}')
    assert sum(figures[f'{s} complete'] for s in ('SIGINT', 'SIGTERM')) >= 1
