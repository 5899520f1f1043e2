# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Recordings every reader accepts, runs that destroy nothing, info and recover.

The stream order of schema, channel and message records (what a stream
reader or a recovery tool meets), the chunk sizes the README states, the
partial file moved onto OUT only when complete, the refused outputs and
run sizes, ``cfem-sim info`` from the summary alone, and ``cfem-sim
recover`` on recordings cut at many offsets, checked against the offsets
the indexes give for every message.
"""

import os
import pathlib
import re
import struct
import subprocess
import sys
import warnings

from cfem_ros import cli, load_scenario, Simulator
from cfem_ros.recording import offline
from cfem_ros.recording.chunks import CHUNK_SIZE
from cfem_ros.recording.container import partial_path
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.recorder import StateRecorder
from cfem_ros.recording.recover import recover
from mcap.reader import make_reader
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import breakup_chunk, StreamReader
import pytest
from recordings import read_mcap, read_rosbags

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
#: A Chunk record up to its records: opcode, length, start, end, size, crc,
#: compression '' (its length), records length.
CHUNK_HEADER = 9 + 8 + 8 + 8 + 4 + 4 + 8


@pytest.fixture(scope='module')
def store(tmp_path_factory):
    out = tmp_path_factory.mktemp('robust') / 'store.mcap'
    assert cli.main(['run', str(CONFIG / 'store_separation.yaml'), '-o', str(out),
                     '--rate', '1000']) == 0
    return out


def test_channels_and_schemas_precede_their_messages_in_every_chunk(store):
    """Each chunk, read alone, holds what its messages need, the first time they need it."""
    seen_schemas, seen_channels, chunks = set(), set(), []
    with open(store, 'rb') as stream:
        for record in StreamReader(stream, emit_chunks=True, validate_crcs=True).records:
            if not isinstance(record, Chunk):
                continue
            chunks.append(record)
            for inner in breakup_chunk(record, validate_crc=True):
                if isinstance(inner, Schema):
                    seen_schemas.add(inner.id)
                elif isinstance(inner, Channel):
                    assert inner.schema_id in seen_schemas, 'schema before its channel'
                    seen_channels.add(inner.id)
                elif isinstance(inner, Message):
                    assert inner.channel_id in seen_channels, 'channel before its message'
    # every channel is in a chunk exactly once (the first using it), and in the summary
    _, summary, messages = read_mcap(store)
    assert seen_channels == set(summary.channels)
    # chunks as the README says: uncompressed, closed once they hold 64 KiB, under 128 KiB
    assert len(chunks) == summary.statistics.chunk_count > 10
    sizes = [chunk.uncompressed_size for chunk in chunks]
    assert {chunk.compression for chunk in chunks} == {''}
    assert CHUNK_SIZE <= min(sizes[:-1]) and max(sizes) < 2 * CHUNK_SIZE
    # and both readers still read every message
    theirs, _ = read_rosbags(store)
    assert len(theirs) == len(messages) == summary.statistics.message_count


def test_an_existing_output_is_untouched_until_the_new_one_is_complete(tmp_path):
    out = tmp_path / 'run.mcap'
    out.write_bytes(b'the old recording')
    sim = Simulator(load_scenario(str(CONFIG / 'double_pendulum.yaml')))
    recorder = Recorder(str(out), overwrite=True, atomic=True)
    partial = pathlib.Path(partial_path(str(out)))
    assert partial.name == f'.run.mcap.partial-{os.getpid()}'
    offline.run(sim, StateRecorder(recorder, sim), rate_hz=1000, duration=2.0)
    assert out.read_bytes() == b'the old recording' and partial.stat().st_size > CHUNK_SIZE
    recorder.finish()
    assert not partial.exists()
    _, summary, messages = read_mcap(out)
    assert summary.statistics.message_count == len(messages)
    assert sum(topic == '/cfem/bodies/B/pose' for topic, _, _, _ in messages) == 2001


def test_the_output_may_not_be_the_scenario_or_the_inputs(store, tmp_path, capsys):
    scenario = tmp_path / 'scenario.yaml'
    text = (CONFIG / 'double_pendulum.yaml').read_text()
    scenario.write_text(text)
    assert cli.main(['run', str(scenario), '-o', str(scenario), '--overwrite']) == 2
    assert 'is the scenario file itself' in capsys.readouterr().err
    assert scenario.read_text() == text
    log = tmp_path / 'log.mcap'
    log.write_bytes(store.read_bytes())
    assert cli.main(['run', str(scenario), '-o', str(tmp_path / '.' / 'log.mcap'),
                     '--inputs', str(log), '--overwrite']) == 2
    assert 'is the --inputs log itself' in capsys.readouterr().err
    assert log.read_bytes() == store.read_bytes()


def test_rate_and_size_bounds(tmp_path, capsys):
    from cfem_ros.ros.node import PARAMETERS
    bounds = PARAMETERS['rate_hz'][1].floating_point_range[0]
    assert offline.RATE_RANGE == (bounds.from_value, bounds.to_value)
    scenario, out = str(CONFIG / 'double_pendulum.yaml'), tmp_path / 'x.mcap'
    for rate in ('1e7', '0.001', 'nan'):
        assert cli.main(['run', scenario, '-o', str(out), '--rate', rate]) == 2
        assert '--rate: is' in capsys.readouterr().err
    # 30 s at 1e5 Hz: 3,000,001 samples of 8 messages, about 2.3 GB
    args = ['run', scenario, '-o', str(out), '--rate', '1e5', '--duration', '30']
    assert cli.main(args + ['--max-samples', '3e6']) == 2
    assert '3e+06 samples, more than --max-samples 3e+06' in capsys.readouterr().err
    assert cli.main(args + ['--max-gb', '2']) == 2
    err = capsys.readouterr().err
    assert 'GB of recording, more than --max-gb 2' in err and err.count('\n') == 1
    assert not out.exists() and not list(tmp_path.iterdir())
    model = load_scenario(scenario)
    assert offline.expected_samples(1000, 5.0) == 5001
    # the estimate is within 5 % of a real recording's size
    real = tmp_path / 'real.mcap'
    assert cli.main(['run', scenario, '-o', str(real), '--rate', '1000']) == 0
    estimate = offline.estimate_bytes(model, offline.expected_samples(1000, model.duration))
    assert abs(estimate / real.stat().st_size - 1) < 0.05


def test_info_reads_only_the_summary(store, tmp_path, capsys):
    """Info prints the summary's counts, and still does with every message chunk wiped."""
    _, summary, messages = read_mcap(store)
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        assert cli.main(['info', str(store)]) == 0
    out = capsys.readouterr().out
    assert f'{len(messages)} messages in {summary.statistics.chunk_count} chunks' in out
    assert re.search(r'/cfem/bodies/store/pose +1501  geometry_msgs/msg/PoseStamped\n', out)
    assert 'release pivot at t = 0.28' in out and '(angle)' in out
    assert 'metadata cfem_ros:' in out and 'rate_hz 1000.0' in out
    # wipe the records of every chunk without an event: a full read would fail
    data = bytearray(store.read_bytes())
    with open(store, 'rb') as stream:
        reader = make_reader(stream)
        events = [c.id for c in summary.channels.values() if c.topic.endswith('/events')]
        wiped = 0
        for index in reader.get_summary().chunk_indexes:
            if set(index.message_index_offsets) & set(events):
                continue
            start = index.chunk_start_offset + CHUNK_HEADER
            data[start:index.chunk_start_offset + index.chunk_length] = bytes(
                index.chunk_length - CHUNK_HEADER)
            wiped += 1
    assert wiped >= 5
    broken = tmp_path / 'wiped.mcap'
    broken.write_bytes(bytes(data))
    assert cli.main(['info', str(broken)]) == 0
    assert capsys.readouterr().out.replace(str(broken), str(store)) == out


def _message_ends(path):
    """Return the end offset of every message record, in file order, from the indexes."""
    ends = []
    with open(path, 'rb') as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        for index in summary.chunk_indexes:
            stream.seek(index.chunk_start_offset + CHUNK_HEADER)
            records = stream.read(index.chunk_length - CHUNK_HEADER)
            position = 0
            while position < len(records):
                opcode, length = struct.unpack_from('<BQ', records, position)
                position += 9 + length
                if opcode == 0x05:
                    ends.append(index.chunk_start_offset + CHUNK_HEADER + position)
    return ends, summary.statistics.message_count


def test_recover_keeps_every_complete_message_of_a_cut_file(store, tmp_path, capsys):
    ends, total = _message_ends(store)
    assert len(ends) == total
    _, _, original = read_mcap(store)
    data = store.read_bytes()
    size = len(data)
    cuts = [size - 1, size // 2, size // 3 + 17, ends[100], ends[100] - 1,
            ends[0] + 5, 300]
    for i, cut in enumerate(cuts):
        broken, fixed = tmp_path / f'cut{i}.mcap', tmp_path / f'fixed{i}.mcap'
        broken.write_bytes(data[:cut])
        for command in (['info', str(broken)], ['plot', str(broken), '-o', str(tmp_path)]):
            assert cli.main(command) == 2
            assert f'cfem-sim recover {broken} -o FIXED.mcap' in capsys.readouterr().err
        assert cli.main(['recover', str(broken), '-o', str(fixed)]) == 0
        expected = sum(end <= cut for end in ends)
        out = capsys.readouterr().out
        assert f'{fixed}: {expected} messages recovered' in out, (cut, out)
        assert 'cut at byte' in out and f'of {cut} ' in out
        _, summary, messages = read_mcap(fixed)   # indexed, CRCs checked
        assert summary.statistics.message_count == len(messages) == expected
        assert [(t, lt) for t, lt, _, _ in messages] == [
            (t, lt) for t, lt, _, _ in original[:expected]]
        theirs, _ = read_rosbags(fixed)
        assert len(theirs) == expected
        if cut == size // 2:   # the load arrows of the run so far, written as it went
            arrows = [lt for t, lt, _, _ in messages if t == '/cfem/load_markers']
            poses = [lt for t, lt, _, _ in messages if t == '/cfem/bodies/store/pose']
            assert arrows and poses[-1] - arrows[-1] <= 10 ** 6   # within a sample (1 ms)
    # a complete file is copied whole
    fixed = tmp_path / 'whole.mcap'
    report = recover(str(store), str(fixed))
    assert report.complete and report.messages == total
    assert cli.main(['recover', str(store), '-o', str(fixed)]) == 2
    assert 'already exists' in capsys.readouterr().err


def test_a_closed_stdout_ends_quietly(store):
    """``cfem-sim info RUN.mcap | head -0``: no BrokenPipeError traceback."""
    read, write = os.pipe()
    os.close(read)   # the reader has gone before anything is written
    try:
        done = subprocess.run([str(pathlib.Path(sys.executable).with_name('cfem-sim')), 'info',
                               str(store)], stdout=write, stderr=subprocess.PIPE, text=True,
                              timeout=120)
    finally:
        os.close(write)
    assert done.stderr == '' and done.returncode == 141, done
