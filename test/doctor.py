# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What ``mcap doctor`` (the Go and Rust CLIs) checks, with the mcap library's stream reader.

``diagnose(path)`` returns the warnings and errors the Go CLI's doctor
(``go/cli/mcap/cmd/doctor.go``) would print: schema and channel records
written twice in the data section, a message before its channel, log times
that go back in file order, chunk times and message indexes that do not
match their messages, statistics that do not match the file, summary
records missing from the data section or missing for an indexed chunk.
"""

import io

from mcap.records import (Channel, Chunk, ChunkIndex, DataEnd, Message, MessageIndex, Schema,
                          Statistics)
from mcap.stream_reader import breakup_chunk, StreamReader


class _Doctor:

    def __init__(self):
        self.problems = []
        self.schemas, self.channels = {}, {}
        self.summary_schemas, self.summary_channels = set(), set()
        self.in_summary = False
        self.max_log_time, self.min_log_time = 0, None
        self.count, self.per_channel = 0, {}
        self.referenced = []   # the channels of each chunk, in file order

    def schema(self, record):
        if self.in_summary:
            if record.id not in self.schemas:
                self.problems.append(f'schema {record.id} in the summary only')
            self.summary_schemas.add(record.id)
        else:
            if record.id in self.schemas:
                self.problems.append(f'duplicate schema record {record.id} in the data section')
            self.schemas[record.id] = record

    def channel(self, record):
        if self.in_summary:
            if record.id not in self.channels:
                self.problems.append(f'channel {record.id} in the summary only')
            self.summary_channels.add(record.id)
        else:
            if record.id in self.channels:
                self.problems.append(f'duplicate channel record {record.id} in the data section')
            self.channels[record.id] = record
        if record.schema_id and record.schema_id not in self.schemas:
            self.problems.append(f'channel {record.id} before its schema {record.schema_id}')

    def chunk(self, chunk, indexes):
        times, channels, position = [], set(), 0
        for record in breakup_chunk(chunk, validate_crc=True):
            if isinstance(record, Schema):
                self.schema(record)
            elif isinstance(record, Channel):
                self.channel(record)
            elif isinstance(record, Message):
                topic = getattr(self.channels.get(record.channel_id), 'topic', None)
                if topic is None:
                    self.problems.append(f'message on channel {record.channel_id} before it')
                if record.log_time < self.max_log_time:
                    self.problems.append(f'log time {record.log_time} on {topic} is less than '
                                         f'the latest log time {self.max_log_time}')
                self.max_log_time = max(self.max_log_time, record.log_time)
                times.append(record.log_time)
                channels.add(record.channel_id)
                self.count += 1
                self.per_channel[record.channel_id] = (
                    self.per_channel.get(record.channel_id, 0) + 1)
                entries = {o: t for t, o in getattr(
                    indexes.get(record.channel_id), 'records', [])}
                if entries.get(position) != record.log_time:
                    self.problems.append(f'no message index entry for channel '
                                         f'{record.channel_id} at {position}')
            else:
                self.problems.append(f'illegal record in a chunk: {type(record).__name__}')
            position += 9 + int.from_bytes(chunk.data[position + 1:position + 9], 'little')
        if times and (min(times), max(times)) != (chunk.message_start_time,
                                                  chunk.message_end_time):
            self.problems.append(f'chunk {len(self.referenced)}: start/end times do not match')
        if times:
            self.min_log_time = min(times if self.min_log_time is None
                                    else times + [self.min_log_time])
        self.referenced.append(channels)


def diagnose(path) -> list:
    """Return what ``mcap doctor`` would warn of in the file at path (empty: clean)."""
    data = open(path, 'rb').read()
    doctor = _Doctor()
    reader = StreamReader(io.BytesIO(data), emit_chunks=True, validate_crcs=True)
    chunk, indexes, statistics, chunk_indexes = None, {}, None, []
    for record in reader.records:
        if chunk is not None and not isinstance(record, MessageIndex):
            doctor.chunk(chunk, indexes)
            chunk, indexes = None, {}
        if isinstance(record, Chunk):
            chunk = record
        elif isinstance(record, MessageIndex):
            if record.channel_id in indexes:
                doctor.problems.append(f'duplicate message index for {record.channel_id}')
            indexes[record.channel_id] = record
        elif isinstance(record, Schema):
            doctor.schema(record)
        elif isinstance(record, Channel):
            doctor.channel(record)
        elif isinstance(record, Message):
            doctor.problems.append('a message outside chunks')
        elif isinstance(record, DataEnd):
            doctor.in_summary = True
        elif isinstance(record, Statistics):
            statistics = record
        elif isinstance(record, ChunkIndex):
            chunk_indexes.append(record)
    if chunk is not None:
        doctor.chunk(chunk, indexes)
    if len(chunk_indexes) != len(doctor.referenced):
        doctor.problems.append(f'{len(doctor.referenced)} chunks, {len(chunk_indexes)} indexed')
    for channels in doctor.referenced:
        for channel in channels:
            if channel not in doctor.summary_channels:
                doctor.problems.append(f'channel {channel} of an indexed chunk not in summary')
            schema = doctor.channels[channel].schema_id
            if schema and schema not in doctor.summary_schemas:
                doctor.problems.append(f'schema {schema} of an indexed chunk not in summary')
    if statistics is not None:
        if statistics.message_count != doctor.count:
            doctor.problems.append('statistics: message count')
        if doctor.count and (statistics.message_start_time, statistics.message_end_time) != (
                doctor.min_log_time, doctor.max_log_time):
            doctor.problems.append('statistics: start/end times')
        for channel, count in doctor.per_channel.items():
            if statistics.channel_message_counts.get(channel) != count:
                doctor.problems.append(f'statistics: message count of channel {channel}')
    return doctor.problems
