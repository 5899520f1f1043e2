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

from dataclasses import dataclass, field
import json
import re
from typing import Optional

from cfem_ros.core import rotations
from cfem_ros.recording import schema
from cfem_ros.recording.errors import RecordingError
from cfem_ros.recording.reader import check_mcap, decoded_messages, open_mcap, reading
import numpy as np
from scipy.spatial.transform import Rotation, Slerp

__all__ = ['BodyTrack', 'Difference', 'JointTrack', 'Run', 'attitude_difference_deg',
           'check_mcap', 'compare_runs', 'euler_continuous', 'open_run']

#: What ``cfem-sim info`` lists a recording's bodies and joints by (group ``name``); to be
#: replaced there by ``schema.POSE.pattern`` and ``schema.JOINT_WRENCH.pattern``.
BODY_TOPIC = re.compile(r'^(?P<ns>.*)/bodies/(?P<name>[^/]+)/(?P<kind>pose|twist|wrench)$')
JOINT_TOPIC = re.compile(r'^(?P<ns>.*)/joints/(?P<name>[^/]+)/wrench$')
#: The topics a ``Run`` is read from, with the kind of ``_read_messages``'s rows they make.
#: The loads in world axes (SPEC sections 3 and 5) are what a ``Run`` holds; recordings
#: made before the ``_world`` topics existed had the world axes on the others (``*_in``).
READ = ((schema.RELATIVE_POSE, 'relative_pose'), (schema.RELATIVE_TWIST, 'relative_twist'),
        (schema.POSE, 'pose'), (schema.TWIST, 'twist'),
        (schema.JOINT_WRENCH_WORLD, 'joint'), (schema.APPLIED_WORLD, 'applied'),
        (schema.JOINT_WRENCH, 'joint_in'), (schema.APPLIED, 'applied_in'),
        (schema.EVENTS, 'events'))
NAN = float('nan')

#: Near pitch +-90 deg roll and yaw are each undefined (only their sum or
#: difference is): a body whose roll or yaw moves more than this (deg) from
#: one sample to the next, and ten times more than the body turns, is shown
#: with a quaternion instead of Euler angles.
EULER_JUMP_DEG = 10.0


@dataclass
class BodyTrack:
    """
    One body's recorded motion; arrays have one row per pose sample.

    Attributes
    ----------
    name : str
    time : ndarray (n,)
        s from the run's start.
    stamp_ns : ndarray (n,) of int64
        The samples' stamps.
    position : ndarray (n, 3)
        CG in the world frame, m.
    quaternion : ndarray (n, 4)
        Body-to-world attitude, x, y, z, w.
    euler_deg : ndarray (n, 3)
        Roll, pitch, yaw in degrees, Z-Y-X (yaw first); pitch within +-90 deg,
        roll and yaw within +-180 deg (they flip by 180 deg when pitch passes
        +-90 deg).
    euler_continuous_deg : ndarray (n, 3)
        The same attitudes as continuous angles: pitch may go past +-90 deg
        (a tumbling store's pitch keeps growing) and no angle jumps by 360.
    rates : ndarray (n, 3)
        Body rates p, q, r, rad/s (NaN where no twist matches a pose).
    velocity : ndarray (n, 3)
        CG velocity in body axes (u, v, w), m/s, as published.
    velocity_world : ndarray (n, 3)
        CG velocity in world axes, m/s.

    """

    name: str
    time: np.ndarray
    stamp_ns: np.ndarray
    position: np.ndarray
    quaternion: np.ndarray
    euler_deg: np.ndarray
    euler_continuous_deg: np.ndarray
    rates: np.ndarray
    velocity: np.ndarray
    velocity_world: np.ndarray

    @property
    def euler_singular(self) -> bool:
        """
        Tell whether the Euler angles misrepresent the motion near pitch +-90 deg.

        True when roll or yaw moves by more than ``EULER_JUMP_DEG`` between two
        samples and by more than ten times the angle the body turned between
        them (a pure pitch through 90 deg keeps its roll and yaw and is fine).
        """
        if len(self.time) < 2:
            return False
        turned = np.degrees(rotations.angle_between(self.quaternion[:-1], self.quaternion[1:]))
        moved = np.abs(np.diff(self.euler_continuous_deg[:, [0, 2]], axis=0)).max(axis=1)
        return bool(np.any((moved > EULER_JUMP_DEG) & (moved > 10.0 * turned)))

    @property
    def quaternion_continuous(self) -> np.ndarray:
        """Return the attitudes as quaternions whose sign never jumps (q, -q: one attitude)."""
        q = np.array(self.quaternion, dtype=float, copy=True)
        if len(q) > 1:
            flips = np.einsum('ij,ij->i', q[1:], q[:-1]) < 0.0
            sign = np.concatenate([[1.0], np.where(np.cumsum(flips) % 2, -1.0, 1.0)])
            q *= sign[:, None]
        return q

    @property
    def moves(self) -> bool:
        """Tell whether the body changes position or attitude during the run."""
        return bool(np.ptp(self.position, axis=0).max(initial=0.0) > 0.0
                    or np.ptp(self.quaternion, axis=0).max(initial=0.0) > 0.0)


@dataclass
class JointTrack:
    """
    One joint's recorded load on its child, while it was active.

    Attributes
    ----------
    name : str
    time : ndarray (n,)
        s from the run's start.
    stamp_ns : ndarray (n,) of int64
    force : ndarray (n, 3)
        N, world axes.
    moment : ndarray (n, 3)
        N m about the joint point, world axes.

    """

    name: str
    time: np.ndarray
    stamp_ns: np.ndarray
    force: np.ndarray
    moment: np.ndarray


@dataclass
class RelativeTrack:
    """
    One body's recorded pose and twist in its reference's (carrier's) frame.

    Attributes
    ----------
    name, reference : str
        The body and the frame (``frame_id``) its numbers are in.
    time : ndarray (n,)
        s from the run's start.
    position : ndarray (n, 3)
        CG relative to the reference's CG, reference axes, m.
    quaternion : ndarray (n, 4)
        Attitude relative to the reference, x y z w.
    velocity, rates : ndarray (n, 3)
        CG velocity seen from the reference (m/s) and angular velocity
        relative to it (rad/s), reference axes; NaN where no twist matches.

    """

    name: str
    reference: str
    time: np.ndarray
    position: np.ndarray
    quaternion: np.ndarray
    velocity: np.ndarray
    rates: np.ndarray


@dataclass
class Run:
    """
    A recording, read.

    Attributes
    ----------
    path : str
    namespace : str
        The topics' prefix, e.g. '/cfem'.
    start_ns : int
        Stamp of t = 0.
    bodies : dict of str to BodyTrack
        In the order the recording first names them.
    joints : dict of str to JointTrack
    events : list of dict
        Decoded JSON events: releases (``{'event', 'joint', 'time', 'cause'}``,
        ``'group'`` for a release group's joints) and stroke ends
        (``stroke_ends``).
    topics : dict of str to (str, int)
        Every topic in the file: (message type, message count).
    metadata : dict of str to str
        The ``cfem_ros`` metadata record, if any.
    duration : float
        Seconds from the start to the last sample.
    applied : dict of str to JointTrack
        Scheduled loads (``bodies/<body>/applied/<source>``) by '<body>/<source>':
        force and moment about the body's CG, world axes.
    relative : dict of str to RelativeTrack
        Poses and twists in a carrier's frame (``bodies/<body>/relative_pose``).
    joint_frame : dict of str to JointTrack
        Joint loads as published on ``joints/<joint>/wrench``: in the joint's
        frame (the child's axes), moment about the joint point.

    """

    path: str
    namespace: str
    start_ns: int
    bodies: dict
    joints: dict
    events: list
    topics: dict
    metadata: dict = field(default_factory=dict)
    duration: float = 0.0
    applied: dict = field(default_factory=dict)
    relative: dict = field(default_factory=dict)
    joint_frame: dict = field(default_factory=dict)

    def releases(self) -> list:
        """Return the release events as (time, joint, cause), in time order."""
        return sorted((e['time'], e.get('joint', '?'), e.get('cause', '?'))
                      for e in self.events if e.get('event') == 'release' and 'time' in e)

    def moving_bodies(self) -> list:
        """Return the bodies that move, in order."""
        return [track for track in self.bodies.values() if track.moves]

    def stroke_ends(self) -> dict:
        """
        Return the end-of-stroke figures by wrench name (SPEC section 7).

        Each is a dict with ``time`` (s), ``velocity`` (u, v, w, m/s) and
        ``rates`` (p, q, r, rad/s) as arrays: the loaded body's CG velocity
        and body rates relative to the wrench's ``reacts_on`` body (the
        world when none), in the loaded body's axes; and ``body`` and
        ``reacts_on`` (None: the world). Wrenches whose stroke never ended
        are absent; of two wrenches of one name (on two bodies), the first.
        """
        out = {}
        for e in self.events:
            if e.get('event') != 'stroke_end' or 'wrench' not in e:
                continue
            out.setdefault(e['wrench'], {
                'time': float(e['time']), 'body': e.get('body'),
                'reacts_on': e.get('reacts_on'),
                'velocity': np.asarray(e['velocity'], dtype=float),
                'rates': np.asarray(e['rates'], dtype=float)})
        return out


def euler_continuous(euler_deg: np.ndarray) -> np.ndarray:
    """
    Turn Z-Y-X angles (pitch within +-90 deg) into continuous ones.

    Each attitude has two Z-Y-X triples, (roll, pitch, yaw) and
    (roll + 180, 180 - pitch, yaw + 180); at each sample the one nearest the
    previous sample is kept, and every angle is unwrapped by whole turns.
    """
    out = np.array(euler_deg, dtype=float, copy=True)
    for i in range(1, len(out)):
        prev = out[i - 1]
        best = None
        roll, pitch, yaw = out[i]
        for candidate in (out[i], np.array([roll + 180.0, 180.0 - pitch, yaw + 180.0])):
            unwrapped = candidate + 360.0 * np.round((prev - candidate) / 360.0)
            distance = np.abs(unwrapped - prev).sum()
            if best is None or distance < best[0]:
                best = (distance, unwrapped)
        out[i] = best[1]
    return out


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
             topic_map: Optional[dict] = None) -> Run:
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
        raw = _read_messages(decoded_messages(reader, path), ns, renamed)
    with reading(path):
        return _assemble(path, ns, topics, metadata, raw)


def _renamed(channel, renamed: dict):
    """Return the channel, under the topic the map gives it (a copy), if any."""
    if channel.topic not in renamed:
        return channel
    from dataclasses import replace as _replace
    return _replace(channel, topic=renamed[channel.topic])


def _read_messages(messages, ns: str, renamed: Optional[dict] = None) -> dict:
    raw = {'pose': {}, 'twist': {}, 'joint': {}, 'applied': {}, 'events': [],
           'relative_pose': {}, 'relative_twist': {}, 'reference': {},
           'joint_in': {}, 'applied_in': {}, 'world': set()}   # *_in: loads, frame_id
    for channel, _, decoded in messages:
        topic = (renamed or {}).get(channel.topic, channel.topic)
        found = _topic_of(topic, ns)
        if found is None:
            continue
        kind, match = found
        if kind == 'events':
            try:
                event = json.loads(decoded.data)
            except (ValueError, TypeError):
                event = {'event': 'unparsed', 'data': str(decoded.data)}
            raw['events'].append(event if isinstance(event, dict) else {'event': event})
            continue
        stamp = decoded.header.stamp
        when = stamp.sec * 1_000_000_000 + stamp.nanosec
        if kind.endswith('pose'):
            p, q = decoded.pose.position, decoded.pose.orientation
            values = (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
            if kind == 'pose':
                raw['world'].add(decoded.header.frame_id)
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
    else:
        start_ns = min(rows[0][0] for rows in poses.values())
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
                if e.get('event') == 'release'}
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
    last = max((track.time[-1] for track in bodies.values() if len(track.time)), default=0.0)
    return Run(path=path, namespace=ns, start_ns=start_ns, bodies=bodies, joints=joints,
               events=raw['events'], topics=topics, metadata=metadata, duration=float(last),
               applied=applied, relative=relative, joint_frame=joint_frame)


@dataclass(frozen=True)
class Difference:
    """The largest difference of one quantity between two runs."""

    quantity: str
    unit: str
    max_abs: float
    at_time: float
    scale: float
    samples: int


def _overlap(t_a, t_b):
    """Tell which of A's times lie inside B's span (a boolean mask; all False if B is empty)."""
    if not len(t_b):
        return np.zeros(len(t_a), dtype=bool)
    return (t_a >= t_b[0] - 1e-12) & (t_a <= t_b[-1] + 1e-12)


def _resampled_difference(t_a, values_a, t_b, values_b):
    """Differences of A and B at A's times inside B's span (B linearly interpolated)."""
    inside = _overlap(t_a, t_b)
    t = t_a[inside]
    ours = values_a[inside]
    theirs = np.column_stack([np.interp(t, t_b, values_b[:, k])
                              for k in range(values_b.shape[1])])
    return t, ours - theirs, ours


def attitude_difference_deg(a: BodyTrack, b: BodyTrack):
    """
    Return A's times inside B's span and the angle from A's attitude to B's there, deg.

    The angle is that of the rotation q_A^-1 q_B, in [0, 180] deg: it has no
    singularity (Euler angles do at pitch +-90 deg). B's attitudes are
    interpolated onto A's times by spherical linear interpolation.
    """
    if not len(a.time) or not len(b.time):
        return np.zeros(0), np.zeros(0)
    inside = _overlap(a.time, b.time)
    t = a.time[inside]
    theirs = np.repeat(b.quaternion[:1], len(t), axis=0)
    if len(b.time) > 1:
        slerp = Slerp(b.time, Rotation.from_quat(b.quaternion))
        theirs = slerp(np.clip(t, b.time[0], b.time[-1])).as_quat()
    # at B's own sample times, B's own attitudes (no interpolation rounding)
    k = np.clip(np.searchsorted(b.time, t), 0, len(b.time) - 1)
    same = b.time[k] == t
    theirs[same] = b.quaternion[k[same]]
    return t, np.degrees(rotations.angle_between(a.quaternion[inside], theirs))


def relative_position(body: BodyTrack, carrier: BodyTrack):
    """
    Return a body's times inside the carrier's span and its CG in the carrier's axes there.

    The carrier's pose is interpolated onto the body's times (position
    linearly, attitude by slerp).
    """
    inside = (body.time >= carrier.time[0] - 1e-12) & (body.time <= carrier.time[-1] + 1e-12)
    t = body.time[inside]
    origin = np.column_stack([np.interp(t, carrier.time, carrier.position[:, k])
                              for k in range(3)])
    if len(carrier.time) > 1:
        turn = Slerp(carrier.time, Rotation.from_quat(carrier.quaternion))(
            np.clip(t, carrier.time[0], carrier.time[-1]))
    else:
        turn = Rotation.from_quat(np.repeat(carrier.quaternion[:1], len(t), axis=0))
    return t, turn.inv().apply(body.position[inside] - origin)


def compare_runs(a: Run, b: Run) -> tuple:
    """
    Compare the bodies and joints two runs share, quantity by quantity.

    B is interpolated linearly onto A's sample times where they differ (only
    inside B's time span: every column, ``max_abs``, ``at_time`` and
    ``scale`` (max |A|), is over these compared times only). A vector's
    difference and scale are its largest component. Quantities:
    ``<body> position`` (m, world axes), ``attitude`` (the angle of the
    rotation from A's attitude to B's, deg; B's quaternions interpolated by
    slerp; scale: A's turn from its first sample), ``rates`` (body axes,
    deg/s), ``velocity`` (CG velocity in body axes u, v, w, m/s);
    ``<joint> force`` (N), ``moment`` (N m),
    ``release`` (time, s); with a carrier in A (``Run.relative``),
    ``<body> position in <carrier> axes`` (m: B's relative track, or B's
    body and carrier poses). Returns (differences, only_in_a, only_in_b), where
    the last two list body and joint names present in one run only, and a
    body's rates and velocity when only one run has its twists.
    """
    rows, missing_a, missing_b = [], [], []

    def add(quantity, unit, t_a, v_a, t_b, v_b):
        t, diff, ours = _resampled_difference(t_a, v_a, t_b, v_b)
        if not len(t):
            rows.append(Difference(quantity, unit, NAN, NAN, NAN, 0))
            return
        magnitude = np.abs(diff).max(axis=1)
        k = int(np.nanargmax(magnitude)) if np.isfinite(magnitude).any() else 0
        rows.append(Difference(quantity, unit, float(magnitude[k]), float(t[k]),
                               float(np.nanmax(np.abs(ours))), len(t)))

    for name, ta in a.bodies.items():
        tb = b.bodies.get(name)
        if tb is None:
            continue
        add(f'{name} position', 'm', ta.time, ta.position, tb.time, tb.position)
        t, angle = attitude_difference_deg(ta, tb)
        if len(t):
            k = int(np.argmax(angle))
            # A's turn from its start, at the compared times only (as every other column)
            turned = rotations.angle_between(ta.quaternion[:1],
                                             ta.quaternion[_overlap(ta.time, tb.time)])
            rows.append(Difference(f'{name} attitude', 'deg', float(angle[k]), float(t[k]),
                                   float(np.degrees(turned.max())), len(t)))
        else:
            rows.append(Difference(f'{name} attitude', 'deg', NAN, NAN, NAN, 0))
        # rates and velocity come from the twists, which a log may not have
        has_a, has_b = not np.isnan(ta.rates).all(), not np.isnan(tb.rates).all()
        if has_a and has_b:
            add(f'{name} rates', 'deg/s', ta.time, np.degrees(ta.rates), tb.time,
                np.degrees(tb.rates))
            add(f'{name} velocity', 'm/s', ta.time, ta.velocity, tb.time, tb.velocity)
        elif has_a != has_b:
            missing = missing_b if has_a else missing_a
            missing += [f'{name} rates (no twist in {"B" if has_a else "A"})',
                        f'{name} velocity (no twist in {"B" if has_a else "A"})']
    for name, ja in a.joints.items():
        jb = b.joints.get(name)
        if jb is None:
            continue
        add(f'{name} force', 'N', ja.time, ja.force, jb.time, jb.force)
        add(f'{name} moment', 'N m', ja.time, ja.moment, jb.time, jb.moment)
    for name, ra in a.relative.items():   # in the carrier's frame (SPEC section 5)
        rb = b.relative.get(name)
        if rb is not None and rb.reference == ra.reference:
            add(f'{name} position in {ra.reference} axes', 'm', ra.time, ra.position,
                rb.time, rb.position)
            continue
        body, carrier = b.bodies.get(name), b.bodies.get(ra.reference)
        if body is None or carrier is None or len(carrier.time) < 1:
            continue
        t, position = relative_position(body, carrier)
        add(f'{name} position in {ra.reference} axes', 'm', ra.time, ra.position, t, position)
    releases_a = {joint: t for t, joint, _ in a.releases()}
    releases_b = {joint: t for t, joint, _ in b.releases()}
    for joint in sorted(set(releases_a) & set(releases_b)):
        gap = abs(releases_a[joint] - releases_b[joint])
        rows.append(Difference(f'{joint} release', 's', gap, releases_a[joint],
                               releases_a[joint], 1))
    names_a = set(a.bodies) | set(a.joints) | {f'{j} release' for j in releases_a}
    names_b = set(b.bodies) | set(b.joints) | {f'{j} release' for j in releases_b}
    return (rows, sorted(names_a - names_b) + missing_b,
            sorted(names_b - names_a) + missing_a)
