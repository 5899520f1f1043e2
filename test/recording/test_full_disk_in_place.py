# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A recording written in place (the node's) that hits a full disk keeps its whole chunks.

The file's stream fails with EFBIG once it holds ``limit`` bytes, in the
middle of a chunk, as a full disk or a file size limit makes it fail.
The recorder cuts the file back to its last whole chunk and finishes it
there: the file then holds exactly the first messages of the same
recording made without a limit (the reference), with its summary, and
nothing ``mcap doctor`` would report. When even the summary does not fit,
the file is left cut after its last whole chunk, as a hard kill leaves it,
and ``recover`` gets those messages back.
"""

import errno

from cfem_ros.recording.errors import OutputError
from cfem_ros.recording.recorder import CHUNK_SIZE, Recorder, STRING
from cfem_ros.recording.recover import recover
from doctor import diagnose
from mcap.reader import make_reader
import pytest

MESSAGES = 300   # of about 1 kB: four or five chunks


class _FullAfter:
    """A binary stream that takes limit bytes, then fails as a full disk does."""

    def __init__(self, stream, limit):
        self.stream, self.room = stream, limit

    def write(self, data):
        if len(data) > self.room:
            self.stream.write(bytes(data[:self.room]))   # a short write, then the error
            self.room = 0
            raise OSError(errno.EFBIG, 'File too large')
        self.room -= len(data)
        return self.stream.write(data)

    def flush(self):
        self.stream.flush()

    def close(self):
        self.stream.close()


def _record(path, limit=None):
    """Write MESSAGES strings (a metadata record first); limit: bytes before the disk is full."""
    with Recorder(str(path), metadata={'scenario': 'x'}) as recorder:
        if limit is not None:
            recorder._stream = recorder._writer._stream = _FullAfter(recorder._stream, limit)
        for k in range(MESSAGES):
            recorder.write('/cfem/events', STRING, {'data': f'{k:04d}' + 'x' * 1000},
                           1_000_000 * k)


def _messages(path):
    with open(path, 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        summary = reader.get_summary()
        return summary, [(m.log_time, m.data) for _, _, m in reader.iter_messages()]


def test_a_full_disk_keeps_the_whole_chunks_finished(tmp_path):
    _record(tmp_path / 'whole.mcap')
    _, reference = _messages(tmp_path / 'whole.mcap')
    assert len(reference) == MESSAGES
    cut = tmp_path / 'cut.mcap'
    with pytest.raises(OutputError) as raised:
        _record(cut, limit=int(2.5 * CHUNK_SIZE))
    error = raised.value
    assert error.complete and 'File too large' in str(error)
    assert 'is kept complete up to its last whole chunk' in str(error)
    summary, kept = _messages(cut)
    assert summary is not None and summary.statistics.message_count == len(kept)
    assert 0 < len(kept) == error.kept_messages < MESSAGES
    assert kept == reference[:len(kept)]     # the first messages, none torn or missing
    assert error.kept_until_ns == kept[-1][0]
    assert len(summary.chunk_indexes) == 2 and summary.statistics.metadata_count == 1
    assert diagnose(cut) == []


def test_no_room_for_the_summary_leaves_the_whole_chunks_for_recover(tmp_path, monkeypatch):
    _record(tmp_path / 'whole.mcap')
    _, reference = _messages(tmp_path / 'whole.mcap')

    def no_room(self, stream):
        stream.write(b'\x05' * 100)   # a summary begun
        raise OSError(errno.ENOSPC, 'No space left on device')

    from cfem_ros.recording.chunks import ChunkedWriter
    monkeypatch.setattr(ChunkedWriter, 'finish_complete', no_room)
    cut = tmp_path / 'cut.mcap'
    with pytest.raises(OutputError) as raised:
        _record(cut, limit=int(2.5 * CHUNK_SIZE))
    error = raised.value
    assert not error.complete and 'without a summary' in str(error)
    assert f'cfem-sim recover {cut}' in str(error)
    report = recover(str(cut), str(tmp_path / 'fixed.mcap'))
    assert report.cut_at == report.size == cut.stat().st_size   # it ends on a whole record
    _, kept = _messages(tmp_path / 'fixed.mcap')
    assert len(kept) == error.kept_messages and kept == reference[:len(kept)]
