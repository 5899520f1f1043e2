# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A recording's poses read through its message index (``recording.poses``) against the whole read.

The figures of a sweep folder draw from ``read_poses``: on a recording of
``cfem-sim run`` (and on its copy in zstd chunks) it gives ``open_run``'s
arrays, events and metadata to the bit without reading the file whole; a
file it does not read (no chunk index) is read whole, and a damaged one
gives the whole read's error. The envelope's histories, read and turned
continuous many runs at once, are each run's own from the whole read.
"""

import pathlib

from cfem_ros import cli
from cfem_ros.recording import analysis, poses
from cfem_ros.recording.errors import RecordingError
from cfem_ros.recording.relative import relative_track, release_time
from cfem_ros.separation import envelopes
from mcap.reader import make_reader
from mcap.writer import Writer
import numpy as np
import pytest
from recordings import rewrite_zstd
from scipy.spatial.transform import Rotation

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'


@pytest.fixture(scope='module')
def near_pylon(tmp_path_factory):
    """Two runs of the near-pylon release (0.4 s and 0.3 s), recorded by cfem-sim run."""
    folder = tmp_path_factory.mktemp('poses')
    out = []
    for duration in ('0.4', '0.3'):
        path = folder / f'near_pylon_{duration}.mcap'
        assert cli.main(['run', str(CONFIG / 'store_release_near_pylon.yaml'), '-o', str(path),
                         '--duration', duration]) == 0
        out.append(str(path))
    return out


def _same(found, run):
    assert list(found.bodies) == list(run.bodies) == ['pylon', 'wing', 'store']
    for name, track in found.bodies.items():
        whole = run.bodies[name]
        for field in ('time', 'stamp_ns', 'position', 'quaternion'):
            mine, theirs = getattr(track, field), getattr(whole, field)
            assert mine.dtype == theirs.dtype and np.array_equal(mine, theirs), (name, field)
    assert found.events == run.events and found.metadata == run.metadata
    assert found.releases() == run.releases() and found.releases()[0][1] == 'hooks'


def _not_whole(path):
    raise AssertionError(f'{path} was read whole')


def test_the_indexed_poses_are_the_whole_read_to_the_bit(near_pylon, tmp_path, monkeypatch):
    runs = [analysis.open_run(path) for path in near_pylon]
    zstd = str(tmp_path / 'zstd.mcap')
    rewrite_zstd(near_pylon[0], zstd, chunk_size=8 * 1024)
    with open(zstd, 'rb') as stream:
        chunks = make_reader(stream).get_summary().chunk_indexes
    assert len(chunks) > 3 and {c.compression for c in chunks} == {'zstd'}
    monkeypatch.setattr(poses, '_from_run', _not_whole)
    for path, run in zip(near_pylon + [zstd], runs + runs[:1]):
        _same(poses.read_poses(path), run)
    assert len(runs[0].bodies['store'].time) == 41 and len(runs[1].bodies['store'].time) == 31


def test_a_file_without_chunk_indexes_is_read_whole_and_a_damaged_one_refused(near_pylon,
                                                                              tmp_path):
    plain = str(tmp_path / 'unchunked.mcap')
    with open(near_pylon[0], 'rb') as stream, open(plain, 'wb') as out:
        reader = make_reader(stream)
        writer = Writer(out, use_chunking=False)
        writer.start('ros2', 'test')
        summary = reader.get_summary()
        schemas = {sid: writer.register_schema(s.name, s.encoding, s.data)
                   for sid, s in summary.schemas.items()}
        channels = {cid: writer.register_channel(c.topic, c.message_encoding,
                                                 schemas[c.schema_id], dict(c.metadata))
                    for cid, c in summary.channels.items()}
        for record in reader.iter_metadata():
            writer.add_metadata(record.name, dict(record.metadata))
        for _, channel, message in reader.iter_messages(log_time_order=False):
            writer.add_message(channels[channel.id], message.log_time, message.data,
                               message.publish_time, message.sequence)
        writer.finish()
    _same(poses.read_poses(plain), analysis.open_run(plain))
    data = bytearray(pathlib.Path(near_pylon[0]).read_bytes())
    data[len(data) // 3] ^= 0x40   # inside a chunk: the data section's CRC no longer holds
    damaged = tmp_path / 'damaged.mcap'
    damaged.write_bytes(bytes(data))
    with pytest.raises(RecordingError) as whole:
        analysis.open_run(str(damaged))
    with pytest.raises(RecordingError) as indexed:
        poses.read_poses(str(damaged))
    assert str(indexed.value) == str(whole.value) and 'damaged recording' in str(whole.value)


def test_the_envelope_s_histories_are_each_run_s_own_from_the_whole_read(near_pylon):
    found = envelopes.histories(dict(enumerate(near_pylon * 2)), 'store', 'pylon')
    assert list(found) == [0, 1, 2, 3]
    for k, path in enumerate(near_pylon * 2):
        run = analysis.open_run(path)
        track = relative_track(run, 'store', 'pylon')
        since = track.time - release_time(run)
        values = np.column_stack([track.position, analysis.euler_continuous(track.euler_deg)])
        assert np.array_equal(found[k][0], since) and np.array_equal(found[k][1], values)


def test_euler_angles_of_many_runs_turn_as_each_run_alone():
    """Tumbling bodies through pitch +-90 deg, some samples NaN: a stack is each run alone."""
    rng = np.random.default_rng(7)
    turns = np.cumsum(rng.normal(0.0, 0.3, (40, 120, 3)), axis=1)
    euler = Rotation.from_rotvec(turns.reshape(-1, 3)).as_euler('ZYX', degrees=True)
    euler = euler[:, ::-1].reshape(40, 120, 3)
    euler[::3, rng.integers(1, 120, 4)] = np.nan
    stacked = analysis.euler_continuous(euler)
    alone = np.array([analysis.euler_continuous(one) for one in euler])
    assert np.array_equal(stacked, alone, equal_nan=True)
    assert not np.array_equal(stacked, euler, equal_nan=True)   # some were turned
    kept = np.isfinite(stacked).all(axis=-1)   # (a NaN sample makes the rest of its run NaN)
    turned, given = (Rotation.from_euler('ZYX', a[kept][:, ::-1], degrees=True)
                     for a in (stacked, euler))
    assert kept.sum() > 1000 and np.allclose((turned.inv() * given).magnitude(), 0, atol=1e-9)
