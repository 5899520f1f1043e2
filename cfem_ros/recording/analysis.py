# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Recorded runs as numpy arrays, without ROS.

``open_run(path)`` reads a recording of the SPEC section 3 topics (from
``cfem-sim run``, from the node, or from any other program that writes the
same topics) and returns a ``Run``: per body, time, position, quaternion,
Euler angles, body rates and velocity; per joint, time, force and moment;
per applied load source, time, force and moment about the CG; and the
events. CDR is decoded by mcap_ros2 from the schemas in the file, so no ROS
installation is needed.

Times are seconds from the run's start: the ``cfem_ros`` metadata's
``start_stamp_ns`` if present, else the first pose's stamp.
"""

from __future__ import annotations

import functools
import json
import os
from typing import Optional

from cfem_ros.core import rotations
from cfem_ros.core.engine.events import Event
from cfem_ros.recording import schema
from cfem_ros.recording.comparison import attitude_difference_deg, compare_runs, Difference
from cfem_ros.recording.errors import RecordingError
from cfem_ros.recording.reader import check_mcap, decoded_messages, open_mcap, reading
from cfem_ros.recording.tracks import (BodyTrack, euler_continuous, JointTrack, RelativeTrack,
                                       Run)
import numpy as np
from scipy.spatial.transform import Rotation, Slerp

__all__ = ['BodyTrack', 'Difference', 'JointTrack', 'Run', 'attitude_difference_deg',
           'check_mcap', 'compare_runs', 'euler_continuous', 'open_run']

#: The topics a ``Run`` is read from, with the kind of ``_read_messages``'s rows they make.
#: The loads in world axes (SPEC sections 3 and 5) are what a ``Run`` holds; recordings
#: made before the ``_world`` topics existed had the world axes on the others (``*_in``).
READ = ((schema.RELATIVE_POSE, 'relative_pose'), (schema.RELATIVE_TWIST, 'relative_twist'),
        (schema.POSE, 'pose'), (schema.TWIST, 'twist'),
        (schema.JOINT_WRENCH_WORLD, 'joint'), (schema.APPLIED_WORLD, 'applied'),
        (schema.JOINT_WRENCH, 'joint_in'), (schema.APPLIED, 'applied_in'),
        (schema.EVENTS, 'events'))


def _choose_namespace(path, found: set, namespace: Optional[str]) -> str:
    if namespace is not None:
        namespace = namespace.rstrip('/')
        if namespace not in found:
            raise RecordingError(f'{path}: no bodies/<body>/pose topic under namespace '
                                 f'{namespace or "/"!r} (found: {sorted(found)})')
        return namespace
    if not found:
        raise RecordingError(f'{path}: holds no <namespace>/bodies/<body>/pose topic; expected '
                             'a recording of the cfem_ros topics (SPEC section 3)')
    if len(found) > 1:
        raise RecordingError(f'{path}: several namespaces {sorted(found)}; choose one')
    return next(iter(found))


def _vectors(rows, n):
    return np.array(rows, dtype=float).reshape(n, 3)


def open_run(path: str, namespace: Optional[str] = None,
             topic_map: Optional[dict] = None, frames=()) -> Run:
    """
    Read a recording into arrays.

    Parameters
    ----------
    path : str
        An MCAP recording of the SPEC section 3 topics.
    namespace : str, optional
        The topics' prefix; needed only if the file holds several.
    topic_map : dict, optional
        Topic in the file -> the topic it is read as (e.g. a flight log's
        '/flight/store/pose' read as '/cfem/bodies/store/pose').
    frames : iterable of str, optional
        Names of bodies (another run's) a pose's ``frame_id`` may name. A
        ``bodies/<b>/pose`` whose ``frame_id`` is another body of this run,
        or one of these, is that body's pose relative to it (SPEC 15: a
        pose in ``aircraft`` is never read as a world pose): composed with
        that body's world pose when this run has it (``bodies``, and kept
        in ``relative``), else kept in ``relative`` only.

    Raises
    ------
    RecordingError
        If the file is missing, not MCAP, truncated, undecodable, or has no
        ``bodies/<body>/pose`` topic.

    """
    with open_mcap(path) as reader:
        summary = reader.get_summary()
        if summary is None:
            raise RecordingError(f'{path}: MCAP file without a summary section; '
                                 'expected a finished recording')
        schemas = summary.schemas
        topics = {}
        renamed = dict(topic_map or {})
        for channel in summary.channels.values():
            channel = _renamed(channel, renamed)
            count = (summary.statistics.channel_message_counts.get(channel.id, 0)
                     if summary.statistics else 0)
            kind = schemas.get(channel.schema_id)
            topics[channel.topic] = (kind.name if kind else '?', count)
        spaces = {m['ns'] for t in topics for m in [schema.POSE.pattern.match(t)] if m}
        ns = _choose_namespace(path, spaces, namespace)
        metadata = {}
        for record in reader.iter_metadata():
            if record.name == 'cfem_ros':
                metadata = dict(record.metadata)
        # only the topics a Run reads are decoded: a recording's markers and transforms
        # (nested message arrays) cost most of the decoding, and nothing here uses them
        wanted = [c.topic for c in summary.channels.values()
                  if _topic_of(renamed.get(c.topic, c.topic), ns) is not None]
        raw = _read_messages(decoded_messages(reader, path, topics=wanted) if wanted else (),
                             ns, renamed)
    with reading(path):
        _poses_in_bodies(path, ns, raw, set(frames))
        return _assemble(path, ns, topics, metadata, raw)


def shared_run(path: str) -> Run:
    """
    Return ``open_run(path)``, read once in this process while the file is unchanged.

    For a study folder's figures, several of which read every recorded run
    (the envelopes, the worst run's snapshots): the same ``Run`` object is
    given to each, so its users read it and never change it. The file is
    read again when its size or modification time changes.
    """
    info = os.stat(path)
    return _shared_run(os.path.abspath(path), info.st_size, info.st_mtime_ns)


@functools.lru_cache(maxsize=64)   # a study's recorded runs are small: 100 to 1000 samples
def _shared_run(path: str, size: int, mtime_ns: int) -> Run:
    return open_run(path)


def _renamed(channel, renamed: dict):
    """Return the channel, under the topic the map gives it (a copy), if any."""
    if channel.topic not in renamed:
        return channel
    from dataclasses import replace as _replace
    return _replace(channel, topic=renamed[channel.topic])


def _read_messages(messages, ns: str, renamed: Optional[dict] = None) -> dict:
    raw = {'pose': {}, 'twist': {}, 'joint': {}, 'applied': {}, 'events': [],
           'relative_pose': {}, 'relative_twist': {}, 'reference': {},
           'joint_in': {}, 'applied_in': {}, 'world': set(),   # *_in: loads, frame_id
           'pose_frame': {}}
    kinds = {}   # topic -> _topic_of's answer: the same for each of its messages
    for channel, _, decoded in messages:
        topic = (renamed or {}).get(channel.topic, channel.topic)
        if topic not in kinds:
            kinds[topic] = _topic_of(topic, ns)
        found = kinds[topic]
        if found is None:
            continue
        kind, match = found
        if kind == 'events':
            try:
                event = json.loads(decoded.data)
            except (ValueError, TypeError):
                event = {'event': Event.UNPARSED, 'data': str(decoded.data)}
            raw['events'].append(event if isinstance(event, dict) else {'event': event})
            continue
        stamp = decoded.header.stamp
        when = stamp.sec * 1_000_000_000 + stamp.nanosec
        if kind.endswith('pose'):
            p, q = decoded.pose.position, decoded.pose.orientation
            values = (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
            if kind == 'pose':
                raw['world'].add(decoded.header.frame_id)
                raw['pose_frame'].setdefault(match['body'], set()).add(decoded.header.frame_id)
            else:
                raw['reference'][match['body']] = decoded.header.frame_id
        elif kind.endswith('twist'):
            a, b = decoded.twist.linear, decoded.twist.angular
            values = (a.x, a.y, a.z, b.x, b.y, b.z)
        else:   # a load
            f, m = decoded.wrench.force, decoded.wrench.torque
            row = (when, (f.x, f.y, f.z, m.x, m.y, m.z))
            if kind.endswith('_in'):
                row += (decoded.header.frame_id,)
            name = (match['joint'] if kind.startswith('joint')
                    else f"{match['body']}/{match['source']}")
            raw[kind].setdefault(name, []).append(row)
            continue
        raw[kind].setdefault(match['body'], []).append((when, values))
    return raw


def _poses_in_bodies(path: str, ns: str, raw: dict, frames: set):
    """
    Move the poses given in another body's frame out of the world poses (``open_run``).

    Each becomes that body's relative track (its twist, if any, dropped: a
    log's twist frame is not told); composed with the frame body's world
    pose when the run has it. A body whose poses name several frames is
    refused.
    """
    named = {}
    for body, found in raw['pose_frame'].items():
        if len(found) > 1:
            raise RecordingError(f'{path}: {ns}/bodies/{body}/pose has the frame_ids '
                                 f'{sorted(found)}; expected one frame per topic')
        frame = next(iter(found))
        if frame != body and (frame in frames or frame in raw['pose_frame']):
            named[body] = frame
    for body, frame in named.items():
        if frame in named:
            raise RecordingError(f'{path}: {ns}/bodies/{body}/pose is in {frame!r}, whose own '
                                 f'pose is in {named[frame]!r}; expected poses in the world '
                                 'frame or in one body of it')
        rows = raw['pose'].pop(body)
        raw['twist'].pop(body, None)
        raw['relative_pose'].setdefault(body, rows)
        raw['reference'].setdefault(body, frame)
        composed = _composed(rows, raw['pose'].get(frame) or [])
        if composed:
            raw['pose'][body] = composed
    raw['world'] -= set(named.values())


def _composed(rows: list, carrier: list) -> list:
    """
    Return (stamp, pose) rows of poses relative to a carrier composed with its poses.

    Within the carrier's span only; none if the carrier has no pose or one
    that is no rotation (its own topic is refused for it). The carrier's
    pose between its stamps is interpolated (linear, and scipy's Slerp):
    the kernel's ``relative_states`` is the inverse of this composition
    (test_analysis checks the round trip), not the composition itself.
    """
    if not carrier or not rows:
        return []
    carrier = sorted(carrier, key=lambda r: r[0])
    stamps = np.array([r[0] for r in carrier], dtype=np.int64)
    values = np.array([r[1] for r in carrier], dtype=float).reshape(len(carrier), 7)
    rows = sorted(rows, key=lambda r: r[0])
    when = np.array([r[0] for r in rows], dtype=np.int64)
    inside = (when >= stamps[0]) & (when <= stamps[-1])   # the carrier's span only
    when = when[inside]
    ours = np.array([r[1] for r in rows], dtype=float).reshape(len(rows), 7)[inside]
    if not (len(when) and _rotations(values[:, 3:]).all()):
        return []
    # a relative pose that is no rotation stays NaN, for _assemble to refuse with its topic
    good = _rotations(ours[:, 3:])
    ours[~good, 3:] = [0.0, 0.0, 0.0, 1.0]
    seconds, at = (stamps - stamps[0]) / 1e9, (when - stamps[0]) / 1e9
    origin = np.column_stack([np.interp(at, seconds, values[:, k]) for k in range(3)])
    turn = Rotation.from_quat(values[:, 3:])
    if len(stamps) > 1:
        turn = Slerp(seconds, turn)(at)
    else:
        turn = Rotation.from_quat(np.repeat(values[:1, 3:], len(at), axis=0))
    k = np.clip(np.searchsorted(stamps, when), 0, len(stamps) - 1)
    same = stamps[k] == when   # at the carrier's own stamps, its own poses (no rounding)
    quat = turn.as_quat()
    quat[same] = values[k[same], 3:]
    origin[same] = values[k[same], :3]
    turn = Rotation.from_quat(quat)
    position = origin + turn.apply(ours[:, :3])
    attitude = (turn * Rotation.from_quat(ours[:, 3:])).as_quat()
    attitude[~good] = np.nan
    return [(int(t), tuple(p) + tuple(q)) for t, p, q in zip(when, position, attitude)]


def _rotations(quat: np.ndarray) -> np.ndarray:
    """Tell which quaternions are rotations (finite, of norm above 1e-6)."""
    norms = np.linalg.norm(quat, axis=1) if len(quat) else np.zeros(0)
    return np.isfinite(norms) & (norms > 1e-6)


def _topic_of(topic: str, ns: str):
    """Return (kind, match) of a topic of namespace ns that a ``Run`` reads (``READ``)."""
    for which, kind in READ:
        match = which.pattern.match(topic)
        if match and match['ns'] == ns:
            return kind, match
    return None


def _world_axes_loads(raw: dict):
    """
    Keep the world-axes loads; a load with only its other topic, stamped in world axes, too.

    Recordings made before the ``_world`` topics had the world axes on
    ``joints/<joint>/wrench`` and ``applied/<source>``.
    """
    for kind in ('joint', 'applied'):
        for name, rows in raw[f'{kind}_in'].items():
            if name not in raw[kind] and {r[2] for r in rows} <= raw['world']:
                raw[kind][name] = [r[:2] for r in rows]


def _zero_at_release(rows, release_time, start_ns: int) -> bool:
    """Tell whether a joint's last load is the zero a recording adds at its release."""
    if not rows or not isinstance(release_time, (int, float)):
        return False
    when, values = rows[-1][0], rows[-1][1]
    return when == start_ns + round(release_time * 1e9) and not any(values)


def _check_attitudes(path: str, topic: str, since_ns: np.ndarray, quat: np.ndarray):
    """Refuse poses whose quaternion is not a rotation (zero or non-finite norm)."""
    norms = np.linalg.norm(quat, axis=1) if len(quat) else np.zeros(0)
    bad = ~(np.isfinite(norms) & (norms > 1e-6))
    if bad.any():
        k = int(np.argmax(bad))
        shown = ', '.join(f'{v:g}' for v in quat[k])
        raise RecordingError(
            f'{path}: {topic} at t = {since_ns[k] / 1e9:.9g} s has the quaternion '
            f'[{shown}], which is not a rotation ({int(bad.sum())} such pose(s)); '
            'expected unit quaternions (x, y, z, w)')


def _assemble(path, ns, topics, metadata, raw) -> Run:
    _world_axes_loads(raw)
    poses = raw['pose']
    if 'start_stamp_ns' in metadata:
        start_ns = int(metadata['start_stamp_ns'])
    else:   # the first pose, in the world or (a log's only poses) relative to a body
        start_ns = min(min(r[0] for r in rows)
                       for rows in list(poses.values()) + list(raw['relative_pose'].values())
                       if rows)
    bodies = {}
    for name, rows in poses.items():
        rows.sort(key=lambda r: r[0])
        stamps = np.array([r[0] for r in rows], dtype=np.int64)
        values = np.array([r[1] for r in rows], dtype=float).reshape(len(rows), 7)
        quat = values[:, 3:7]
        _check_attitudes(path, f'{ns}/bodies/{name}/pose', stamps - start_ns, quat)
        twist = np.full((len(rows), 6), np.nan)
        index = {s: i for i, s in enumerate(stamps.tolist())}
        for when, v in raw['twist'].get(name, []):
            if when in index:
                twist[index[when]] = v
        euler = rotations.to_rpy_deg(quat) if len(rows) else np.zeros((0, 3))
        velocity = twist[:, 0:3]
        world = (np.einsum('nij,nj->ni', rotations.matrices(quat), velocity)
                 if len(rows) else np.zeros((0, 3)))
        bodies[name] = BodyTrack(
            name=name, time=(stamps - start_ns) / 1e9, stamp_ns=stamps,
            position=values[:, 0:3], quaternion=quat, euler_deg=euler,
            euler_continuous_deg=euler_continuous(euler), rates=twist[:, 3:6],
            velocity=velocity, velocity_world=world)
    joints, applied, joint_frame = {}, {}, {}
    released = {e.get('joint'): e.get('time') for e in raw['events']
                if e.get('event') == Event.RELEASE}
    in_joint_frame = {name: [r[:2] for r in rows if r[2] not in raw['world']]
                      for name, rows in raw['joint_in'].items()}   # old files: world axes
    for kind, tracks, found in (('joint', joints, raw['joint']),
                                ('applied', applied, raw['applied']),
                                ('frame', joint_frame, in_joint_frame)):
        for name, rows in found.items():
            rows.sort(key=lambda r: r[0])
            if kind != 'applied' and _zero_at_release(rows, released.get(name), start_ns):
                rows = rows[:-1]   # for viewers' plots: the loads are those while it held
            stamps = np.array([r[0] for r in rows], dtype=np.int64)
            values = np.array([r[1] for r in rows], dtype=float).reshape(len(rows), 6)
            tracks[name] = JointTrack(name=name, time=(stamps - start_ns) / 1e9,
                                      stamp_ns=stamps, force=values[:, 0:3],
                                      moment=values[:, 3:6])
    relative = {}
    for name, rows in raw['relative_pose'].items():
        rows.sort(key=lambda r: r[0])
        stamps = np.array([r[0] for r in rows], dtype=np.int64)
        values = np.array([r[1] for r in rows], dtype=float).reshape(len(rows), 7)
        _check_attitudes(path, f'{ns}/bodies/{name}/relative_pose', stamps - start_ns,
                         values[:, 3:])
        twist = np.full((len(rows), 6), np.nan)
        index = {s: i for i, s in enumerate(stamps.tolist())}
        for when, v in raw['relative_twist'].get(name, []):
            if when in index:
                twist[index[when]] = v
        relative[name] = RelativeTrack(
            name=name, reference=raw['reference'][name], time=(stamps - start_ns) / 1e9,
            position=values[:, :3], quaternion=values[:, 3:], velocity=twist[:, :3],
            rates=twist[:, 3:])
    last = max((track.time[-1] for track in list(bodies.values()) + list(relative.values())
                if len(track.time)), default=0.0)
    return Run(path=path, namespace=ns, start_ns=start_ns, bodies=bodies, joints=joints,
               events=raw['events'], topics=topics, metadata=metadata, duration=float(last),
               applied=applied, relative=relative, joint_frame=joint_frame)
