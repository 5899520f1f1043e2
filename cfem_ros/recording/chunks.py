# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
An MCAP writer whose chunks take message records many at a time.

The ``mcap`` package's ``Writer`` spends about 5 us of Python on every
message: for the double pendulum's 8 messages per sample that is as much as
the 10 integration steps between two samples. ``ChunkedWriter`` writes the
same layout as that writer (magic, header; schema and channel records;
chunks, each followed by its message indexes; metadata; data end; a summary
with the schemas, channels, statistics, chunk indexes and metadata indexes,
and its summary offsets; footer; magic), with ``mcap.records`` serializing
every record except the two that come by the thousand: Message records,
which the caller builds many at once (``message_records``), and
MessageIndex records, built here with numpy. The readers in the tests
(``mcap``'s with CRC checks, and ``rosbags``) read what it writes.

Schema and channel records are written once in the data section, in the
first chunk that holds a message of the channel, before that message (as
rosbag2's writer does: ``mcap doctor`` warns of a record written twice), and
again in the summary for the readers that stop there. A stream reader or a
recovery tool meets a message's channel and schema before the message.

A chunk is written with SIGINT and SIGTERM held (``signals_held``): a
signal handler runs only between chunks, never inside a half-written one.
"""

from __future__ import annotations

import contextlib
import dataclasses
import signal
import struct
from typing import BinaryIO, Dict, List, Optional
import zlib

from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (Channel, ChunkIndex, DataEnd, Footer, Header, Metadata,
                          MetadataIndex, Schema, Statistics, SummaryOffset)
import numpy as np

#: The file's magic (MCAP specification; ``mcap.writer.MCAP0_MAGIC``, whose module imports
#: importlib.metadata and both compressors: not needed here).
MCAP0_MAGIC = b'\x89MCAP0\r\n'
#: A recording's chunk size in bytes: small, so that a hard kill loses little.
CHUNK_SIZE = 64 * 1024
#: Samples handed over a batch at a time (``Recorder.free_rows``) are
#: buffered for up to this many chunks before they are written: a batched
#: run comes back to Python once per batch, not once per chunk.
BATCH_CHUNKS = 16

#: A Message record up to its data: opcode, record length, channel id,
#: sequence, log time, publish time.
MESSAGE_HEADER = struct.Struct('<BQHIQQ')
#: An uncompressed Chunk record up to its records: opcode, record length,
#: message start and end time, uncompressed size and CRC, compression ''
#: (length 0), byte length of the records.
_CHUNK_HEADER = struct.Struct('<BQQQQIIQ')
#: A MessageIndex record up to its entries: opcode, record length, channel
#: id, byte length of the (log time, offset) entries.
_MESSAGE_INDEX_HEADER = struct.Struct('<BQHI')


#: The signals held while a chunk (or the summary) is written.
HELD_SIGNALS = {signal.SIGINT, signal.SIGTERM}


@contextlib.contextmanager
def signals_held():
    """
    Hold SIGINT and SIGTERM in this thread while the block runs; deliver them after.

    A Python signal handler (e.g. one raising KeyboardInterrupt) then runs
    after the block, never in the middle of it.
    """
    try:
        previous = signal.pthread_sigmask(signal.SIG_BLOCK, HELD_SIGNALS)
    except (AttributeError, OSError, ValueError):   # no pthread_sigmask here
        previous = None
    try:
        yield
    finally:
        if previous is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def message_record_fields(data_dtype: np.dtype) -> list:
    """
    Return the numpy fields of a Message record whose data has the given (packed) dtype.

    ``times`` holds the log time and the publish time, in that order.
    """
    return [('opcode', 'u1'), ('length', '<u8'), ('channel', '<u2'), ('sequence', '<u4'),
            ('times', '<u8', (2,)), ('data', data_dtype)]


def _serialize(record) -> bytes:
    builder = RecordBuilder()
    record.write(builder)
    return builder.end()


class ChunkedWriter:
    """
    Write an MCAP file to a binary stream; chunks are uncompressed.

    Parameters
    ----------
    stream : binary file
        Written from its start; not closed.
    profile, library : str
        Of the header record.
    chunk_size : int
        A chunk is closed (written with its indexes) once it holds this many bytes.

    """

    def __init__(self, stream: BinaryIO, *, profile: str, library: str, chunk_size: int):
        self._stream = stream
        self._offset = 0
        self._data_crc = 0
        self._chunk_size = chunk_size
        self._chunk: List[bytes] = []
        self._chunk_bytes = 0
        self._chunk_times = None            # (start, end) of the chunk in progress
        self._parts: List[tuple] = []   # (channels, log times, offsets) added to the chunk
        self._schemas: Dict[int, bytes] = {}    # serialized records, by id
        self._channels: Dict[int, bytes] = {}
        self._channel_schema: Dict[int, int] = {}
        self._chunked_schemas = set()    # ids written in a chunk already
        self._chunked_channels = set()
        self._chunk_indexes: List[ChunkIndex] = []
        self._metadata_indexes: List[MetadataIndex] = []
        self.statistics = Statistics(
            message_count=0, schema_count=0, channel_count=0, attachment_count=0,
            metadata_count=0, chunk_count=0, message_start_time=0, message_end_time=0,
            channel_message_counts={})
        self._write_data(MCAP0_MAGIC)
        self._write_data(_serialize(Header(profile=profile, library=library)))
        # where the file is whole (``_mark``): the last such place, the last one flushed
        self._latest, self._flushed = {}, None
        self._mark(chunk=True, flushed=False)

    # --------------------------------------------------------------- records

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        """Register a schema (written with its channel's first message); return its id."""
        schema = Schema(id=len(self._schemas) + 1, name=name, encoding=encoding, data=data)
        self._schemas[schema.id] = _serialize(schema)   # in a chunk, and in the summary
        self.statistics.schema_count += 1
        return schema.id

    def register_channel(self, topic: str, message_encoding: str, schema_id: int,
                         metadata: Dict[str, str]) -> int:
        """Register a channel (written before its first message); return its id."""
        channel = Channel(id=len(self._channels) + 1, topic=topic,
                          message_encoding=message_encoding, schema_id=schema_id,
                          metadata=metadata)
        self._channels[channel.id] = _serialize(channel)   # in a chunk, and in the summary
        self._channel_schema[channel.id] = schema_id
        self.statistics.channel_count += 1
        self.statistics.channel_message_counts[channel.id] = 0
        return channel.id

    def add_metadata(self, name: str, data: Dict[str, str]):
        """Write a metadata record and index it."""
        record = _serialize(Metadata(name=name, metadata=data))
        self._metadata_indexes.append(
            MetadataIndex(offset=self._offset, length=len(record), name=name))
        self.statistics.metadata_count += 1
        self._write_data(record)
        self._mark(chunk=False, flushed=False)

    def add_message(self, channel: int, log_time: int, data: bytes, sequence: int,
                    publish_time: int):
        """Add one message to the chunk in progress."""
        record = MESSAGE_HEADER.pack(Opcode.MESSAGE, 22 + len(data), channel, sequence,
                                     log_time, publish_time) + data
        self.add_messages(record, [channel], np.array([log_time]), np.zeros((1, 1), np.int64))

    def add_messages(self, records: bytes, channels, log_times: np.ndarray,
                     offsets: np.ndarray):
        """
        Add the Message records of k samples to the chunk in progress, in their order.

        Sample s has one message on each of ``channels``, all logged at
        ``log_times[s]``; its message on channels[i] starts at offsets[s, i]
        of ``records`` (complete Message records, back to back).
        """
        k = len(log_times)
        if not k:
            return
        for channel in channels:
            if channel not in self._chunked_channels:
                self._add_to_chunk(channel)
        base = self._chunk_bytes
        stats = self.statistics
        self._parts.append((channels, log_times, offsets + base))
        for channel in channels:
            stats.channel_message_counts[channel] += k
        start, end = int(log_times.min()), int(log_times.max())
        if stats.message_count == 0:
            stats.message_start_time, stats.message_end_time = start, end
        stats.message_start_time = min(stats.message_start_time, start)
        stats.message_end_time = max(stats.message_end_time, end)
        stats.message_count += k * len(channels)
        if self._chunk_times is None:
            self._chunk_times = (start, end)
        self._chunk_times = (min(self._chunk_times[0], start), max(self._chunk_times[1], end))
        self._chunk.append(records)
        self._chunk_bytes += len(records)
        if self._chunk_bytes >= self._chunk_size:
            self.close_chunk()

    def chunk_room(self) -> int:
        """Return the bytes the chunk in progress takes before it is closed."""
        return max(0, self._chunk_size - self._chunk_bytes)

    def _add_to_chunk(self, channel: int):
        """Put the channel's record (and its schema's, the first time) in the chunk."""
        schema = self._channel_schema[channel]
        records = []
        if schema and schema not in self._chunked_schemas:
            records.append(self._schemas[schema])
            self._chunked_schemas.add(schema)
        records.append(self._channels[channel])
        self._chunked_channels.add(channel)
        for record in records:
            self._chunk.append(record)
            self._chunk_bytes += len(record)

    def close_chunk(self):
        """Write the chunk in progress (if it has messages) and its message indexes."""
        if not self._chunk:
            return
        with signals_held():
            self._close_chunk()

    def _close_chunk(self):
        if not self._chunk:
            return
        size = self._chunk_bytes
        crc = 0
        for part in self._chunk:
            crc = zlib.crc32(part, crc)
        start, end = self._chunk_times
        # the Chunk record, its records written as they are (no copy into one)
        header = _CHUNK_HEADER.pack(Opcode.CHUNK, _CHUNK_HEADER.size - 9 + size, start, end,
                                    size, crc, 0, size)
        index = ChunkIndex(message_start_time=start, message_end_time=end,
                           chunk_start_offset=self._offset,
                           chunk_length=_CHUNK_HEADER.size + size, message_index_offsets={},
                           message_index_length=0, compression='', compressed_size=size,
                           uncompressed_size=size)
        self._write_data(header)
        for part in self._chunk:
            self._write_data(part)
        indexes, position = [], self._offset
        for channel, entries in self._index_entries():
            index.message_index_offsets[channel] = position
            indexes.append(_MESSAGE_INDEX_HEADER.pack(Opcode.MESSAGE_INDEX,
                                                      6 + entries.nbytes, channel,
                                                      entries.nbytes))
            indexes.append(entries.data)
            position += _MESSAGE_INDEX_HEADER.size + entries.nbytes
        indexes = b''.join(indexes)
        index.message_index_length = len(indexes)
        self._write_data(indexes)
        self._chunk_indexes.append(index)
        self.statistics.chunk_count += 1
        self._chunk, self._chunk_bytes, self._chunk_times = [], 0, None
        self._parts = []
        self._stream.flush()   # a closed chunk survives a hard kill
        self._mark(chunk=True, flushed=True)

    def _mark(self, chunk: bool, flushed: bool):
        """
        Note that the file is whole up to here: after a closed chunk, a metadata record.

        With chunk, also the statistics and the records written in chunks,
        which the chunk in progress changes before it is written. A mark
        is on disk once flushed (a closed chunk, and what came before it).
        """
        mark = dict(self._latest)
        mark.update(offset=self._offset, crc=self._data_crc,
                    metadata=len(self._metadata_indexes))
        if chunk:
            stats = self.statistics
            mark.update(chunks=len(self._chunk_indexes), schemas=set(self._chunked_schemas),
                        channels=set(self._chunked_channels), statistics=dataclasses.replace(
                            stats, channel_message_counts=dict(stats.channel_message_counts)))
        self._latest = mark
        if flushed:
            self._flushed = mark

    def whole_part(self, size: int) -> Optional[dict]:
        """
        Return the last mark of a file that holds size bytes (after a failed write), or None.

        The mark's ``offset`` is where the file's whole records end (a
        closed chunk, a metadata record; at most size), its ``statistics``
        those of the messages before it. None: not even the header is whole.
        """
        for mark in (self._latest, self._flushed):
            if mark is not None and mark['offset'] <= size:
                return mark
        return None

    def finish_complete(self, stream: BinaryIO, mark: dict):
        """
        Finish the file as it was at a mark of ``whole_part``, on stream (after a failed write).

        What came after the mark is dropped; stream holds the file cut at
        the mark's offset and is positioned there. The summary and footer
        then describe the chunks before it only.
        """
        self._stream = stream
        self._offset, self._data_crc = mark['offset'], mark['crc']
        del self._chunk_indexes[mark['chunks']:]
        del self._metadata_indexes[mark['metadata']:]
        self._chunked_schemas, self._chunked_channels = set(mark['schemas']), set(
            mark['channels'])
        self.statistics = dataclasses.replace(
            mark['statistics'], metadata_count=mark['metadata'],
            channel_message_counts=dict(mark['statistics'].channel_message_counts))
        self._chunk, self._chunk_bytes, self._chunk_times, self._parts = [], 0, None, []
        with signals_held():
            self._finish()

    def _index_entries(self):
        """Yield (channel, (log time, offset) entries as uint64 (k, 2)) of the chunk."""
        if len(self._parts) == 1:   # the usual chunk: one block of samples
            channels, log_times, offsets = self._parts[0]
            entries = np.empty((len(channels), len(log_times), 2), dtype='<u8')
            entries[:, :, 0] = log_times
            entries[:, :, 1] = offsets.T
            yield from zip(channels, entries)
            return
        found: Dict[int, list] = {}
        for channels, log_times, offsets in self._parts:
            entries = np.empty((len(channels), len(log_times), 2), dtype='<u8')
            entries[:, :, 0] = log_times
            entries[:, :, 1] = offsets.T
            for channel, rows in zip(channels, entries):
                found.setdefault(channel, []).append(rows)
        for channel, parts in found.items():
            yield channel, np.concatenate(parts)

    # ---------------------------------------------------------------- finish

    def finish(self):
        """Close the last chunk and write the summary and footer."""
        with signals_held():
            self._close_chunk()
            self._finish()

    def _finish(self):
        # channels that never had a message: in the data section too, as the summary's are
        for channel in self._channels:
            if channel not in self._chunked_channels:
                schema = self._channel_schema[channel]
                if schema and schema not in self._chunked_schemas:
                    self._write_data(self._schemas[schema])
                    self._chunked_schemas.add(schema)
                self._write_data(self._channels[channel])
        self._write_data(_serialize(DataEnd(data_section_crc=self._data_crc)))
        summary_start = self._offset
        parts, offsets = [], []
        groups = ((Opcode.SCHEMA, list(self._schemas.values())),
                  (Opcode.CHANNEL, list(self._channels.values())),
                  (Opcode.STATISTICS, [_serialize(self.statistics)]),
                  (Opcode.CHUNK_INDEX, [_serialize(r) for r in self._chunk_indexes]),
                  (Opcode.METADATA_INDEX, [_serialize(r) for r in self._metadata_indexes]))
        position = summary_start
        for opcode, records in groups:
            group = b''.join(records)
            offsets.append(SummaryOffset(group_opcode=opcode, group_start=position,
                                         group_length=len(group)))
            parts.append(group)
            position += len(group)
        summary_offset_start = position
        parts.extend(_serialize(offset) for offset in offsets)
        summary = b''.join(parts)
        crc = zlib.crc32(summary)
        crc = zlib.crc32(struct.pack('<BQQQ', Opcode.FOOTER, 20, summary_start,
                                     summary_offset_start), crc)
        self._stream.write(summary)
        self._stream.write(_serialize(Footer(summary_start=summary_start,
                                             summary_offset_start=summary_offset_start,
                                             summary_crc=crc)))
        self._stream.write(MCAP0_MAGIC)
        self._stream.flush()

    def _write_data(self, data: bytes):
        self._data_crc = zlib.crc32(data, self._data_crc)
        self._stream.write(data)
        self._offset += len(data)
