# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A recording's body poses and events alone, read through its message index.

The figures of a sweep folder draw every recorded run's separation from
two bodies' poses and the first release (``separation.envelopes``,
``study_plots``). ``read_poses(path)`` reads only those: for each chunk,
the message index of each ``bodies/<body>/pose`` and ``events`` channel
gives where their messages lie, and each is decoded from its CDR bytes
(``PoseStamped``: stamp, frame and the seven numbers; ``String``: the JSON
event), no other record of the chunk parsed. The file is checked as
``open_run`` checks it (``reader.open_mcap``): the summary's, the data
section's and each chunk's CRC.

The answer is the one ``open_run`` gives, to the bit: the same stamps,
positions, quaternions, times from the start, events and metadata (a
test compares them). Where a recording is not the plain case this reader
decodes (no chunk or message index, message counts that disagree with the
statistics, another CDR encapsulation, a pose in another body's frame, no
``start_stamp_ns``, an event that is not a JSON object, a quaternion that
is no rotation, several namespaces), it is read whole by ``open_run``
instead, which also gives its errors.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import functools
import json
import os
import struct

from cfem_ros.recording import schema
from cfem_ros.recording.chunks import MESSAGE_HEADER
from cfem_ros.recording.errors import RecordingError
from cfem_ros.recording.reader import check_data_crc, check_mcap, open_recording, READ_ERRORS
from cfem_ros.recording.tracks import Run
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.reader import make_reader
from mcap.records import Chunk
from mcap.stream_reader import get_chunk_data_stream
import numpy as np

__all__ = ['PoseTrack', 'Poses', 'read_poses', 'shared_poses']

_INDEX = struct.Struct('<BQHI')    # opcode, length, channel, bytes of (time, offset) pairs
_HEADER = struct.Struct('<iII')    # after the CDR header: stamp sec, nanosec, frame_id length
_POSE = struct.Struct('<7d')       # position x y z, orientation x y z w
_CDR_LE = b'\x00\x01'             # the CDR header's first two bytes: little-endian plain CDR


@dataclass
class PoseTrack:
    """
    A body's recorded poses, in stamp order (the fields of a ``BodyTrack`` they give).

    Attributes
    ----------
    name : str
    time : ndarray (n,)
        s from the run's start.
    stamp_ns : ndarray (n,) of int64
    position : ndarray (n, 3)
        CG in the world frame, m.
    quaternion : ndarray (n, 4)
        Body to world, x y z w.

    """

    name: str
    time: np.ndarray
    stamp_ns: np.ndarray
    position: np.ndarray
    quaternion: np.ndarray


@dataclass
class Poses:
    """
    A recording's body poses and events: what ``relative_track`` and ``release_time`` read.

    Attributes
    ----------
    path : str
    bodies : dict of str to PoseTrack
        In the order the recording first names them (as ``Run.bodies``).
    events : list of dict
        The decoded JSON events, in log time order.
    metadata : dict of str to str
        The ``cfem_ros`` metadata record.

    """

    path: str
    bodies: dict
    events: list
    metadata: dict = field(default_factory=dict)

    #: Release events as (time, joint, cause), in time order: ``Run.releases`` itself.
    releases = Run.releases


class _Whole(Exception):
    """The recording is not the plain case: read it whole (``open_run``)."""


def read_poses(path: str) -> Poses:
    """
    Return a recording's body poses and events (``Poses``), equal to ``open_run``'s.

    Raises
    ------
    RecordingError
        As ``open_run`` does, for the same files.

    """
    check_mcap(path)
    with open_recording(path) as stream:
        try:
            check_data_crc(stream, path)
            stream.seek(0)
            return _indexed(path, make_reader(stream, validate_crcs=True), stream)
        except (_Whole, RecordingError) + READ_ERRORS:
            pass   # not the plain case, or damaged: open_run reads it, or says what is wrong
    return _from_run(path)


def shared_poses(path: str) -> Poses:
    """
    Return ``read_poses(path)``, read once in this process while the file is unchanged.

    For the figures of a sweep folder, which read the same recordings in
    turn (``plot`` and ``report`` draw two envelopes): each is given the
    same ``Poses``, so they read it and never change it.
    """
    info = os.stat(path)
    return _shared_poses(os.path.abspath(path), info.st_size, info.st_mtime_ns)


@functools.lru_cache(maxsize=2048)   # 72 bytes a sample and body: 45 MB for 2,048 runs of 3 x 101
def _shared_poses(path: str, size: int, mtime_ns: int) -> Poses:
    return read_poses(path)


def _from_run(path: str) -> Poses:
    from cfem_ros.recording.analysis import open_run
    run = open_run(path)
    bodies = {name: PoseTrack(name, track.time, track.stamp_ns, track.position,
                              track.quaternion) for name, track in run.bodies.items()}
    return Poses(path, bodies, run.events, run.metadata)


def _wanted(summary) -> tuple:
    """Return ({channel id: body name, or None for the events}, namespace) of a summary."""
    poses, events = {}, {}
    for channel in summary.channels.values():
        kind = summary.schemas.get(channel.schema_id)
        pose = schema.POSE.pattern.match(channel.topic)
        if pose:
            if kind is None or kind.name != schema.POSE_TYPE:
                raise _Whole()
            poses[channel.id] = (pose['ns'], pose['body'])
        event = schema.EVENTS.pattern.match(channel.topic)
        if event:
            events[channel.id] = event['ns']
    spaces = {ns for ns, _ in poses.values()}
    if len(spaces) != 1:
        raise _Whole()
    ns = next(iter(spaces))
    wanted = {cid: body for cid, (space, body) in poses.items()}
    for cid, space in events.items():
        if space == ns:
            if summary.schemas[summary.channels[cid].schema_id].name != schema.STRING_TYPE:
                raise _Whole()
            wanted[cid] = None
    return wanted, ns


def _indexed(path: str, reader, stream) -> Poses:
    """Return the Poses of a plain recording from its wanted channels' messages alone."""
    summary = reader.get_summary()
    if summary is None or not summary.chunk_indexes or summary.statistics is None:
        raise _Whole()
    wanted, _ = _wanted(summary)
    metadata = {}
    for record in reader.iter_metadata():
        if record.name == 'cfem_ros':
            metadata = dict(record.metadata)
    if 'start_stamp_ns' not in metadata:
        raise _Whole()
    found = []   # (log time, chunk offset, offset in the chunk, channel, payload)
    for chunk_index in summary.chunk_indexes:
        if not chunk_index.message_index_offsets:
            raise _Whole()   # a chunk without a message index
        mine = [(cid, at) for cid, at in chunk_index.message_index_offsets.items()
                if cid in wanted]
        if not mine:
            continue
        stream.seek(chunk_index.chunk_start_offset + 1 + 8)
        chunk = Chunk.read(ReadDataStream(stream))
        data_stream, size = get_chunk_data_stream(chunk, validate_crc=True)
        data = data_stream.read(size)
        for cid, at in mine:
            stream.seek(at)
            opcode, _, channel, length = _INDEX.unpack(stream.read(_INDEX.size))
            if opcode != Opcode.MESSAGE_INDEX or channel != cid:
                raise _Whole()
            pairs = np.frombuffer(stream.read(length), dtype='<u8').reshape(-1, 2)
            for log_time, offset in pairs.tolist():
                opcode, record, channel, _, logged, _ = MESSAGE_HEADER.unpack_from(data, offset)
                end = offset + 1 + 8 + record
                if opcode != Opcode.MESSAGE or channel != cid or logged != log_time \
                        or end > len(data):
                    raise _Whole()
                found.append((log_time, chunk_index.chunk_start_offset, offset, cid,
                              data[offset + MESSAGE_HEADER.size:end]))
    counts = {}
    for *_, cid, _ in found:
        counts[cid] = counts.get(cid, 0) + 1
    expected = summary.statistics.channel_message_counts
    if any(counts.get(cid, 0) != expected.get(cid, 0) for cid in wanted):
        raise _Whole()
    found.sort(key=lambda item: item[:3])   # log time order, ties in file order
    return _decoded(path, wanted, found, metadata)


def _decoded(path: str, wanted: dict, found: list, metadata: dict) -> Poses:
    """Return the Poses of the messages found (log time order), as ``open_run`` reads them."""
    rows, frames, events = {}, {}, []
    for *_, cid, payload in found:
        if payload[:2] != _CDR_LE or len(payload) < 4 + _HEADER.size:
            raise _Whole()
        body = wanted[cid]
        if body is None:   # an event: std_msgs/String
            (length,) = struct.unpack_from('<I', payload, 4)
            if 8 + length > len(payload):
                raise _Whole()
            text = payload[8:8 + length - 1].decode('utf-8') if length > 1 else ''
            try:
                event = json.loads(text)
            except ValueError as err:
                raise _Whole() from err
            if not isinstance(event, dict):
                raise _Whole()
            events.append(event)
            continue
        sec, nanosec, length = _HEADER.unpack_from(payload, 4)
        at = 4 + ((12 + length + 7) & ~7)   # the pose, aligned to 8 after the CDR header
        if len(payload) < at + _POSE.size:
            raise _Whole()
        frames.setdefault(body, set()).add(
            payload[16:16 + length - 1].decode('utf-8') if length > 1 else '')
        rows.setdefault(body, []).append((sec * 1_000_000_000 + nanosec,
                                          _POSE.unpack_from(payload, at)))
    for body, names in frames.items():   # a pose in another body's frame: open_run's case
        if len(names) > 1 or (next(iter(names)) != body and next(iter(names)) in frames):
            raise _Whole()
    start_ns = int(metadata['start_stamp_ns'])
    bodies = {}
    for name, found_rows in rows.items():
        found_rows.sort(key=lambda r: r[0])
        stamps = np.array([r[0] for r in found_rows], dtype=np.int64)
        values = np.array([r[1] for r in found_rows], dtype=float).reshape(len(found_rows), 7)
        norms = np.linalg.norm(values[:, 3:7], axis=1)
        if not (np.isfinite(norms) & (norms > 1e-6)).all():
            raise _Whole()   # open_run refuses it, with its message
        bodies[name] = PoseTrack(name, (stamps - start_ns) / 1e9, stamps, values[:, 0:3],
                                 values[:, 3:7])
    return Poses(path, bodies, events, metadata)
