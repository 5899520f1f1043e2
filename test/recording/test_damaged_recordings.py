# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Damaged recordings through every reading command: one ERROR line or a correct result.

The shapes of damage of issue 29 (truncations; flipped bytes in the
magic, the header, a schema record, a chunk's records, its CRC, a zstd
chunk, the summary and the footer; a schema name that no longer parses; a
zero-norm quaternion) go through ``info``, ``plot``, ``compare``,
``summarize``, ``run --inputs`` and ``recover``. Readers end with exit 2
and one ``ERROR:`` line naming the file; ``recover`` keeps only messages
of the original, bit for bit, in a file the indexed reader, rosbags'
reader and the CDR decoder all accept, skipping a damaged chunk and going
on with the next.
"""

import pathlib
import struct

from cfem_ros import cli
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.recover import recover
from cfem_ros.recording.schema import POSE_TYPE
from cfem_ros.study.summarize import summarize_file
from mcap.reader import make_reader
import pytest
from recordings import read_mcap, read_rosbags, rewrite_zstd

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
SCENARIO = CONFIG / 'store_separation.yaml'


@pytest.fixture(scope='module')
def good(tmp_path_factory):
    """Record a complete recording of three chunks or more (about 2,000 messages)."""
    out = tmp_path_factory.mktemp('damaged') / 'good.mcap'
    assert cli.main(['run', str(SCENARIO), '-o', str(out), '--rate', '1000',
                     '--duration', '0.4']) == 0
    with open(out, 'rb') as stream:
        assert make_reader(stream).get_summary().statistics.chunk_count >= 3
    return out


@pytest.fixture(scope='module')
def zstd(good, tmp_path_factory):
    """Copy the messages into zstd-compressed chunks, as rosbag2 and Foxglove write them."""
    out = tmp_path_factory.mktemp('zstd') / 'zstd.mcap'
    rewrite_zstd(good, out)
    return out


def records(data: bytes):
    """Return (opcode, start, end) of the top-level records after the magic."""
    out, position = [], 8
    while position + 9 <= len(data) - 8:
        opcode, length = struct.unpack_from('<BQ', data, position)
        out.append((opcode, position, position + 9 + length))
        position += 9 + length
    return out


def chunk_spans(data: bytes):
    return [(start, end) for opcode, start, end in records(data) if opcode == 0x06]


def messages_of(path):
    """Return the (topic, log time, bytes) of every message, with the indexed reader."""
    with open(path, 'rb') as stream:
        return [(channel.topic, message.log_time, bytes(message.data))
                for _, channel, message in make_reader(stream).iter_messages()]


def one_error(capsys, path) -> str:
    err = capsys.readouterr().err
    assert err.startswith('ERROR: ') and err.count('\n') == 1, err
    assert str(path) in err
    assert 'Traceback' not in err
    return err


def reading_commands(path, good, tmp_path):
    """Return the commands that read a recording, with path in the place of a recording."""
    return {
        'info': ['info', str(path)],
        'plot': ['plot', str(path), '-o', str(tmp_path / 'figures')],
        'compare': ['compare', str(good), str(path)],
        'run --inputs': ['run', str(SCENARIO), '-o', str(tmp_path / 'replayed.mcap'),
                         '--inputs', str(path), '--overwrite'],
    }


def damaged_copies(data: bytes) -> dict:
    """Each shape of damage of the issue, on a copy of a complete recording."""
    spans = chunk_spans(data)
    (first_start, first_end), (second_start, _) = spans[0], spans[1]
    out = {
        'cut in the first chunk': data[:(first_start + first_end) // 2],
        'cut in the header': data[:12],
        'only the magic': data[:8],
        'magic flipped': bytes([data[0] ^ 0xFF]) + data[1:],
        'header length huge': data[:9] + struct.pack('<Q', 1 << 62) + data[17:],
    }

    def flipped(position, mask=0x55):
        copy = bytearray(data)
        copy[position] ^= mask
        return bytes(copy)

    out['chunk record byte'] = flipped((first_start + first_end) // 2)
    out['chunk length'] = flipped(first_start + 8, 0x7F)   # the high byte: petabytes
    out['chunk crc'] = flipped(first_start + 9 + 24)
    out['second chunk records length'] = flipped(second_start + 9 + 32 + 4)
    # schemas are written once, in the first chunk that uses them (and in the summary)
    schema = data.index(b'geometry_msgs/msg/PoseStamped')
    assert first_start < schema < first_end, 'a schema record outside the chunks'
    out['schema record in its chunk'] = flipped(schema + 3)
    summary_schema = data.rindex(b'geometry_msgs/msg/PoseStamped')
    out['schema name in the summary'] = (data[:summary_schema + 13] + b'!'
                                         + data[summary_schema + 14:])
    out['summary byte'] = flipped(len(data) - 200)
    out['footer'] = flipped(len(data) - 20, 0x7F)
    return out


def test_damaged_recordings_give_one_error_line_in_every_reader(good, tmp_path, capsys):
    data = good.read_bytes()
    for name, damaged in damaged_copies(data).items():
        path = tmp_path / f'{name.replace(" ", "_")}.mcap'
        path.write_bytes(damaged)
        for command, argv in reading_commands(path, good, tmp_path).items():
            status = cli.main(argv)
            if status == 0:   # the damage missed what this command reads
                capsys.readouterr()
                continue
            assert status == 2, (name, command)
            one_error(capsys, path)
    # a schema name that no longer parses (InvalidResourceName in the decoder), in a
    # file whose writer gave no summary CRC (zero: the MCAP specification's "none")
    damaged = damaged_copies(data)['schema name in the summary']
    path = tmp_path / 'schema_name_without_crc.mcap'
    path.write_bytes(damaged[:-12] + bytes(4) + damaged[-8:])
    assert cli.main(['plot', str(path), '-o', str(tmp_path / 'figures')]) == 2
    assert 'does not parse' in one_error(capsys, path)
    assert cli.main(['info', str(path)]) == 0   # info reads no message: it can tell
    capsys.readouterr()


@pytest.fixture(scope='module')
def metrics(tmp_path_factory):
    from cfem_ros.study import load_sweep
    path = tmp_path_factory.mktemp('metrics') / 'metrics.yaml'
    path.write_text(f'scenario: {SCENARIO}\nmetrics:\n  at:\n    - {{time: 0.1, body: store}}\n')
    return load_sweep(str(path), runs=1).metrics


def test_summarize_gives_a_failed_row_for_a_damaged_recording(good, metrics, tmp_path):
    data = good.read_bytes()
    for name, damaged in damaged_copies(data).items():
        path = tmp_path / f'{name.replace(" ", "_")}.mcap'
        path.write_bytes(damaged)
        row = summarize_file(str(path), metrics)
        assert row['status'] in ('ok', 'failed'), name
        if row['status'] == 'failed':
            assert row['message'].startswith(f'{path}: ') and '\n' not in row['message']
    assert summarize_file(str(good), metrics)['status'] == 'ok'


def test_a_zero_norm_quaternion_is_named_not_a_traceback(good, tmp_path, capsys):
    path = tmp_path / 'zero.mcap'
    pose = {'header': {'stamp': {'sec': 0, 'nanosec': 0}, 'frame_id': 'world'},
            'pose': {'position': {'x': 0.0, 'y': 0.0, 'z': 0.0},
                     'orientation': {'x': 0.0, 'y': 0.0, 'z': 0.0, 'w': 0.0}}}
    with Recorder(str(path)) as recorder:
        for k in range(3):
            pose['header']['stamp']['nanosec'] = k * 10_000_000
            recorder.write('/cfem/bodies/store/pose', POSE_TYPE, pose, k * 10_000_000)
    assert cli.main(['compare', str(good), str(path)]) == 2
    err = one_error(capsys, path)
    assert 'quaternion [0, 0, 0, 0]' in err and 'not a rotation' in err


def test_a_corrupted_zstd_chunk_is_an_error_for_readers_and_skipped_by_recover(
        zstd, tmp_path, capsys):
    data = zstd.read_bytes()
    spans = chunk_spans(data)
    assert len(spans) >= 3
    start, end = spans[1]
    damaged = bytearray(data)
    damaged[(start + end) // 2] ^= 0xFF
    path = tmp_path / 'zstd_damaged.mcap'
    path.write_bytes(bytes(damaged))
    for argv in (['compare', str(zstd), str(path)],
                 ['run', str(SCENARIO), '-o', str(tmp_path / 'r.mcap'), '--inputs', str(path)]):
        assert cli.main(argv) == 2
        one_error(capsys, path)
    fixed = tmp_path / 'zstd_fixed.mcap'
    assert cli.main(['recover', str(path), '-o', str(fixed)]) == 0
    out = capsys.readouterr().out
    assert 'damaged chunk' in out and f'byte {start}' in out
    kept, original = messages_of(fixed), messages_of(zstd)
    assert set(kept) < set(original)
    # every chunk but the damaged one: the chunks after it are kept too
    assert len(kept) > len(original) // 2
    assert max(t for _, t, _ in kept) == max(t for _, t, _ in original)


def test_recover_keeps_only_intact_chunks_and_goes_on(good, tmp_path, capsys):
    data = good.read_bytes()
    original = messages_of(good)
    for name, damaged in damaged_copies(data).items():
        path = tmp_path / f'{name.replace(" ", "_")}.mcap'
        path.write_bytes(damaged)
        fixed = tmp_path / f'{name.replace(" ", "_")}_fixed.mcap'
        status = cli.main(['recover', str(path), '-o', str(fixed)])
        if status == 2:
            one_error(capsys, path)
            assert not fixed.exists()
            continue
        assert status == 0, name
        out = capsys.readouterr().out
        kept = messages_of(fixed)      # the indexed reader, CRCs checked
        assert set(kept) <= set(original), name    # nothing made up, bit for bit
        _, summary, decoded = read_mcap(fixed)     # every message decodes
        assert summary.statistics.message_count == len(decoded) == len(kept)
        if name == 'chunk crc':   # an independent reader too (once: it is slow)
            assert len(read_rosbags(fixed)[0]) == len(kept)
        assert f'{len(kept)} messages recovered' in out, out
        if name in ('chunk record byte', 'chunk crc', 'second chunk records length',
                    'schema record in its chunk'):
            assert 'damaged chunk' in out and 'damage at byte' in out, out
            assert len(kept) > len(original) // 3, name   # the later chunks are kept
        if name in ('summary byte', 'footer', 'schema name in the summary', 'magic flipped'):
            assert kept == original, name   # the chunks' own schemas and channels


def test_fifos_are_refused_by_every_reading_command(good, metrics, tmp_path, capsys):
    import faulthandler
    import os
    import sys
    fifo = tmp_path / 'pipe.mcap'
    os.mkfifo(fifo)
    # a blocked open would hang the suite: end it instead
    faulthandler.dump_traceback_later(60, exit=True, file=sys.__stderr__)
    try:
        commands = reading_commands(fifo, good, tmp_path)
        commands['recover'] = ['recover', str(fifo), '-o', str(tmp_path / 'fixed.mcap')]
        commands['play'] = ['play', str(fifo)]
        for command, argv in commands.items():
            assert cli.main(argv) == 2, command
            assert 'named pipe (FIFO)' in one_error(capsys, fifo), command
        row = summarize_file(str(fifo), metrics)
        assert row['status'] == 'failed' and 'named pipe (FIFO)' in row['message']
    finally:
        faulthandler.cancel_dump_traceback_later()


def test_recover_of_a_complete_file_is_the_same_messages(good, tmp_path):
    fixed = tmp_path / 'copy.mcap'
    report = recover(str(good), str(fixed))
    assert report.complete and not report.skipped and not report.damage
    assert messages_of(fixed) == messages_of(good)
