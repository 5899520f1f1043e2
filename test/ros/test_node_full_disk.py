# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A recording node on a full disk: exit 1, one error line, the file kept complete.

The node runs as fast as it can (``real_time_factor:=0``, 1 kHz samples)
under a file size limit (``RLIMIT_FSIZE``, with SIGXFSZ ignored, so that
a write past it fails with EFBIG as one on a full disk fails with
ENOSPC). It must end by itself with exit status 1 and one ``[ERROR]``
line (the file, why, how far the run got), no traceback; the file it
leaves is a finished recording (summary, statistics, indexes; both
readers agree; nothing ``mcap doctor`` would report) of the run's first
samples, every 1 ms one from t = 0, with as many messages as the error
line says it keeps.
"""

import pathlib
import re
import resource
import signal

from doctor import diagnose
from mcap.reader import make_reader
from rosbags.rosbag2.storage_mcap import McapReader
from rosharness import NodeProcess

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
LIMIT = 400_000   # bytes: a few chunks of the double pendulum's samples
POSE = '/cfem/bodies/B/pose'


def _limit_file_size(limit=LIMIT):
    def limit_it():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    return limit_it


def _error_line(output):
    assert 'Traceback' not in output, output
    errors = [line for line in output.splitlines() if '[ERROR]' in line]
    assert len(errors) == 1, output
    return errors[0]


def test_a_full_disk_ends_a_recording_node_with_exit_1_and_a_complete_file(tmp_path):
    recording = tmp_path / 'node.mcap'
    node = NodeProcess(tmp_path, CONFIG / 'double_pendulum.yaml', record=recording,
                       real_time_factor=0.0, rate_hz=1000.0, duration=60.0,
                       preexec_fn=_limit_file_size())
    status = node.wait(timeout=60.0)
    output = node.output
    assert status == 1, output
    error = _error_line(output)
    assert str(recording) in error and 'File too large' in error, error
    found = re.search(r'recording failed at simulated t = ([0-9.e+-]+) s \((\d+) samples, '
                      r'(\d+) messages written\).* is kept complete up to its last whole '
                      r'chunk \((\d+) of (\d+) messages\).*the file ends at simulated '
                      r't = ([0-9.e+-]+) s; the run ends', error)
    assert found, error
    failed_at, samples = float(found[1]), int(found[2])
    kept, written, ends_at = int(found[4]), int(found[5]), float(found[6])
    assert 0 < failed_at < 60.0 and samples > 0
    assert 0 < kept < written == int(found[3])
    assert 0 <= ends_at <= failed_at
    assert 'run complete' not in output

    size = recording.stat().st_size
    assert size <= LIMIT
    with open(recording, 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None and summary.chunk_indexes, 'not finished'
        assert summary.statistics.message_count == kept
        stamps = [m.log_time for _, _, m in reader.iter_messages(topics=[POSE])]
        count = sum(1 for _ in reader.iter_messages())
    assert count == kept
    bag = McapReader(recording)
    bag.open()
    try:
        assert sum(1 for _ in bag.messages(bag.connections)) == kept
    finally:
        bag.close()
    assert diagnose(recording) == []
    assert len(stamps) > 10
    assert {b - a for a, b in zip(stamps, stamps[1:])} == {1_000_000}   # every sample kept
    assert abs((stamps[-1] - stamps[0]) / 1e9 - ends_at) < 1e-6
    assert sorted(p.name for p in tmp_path.iterdir()) == ['node.log', 'node.mcap']
