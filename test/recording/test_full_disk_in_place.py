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
import io

from cfem_ros.recording import container as recorder_module
from cfem_ros.recording.chunks import CHUNK_SIZE
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.errors import OutputError
from cfem_ros.recording.recover import recover
from cfem_ros.recording.schema import STRING_TYPE
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


def _record(path, limit=None, metadata_at=None):
    """
    Write MESSAGES strings (a metadata record first, another before message metadata_at).

    limit: bytes the file takes after the first metadata record before it is full.
    """
    with Recorder(str(path), metadata={'scenario': 'x'}) as recorder:
        if limit is not None:
            recorder._stream = recorder._writer._stream = _FullAfter(recorder._stream, limit)
        for k in range(MESSAGES):
            if k == metadata_at:
                recorder.add_metadata({'note': 'y' * 200})
            recorder.write('/cfem/events', STRING_TYPE, {'data': f'{k:04d}' + 'x' * 1000},
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

    def no_room(self, stream, mark):
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


class _FullFile(io.FileIO):
    """A file that takes ``room`` bytes, then fails as a full disk does (below the buffer)."""

    room = 0

    def write(self, data):
        if len(data) > self.room:
            super().write(bytes(data[:self.room]))
            self.room = 0
            raise OSError(errno.EFBIG, 'File too large')
        self.room -= len(data)
        return super().write(data)


def test_a_record_still_buffered_is_not_kept(tmp_path, monkeypatch):
    """
    The disk fills up under a metadata record handed to the buffer whole but never written.

    The file is finished at the chunk before it, not over zeros where it
    would have been.
    """
    _record(tmp_path / 'whole.mcap', metadata_at=100)
    with open(tmp_path / 'whole.mcap', 'rb') as stream:
        indexes = make_reader(stream).get_summary().metadata_indexes
    _, reference = _messages(tmp_path / 'whole.mcap')

    def full_open(path, mode='r', *args, **kwargs):
        if mode not in ('xb', 'wb'):
            return open(path, mode, *args, **kwargs)
        raw = _FullFile(path, mode[0])
        raw.room = indexes[1].offset + 50   # in the second metadata record
        return io.BufferedWriter(raw)

    monkeypatch.setattr(recorder_module, 'open', full_open, raising=False)
    cut = tmp_path / 'cut.mcap'
    with pytest.raises(OutputError) as raised:
        _record(cut, metadata_at=100)
    monkeypatch.undo()
    assert raised.value.complete, raised.value
    assert cut.stat().st_size > indexes[1].offset
    summary, kept = _messages(cut)
    assert summary.statistics.metadata_count == 1 and len(summary.metadata_indexes) == 1
    assert 0 < len(kept) < 100 and kept == reference[:len(kept)]
    assert diagnose(cut) == []


def test_no_whole_chunk_on_disk_leaves_no_file(tmp_path):
    cut = tmp_path / 'cut.mcap'
    with pytest.raises(OutputError) as raised:
        _record(cut, limit=1000)
    assert f'{cut} was removed' in str(raised.value) and raised.value.kept_messages is None
    assert not cut.exists()
