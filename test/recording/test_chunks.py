# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The bulk MCAP writing path against the mcap library's own encoder and readers.

Samples are written as numpy-built Message records and the MessageIndex
records are built with numpy too; these tests hold them to the generic
``mcap_ros2`` encoder byte for byte, and read the file back with the mcap
reader (CRCs checked) and by following every index to its record.
"""

import io
import zlib

from cfem_ros.recording.chunks import CHUNK_SIZE, MESSAGE_HEADER
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.msgdefs import DEFINITIONS
from cfem_ros.recording.samplelayout import SampleLayout
from cfem_ros.recording.schema import POSE_TYPE, STRING_TYPE, TWIST_TYPE
from doctor import diagnose
from mcap.reader import make_reader
from mcap.records import (Channel, Chunk, ChunkIndex, DataEnd, Footer, Message, MessageIndex,
                          Schema, Statistics)
from mcap.stream_reader import breakup_chunk, StreamReader
from mcap_ros2._dynamic import serialize_dynamic
import numpy as np


def _encoder(msgtype):
    return serialize_dynamic(msgtype, DEFINITIONS[msgtype])[msgtype]


def _pose(stamp_ns, frame, v):
    sec, nanosec = divmod(stamp_ns, 10 ** 9)
    return {'header': {'stamp': {'sec': sec, 'nanosec': nanosec}, 'frame_id': frame},
            'pose': {'position': dict(zip('xyz', v[:3])),
                     'orientation': dict(zip('xyzw', v[3:7]))}}


def _twist(stamp_ns, frame, v):
    sec, nanosec = divmod(stamp_ns, 10 ** 9)
    return {'header': {'stamp': {'sec': sec, 'nanosec': nanosec}, 'frame_id': frame},
            'twist': {'linear': dict(zip('xyz', v[:3])), 'angular': dict(zip('xyz', v[3:6]))}}


def test_sample_records_are_the_generic_encoders_bytes():
    rng = np.random.default_rng(7)
    # frame names of every length modulo 8, so that every CDR padding occurs
    frames = ['w', 'ab', 'abc', 'abcd', 'abcde', 'abcdef', 'abcdefg', 'abcdefgh', 'ü9']
    messages = [(f, 7) if i % 2 == 0 else (f, 6) for i, f in enumerate(frames)]
    channels = list(range(3, 3 + len(frames)))
    layout = SampleLayout(channels, messages)
    stamps = [0, 999_999_999, 10 ** 9, 12 * 10 ** 9 + 345, 2 ** 31 * 10 ** 9 - 1]
    rows = rng.normal(size=(len(stamps), layout.size)) * 10.0 ** rng.integers(-5, 5)
    for stamp_ns, row in zip(stamps, rows):
        assert not layout.append(stamp_ns, row)
    records, chans, log_times, offsets = layout.records(first_sequence=40)
    assert chans == channels and list(log_times) == stamps
    pose, twist = _encoder(POSE_TYPE), _encoder(TWIST_TYPE)
    sequence = 40
    for s, stamp_ns in enumerate(stamps):
        column = 0
        for i, (frame, count) in enumerate(messages):
            start = int(offsets[s, i])
            opcode, length, channel, seq, log_time, publish_time = MESSAGE_HEADER.unpack_from(
                records, start)
            data = records[start + MESSAGE_HEADER.size:start + 9 + length]
            values = rows[s, column:column + count]
            expected = (pose(_pose(stamp_ns, frame, values)) if count == 7
                        else twist(_twist(stamp_ns, frame, values)))
            assert (opcode, channel, seq, log_time, publish_time) == (
                0x05, channels[i], sequence, stamp_ns, stamp_ns)
            assert bytes(data) == expected
            sequence += 1
            column += count
    assert len(records) == offsets[-1, -1] + 9 + length


def _write_mixed(path):
    """Two kinds of sample, switching, with dict messages and metadata between; several chunks."""
    rng = np.random.default_rng(3)
    written = []   # (topic, log time, encoded data) in writing order
    pose, twist, string = _encoder(POSE_TYPE), _encoder(TWIST_TYPE), _encoder(STRING_TYPE)
    with Recorder(str(path), overwrite=True, metadata={'case': 'mixed'}) as recorder:
        kinds = {
            'both': [('/a/pose', POSE_TYPE, 'world', 7), ('/a/twist', TWIST_TYPE, 'a', 6)],
            'pose': [('/a/pose', POSE_TYPE, 'world', 7)],
        }
        layouts = {key: recorder.layout(m) for key, m in kinds.items()}
        stamp_ns = 0
        for k in range(3 * CHUNK_SIZE // 100):
            key = 'both' if (k // 500) % 2 == 0 else 'pose'
            row = rng.normal(size=layouts[key].size)
            recorder.add_sample(layouts[key], stamp_ns, row)
            written.append(('/a/pose', stamp_ns, pose(_pose(stamp_ns, 'world', row[:7]))))
            if key == 'both':
                written.append(('/a/twist', stamp_ns,
                                twist(_twist(stamp_ns, 'a', row[7:]))))
            if k % 700 == 13:
                recorder.write('/a/events', STRING_TYPE, {'data': f'event {k}'}, stamp_ns)
                written.append(('/a/events', stamp_ns, string({'data': f'event {k}'})))
            stamp_ns += 10_000_000
    return written


def test_mixed_recording_reads_back_with_crcs_checked(tmp_path):
    path = tmp_path / 'mixed.mcap'
    written = _write_mixed(path)
    with open(path, 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        summary = reader.get_summary()
        got = [(channel.topic, message.log_time, message.data, message.sequence)
               for _, channel, message in reader.iter_messages(log_time_order=False)]
        metadata = list(reader.iter_metadata())
    assert [g[:3] for g in got] == written
    assert [g[3] for g in got] == list(range(len(written)))
    assert summary.statistics.message_count == len(written)
    counts = {}
    for topic, _, _ in written:
        counts[topic] = counts.get(topic, 0) + 1
    assert {summary.channels[c].topic: n
            for c, n in summary.statistics.channel_message_counts.items()} == counts
    assert summary.statistics.message_start_time == written[0][1]
    assert summary.statistics.message_end_time == written[-1][1]
    assert len(summary.chunk_indexes) == summary.statistics.chunk_count > 2
    assert [m.metadata for m in metadata] == [{'case': 'mixed'}]


def test_every_index_points_at_its_record(tmp_path):
    path = tmp_path / 'mixed.mcap'
    written = _write_mixed(path)
    data = path.read_bytes()
    records = list(StreamReader(io.BytesIO(data), emit_chunks=True, validate_crcs=True).records)
    footer = next(r for r in records if isinstance(r, Footer))
    data_end = next(r for r in records if isinstance(r, DataEnd))
    # the data section's CRC covers everything up to the Data End record
    assert data_end.data_section_crc == zlib.crc32(data[:footer.summary_start - 13])
    chunk_indexes = [r for r in records if isinstance(r, ChunkIndex)]
    assert len(chunk_indexes) == sum(isinstance(r, Chunk) for r in records)
    seen = 0
    for index in chunk_indexes:
        chunk = next(StreamReader(io.BytesIO(data[index.chunk_start_offset:]), skip_magic=True,
                                  emit_chunks=True).records)
        assert isinstance(chunk, Chunk)
        assert (chunk.message_start_time, chunk.message_end_time) == (
            index.message_start_time, index.message_end_time)
        inner = chunk.data
        messages = [r for r in breakup_chunk(chunk, validate_crc=True) if isinstance(r, Message)]
        entries = 0
        for channel, offset in index.message_index_offsets.items():
            message_index = next(StreamReader(io.BytesIO(data[offset:]), skip_magic=True)
                                 .records)
            assert isinstance(message_index, MessageIndex)
            assert message_index.channel_id == channel
            for log_time, where in message_index.records:
                _, _, ch, _, t, _ = MESSAGE_HEADER.unpack_from(inner, where)
                assert (ch, t) == (channel, log_time)
                entries += 1
        assert entries == len(messages)
        seen += entries
    assert seen == len(written)
    assert next(r for r in records if isinstance(r, Statistics)).message_count == seen


def test_magic_is_mcaps():
    from cfem_ros.recording.chunks import MCAP0_MAGIC
    from mcap.writer import MCAP0_MAGIC as theirs
    assert MCAP0_MAGIC == theirs


def test_mcap_doctor_finds_nothing(tmp_path):
    path = tmp_path / 'mixed.mcap'
    _write_mixed(path)
    assert diagnose(path) == []
    records = list(StreamReader(io.BytesIO(path.read_bytes()), emit_chunks=True).records)
    # schemas and channels only inside chunks (and in the summary), each once
    data_section = records[:next(i for i, r in enumerate(records) if isinstance(r, DataEnd))]
    assert not [r for r in data_section if isinstance(r, (Schema, Channel))]


def test_the_doctor_sees_what_it_should(tmp_path):
    """The check above can fail: records written twice, or out of time order, are found."""
    path = tmp_path / 'twice.mcap'
    with Recorder(str(path)) as recorder:
        recorder.write('/a', STRING_TYPE, {'data': 'x'}, 10)
        recorder._writer.close_chunk()
        recorder._writer._chunked_channels.clear()   # as the writer used to: again
        recorder._writer._chunked_schemas.clear()
        recorder.write('/a', STRING_TYPE, {'data': 'y'}, 5)
    found = diagnose(path)
    assert any('duplicate schema' in p for p in found)
    assert any('duplicate channel' in p for p in found)
    assert any('less than the latest log time' in p for p in found)


def test_a_channel_without_messages_is_in_the_data_section_too(tmp_path):
    path = tmp_path / 'unused.mcap'
    with Recorder(str(path)) as recorder:
        recorder.channel('/never', STRING_TYPE)
        recorder.write('/a', STRING_TYPE, {'data': 'x'}, 10)
    assert diagnose(path) == []
    with open(path, 'rb') as stream:
        summary = make_reader(stream).get_summary()
    assert {c.topic for c in summary.channels.values()} == {'/never', '/a'}
