# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Measured poses of a fit (SPEC section 13): from an MCAP topic or an exported CSV.

A ``Measured`` holds times (s of simulated time), positions (m) and
attitudes of one body relative to another, in that body's axes, and the
releases the file records. Three sources:

- a ``geometry_msgs/msg/PoseStamped`` topic whose ``frame_id`` is the
  ``relative_to`` body (photogrammetry, a telemetry package): times are
  the header stamps less the start of the replayed inputs (as ``run
  --inputs`` takes it: one clock for both), or without inputs the file's
  own start (its ``cfem_ros`` metadata's ``start_stamp_ns``, else its first
  pose of a cfem_ros recording, else the topic's first stamp);
- a ``bodies/<body>/pose`` topic of a cfem_ros recording (world poses):
  composed with the ``relative_to`` body's recorded poses;
- a CSV in the columns of ``cfem-sim export --relative-to`` (``time``,
  ``<body>_x``, ``_y``, ``_z`` in m, ``_roll_deg``, ``_pitch_deg``,
  ``_yaw_deg``, Z-Y-X), each header the bare name or the name with its
  unit as export writes it (``store_x [m]``); another unit is refused.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from typing import Optional

from cfem_ros.recording import schema
from cfem_ros.recording.analysis import open_run
from cfem_ros.recording.errors import RecordingError
from cfem_ros.recording.reader import decoded_messages, open_mcap
from cfem_ros.recording.relative import relative_pose
from cfem_ros.recording.replay import start_stamp_ns
from cfem_ros.recording.units import bare_columns, BODY
from cfem_ros.study.fit.flights import FitError, Flight
import numpy as np
from scipy.spatial.transform import Rotation

POSE_SCHEMA = 'geometry_msgs/msg/PoseStamped'
CSV_QUANTITIES = ('x', 'y', 'z', 'roll_deg', 'pitch_deg', 'yaw_deg')
#: A measured position farther than this from the reference (m) is no measurement of a
#: store near its carrier (1000 km): refused, as a value that is not finite is.
LARGEST_POSITION = 1e6
#: A measured angle beyond this (deg, about 2,800 turns) is refused likewise.
LARGEST_ANGLE_DEG = 1e6
#: A CSV field that is a missing value (NaN, refused by its line): pandas' names for one.
MISSING = frozenset(('', '#N/A', '#N/A N/A', '#NA', '-1.#IND', '-1.#QNAN', '-NaN', '-nan',
                     '1.#IND', '1.#QNAN', '<NA>', 'N/A', 'NA', 'NULL', 'NaN', 'None', 'n/a',
                     'nan', 'null'))


@dataclass
class Measured:
    """
    One body's measured poses relative to another.

    Attributes
    ----------
    time : ndarray (n,)
        s of simulated time, increasing.
    position : ndarray (n, 3)
        CG relative to the reference body's CG, in its axes, m.
    attitude : scipy.spatial.transform.Rotation (n)
        Body axes to the reference body's axes.
    releases : dict of str to float
        Release times (s) the file records, by joint (a cfem_ros recording's
        events); empty if it records none.

    """

    time: np.ndarray
    position: np.ndarray
    attitude: Rotation
    releases: dict = field(default_factory=dict)

    def window(self, start: float, end: float) -> 'Measured':
        """Return the samples with start <= time <= end."""
        keep = (self.time >= start) & (self.time <= end)
        return Measured(self.time[keep], self.position[keep], self.attitude[keep],
                        self.releases)

    def last_before(self, end: float) -> float:
        """Return the time of the last sample at or before end (s; the first if none is)."""
        before = self.time[self.time <= end]
        return float(before[-1]) if before.size else float(self.time[0])


def relative_poses(position, quaternion, position_ref, quaternion_ref) -> tuple:
    """
    Return a body's poses in a reference body's axes, sample by sample.

    Parameters
    ----------
    position, position_ref : ndarray (n, 3)
        CG positions in the world frame, m.
    quaternion, quaternion_ref : ndarray (n, 4)
        Body-to-world attitudes, x, y, z, w.

    Returns
    -------
    (ndarray (n, 3), Rotation)
        The CG relative to the reference's CG in its axes (m), and the
        attitude body-to-reference (``recording.relative.relative_pose``).

    """
    moved, attitude = relative_pose(position, quaternion, position_ref, quaternion_ref)
    return moved, Rotation.from_quat(attitude)


def read_measured(path: str, spec: Flight, start_ns: Optional[int] = None) -> Measured:
    """
    Read one flight's measured poses (path: the fit file, for messages).

    start_ns: the stamp of simulated time 0 (the replayed inputs' start, so
    that measured poses and inputs share one clock); by default the measured
    file's own start.

    Raises
    ------
    FitError
        If the file cannot be read, lacks the topic or columns, names another
        frame, holds a value that is not finite (or a position beyond 1000 km,
        a quaternion of length 0), or fewer than two samples.

    """
    try:
        if spec.measured_file.lower().endswith('.csv'):
            measured = _from_csv(path, spec)
        elif schema.POSE.pattern.match(spec.topic):
            measured = _from_recording(path, spec)
        else:
            measured = _from_topic(path, spec, start_ns)
    except RecordingError as err:
        raise FitError(path, f'{spec.key}.file', str(err), 'a readable MCAP recording') \
            from err
    if len(measured.time) < 2:
        raise FitError(path, spec.key, f'{spec.measured_file} holds '
                       f'{len(measured.time)} pose(s) of {spec.body}', 'a trajectory: '
                       'poses at two times or more')
    order = np.argsort(measured.time, kind='stable')
    return Measured(measured.time[order], measured.position[order],
                    measured.attitude[order], measured.releases)


def _from_csv(path: str, spec: Flight) -> Measured:
    try:
        with open(spec.measured_file, encoding='utf-8-sig', newline='') as stream:
            reader = csv.reader(stream)
            lines = [(reader.line_num, row) for row in reader if row]   # blank lines skipped
    except (OSError, ValueError, csv.Error) as err:
        raise FitError(path, f'{spec.key}.file', f'{spec.measured_file} cannot be read '
                       f'as CSV ({err})', 'a CSV written by cfem-sim export') from err
    if not lines:
        raise FitError(path, f'{spec.key}.file', f'{spec.measured_file} is empty',
                       'a CSV written by cfem-sim export')
    names = ['time'] + [f'{spec.body}_{q}' for q in CSV_QUANTITIES]
    expected = {'time': 's', **{f'{spec.body}_{q}': BODY[q] for q in CSV_QUANTITIES}}
    try:   # a header 'store_x [m]' (as export writes it) or 'store_x'
        header = bare_columns(spec.measured_file, lines[0][1], expected)
    except RecordingError as err:   # '<file>: column ... is in mm; expected m (...)'
        problem, _, expected = str(err).partition('; expected ')
        raise FitError(path, f'{spec.key}.file', problem, expected) from err
    missing = [n for n in names if n not in header]
    if missing:
        raise FitError(path, f'{spec.key}.file', f'{spec.measured_file} has no column '
                       + ', '.join(missing), 'the columns of cfem-sim export --relative-to '
                       f'{spec.relative_to} (time, {spec.body}_x, ..., {spec.body}_yaw_deg)')
    try:
        values = _numbers(lines[1:], [header.index(n) for n in names], len(header))
    except ValueError as err:
        raise FitError(path, f'{spec.key}.file', f'{spec.measured_file} {err}',
                       'numbers, one per column of the header') from err
    _refuse_rows(path, spec, values[:, 0], values[:, 1:4], values[:, 4:7], rows=2,
                 what='line')
    yaw_pitch_roll = values[:, [6, 5, 4]]
    return Measured(values[:, 0], values[:, 1:4],
                    Rotation.from_euler('ZYX', yaw_pitch_roll, degrees=True))


def _numbers(lines: list, columns: list, width: int) -> np.ndarray:
    """
    Return columns of a CSV's data lines ((number, fields)) as floats (n, len(columns)).

    A field that is empty or missing, or one of pandas' names for a missing
    value (``NaN``, ``NA``, ``null``, ...), is NaN. Raises ValueError naming
    the line of a row wider than the header or of a field that is no number.
    """
    out = np.empty((len(lines), len(columns)))
    for k, (line, row) in enumerate(lines):
        if len(row) > width:
            raise ValueError(f'line {line} has {len(row)} fields, the header {width}')
        for j, column in enumerate(columns):
            field = row[column].strip() if column < len(row) else ''
            if field in MISSING:
                out[k, j] = np.nan
                continue
            try:
                if '_' in field:   # float() takes 1_000; a CSV reader does not
                    raise ValueError(field)
                out[k, j] = float(field)
            except ValueError:
                raise ValueError(f'line {line} holds {field!r}, not a number') from None
    return out


def _from_recording(path: str, spec: Flight) -> Measured:
    pose = schema.POSE.pattern.match(spec.topic)
    run = open_run(spec.measured_file, namespace=pose['ns'])
    name = pose['body']
    if name != spec.body:
        raise FitError(path, f'{spec.key}.topic', f'is the pose of {name}',
                       f'the pose topic of the measured body {spec.body}')
    releases = {}
    for t, joint, _ in run.releases():
        releases.setdefault(joint, float(t))
    track = run.bodies[name]
    _refuse_rows(path, spec, track.time, track.position, quaternions=track.quaternion,
                 what='sample')
    if spec.relative_to not in run.bodies:   # the world frame
        return Measured(track.time, track.position, Rotation.from_quat(track.quaternion),
                        releases)
    reference = run.bodies[spec.relative_to]
    common, mine, theirs = np.intersect1d(track.stamp_ns, reference.stamp_ns,
                                          return_indices=True)
    position, attitude = relative_poses(track.position[mine], track.quaternion[mine],
                                        reference.position[theirs],
                                        reference.quaternion[theirs])
    return Measured(track.time[mine], position, attitude, releases)


def _from_topic(path: str, spec: Flight, start_ns: Optional[int]) -> Measured:
    stamps, positions, quaternions, frames = [], [], [], set()
    with open_mcap(spec.measured_file) as reader:
        summary = reader.get_summary()
        topics = {c.topic: summary.schemas[c.schema_id].name
                  for c in summary.channels.values()} if summary else {}
        if spec.topic not in topics:
            raise FitError(path, f'{spec.key}.topic', f'{spec.topic} is not in '
                           f'{spec.measured_file}',
                           'one of its PoseStamped topics: ' + ', '.join(
                               t for t, s in sorted(topics.items()) if s == POSE_SCHEMA))
        if topics[spec.topic] != POSE_SCHEMA:
            raise FitError(path, f'{spec.key}.topic', f'{spec.topic} carries '
                           f'{topics[spec.topic]}', POSE_SCHEMA)
        start = start_stamp_ns(reader) if start_ns is None else start_ns
        for _, _, decoded in decoded_messages(reader, spec.measured_file, topics=[spec.topic]):
            stamp = decoded.header.stamp
            p, q = decoded.pose.position, decoded.pose.orientation
            stamps.append(stamp.sec * 1_000_000_000 + stamp.nanosec)
            positions.append([p.x, p.y, p.z])
            quaternions.append([q.x, q.y, q.z, q.w])
            frames.add(decoded.header.frame_id)
    if frames - {spec.relative_to, ''}:
        raise FitError(path, f'{spec.key}.relative_to', f'is {spec.relative_to}, but '
                       f'{spec.topic} is in frame ' + ', '.join(sorted(frames)),
                       'the frame_id of the measured poses')
    if not stamps:
        raise FitError(path, f'{spec.key}.topic', f'{spec.topic} holds no message',
                       f'the measured poses of {spec.body}')
    stamps = np.array(stamps, dtype=np.int64)
    start = int(stamps.min()) if start is None else start
    positions, quaternions = np.array(positions, dtype=float), np.array(quaternions, float)
    _refuse_rows(path, spec, stamps.astype(float), positions, quaternions=quaternions,
                 rows=1, what='message')
    return Measured((stamps - start) / 1e9, positions, Rotation.from_quat(quaternions))


def _refuse_rows(path: str, spec: Flight, time, position, angles=None, quaternions=None,
                 rows: int = 1, what: str = 'row'):
    """
    Refuse a measured sample that is not finite or cannot be a pose, naming its row.

    rows: the number of the first sample (a CSV's first data line is 2, a
    topic's first message 1).
    """
    problems = []
    with np.errstate(invalid='ignore', over='ignore'):
        problems.append((~np.isfinite(time), 'a time that is not finite'))
        problems.append((~np.all(np.isfinite(position), axis=1), 'a position that is not '
                         'finite'))
        problems.append((np.any(np.abs(position) > LARGEST_POSITION, axis=1),
                         f'a position beyond {LARGEST_POSITION:g} m of {spec.relative_to}'))
        if angles is not None:
            problems.append((~np.all(np.isfinite(angles), axis=1), 'an angle that is not '
                             'finite'))
            problems.append((np.any(np.abs(angles) > LARGEST_ANGLE_DEG, axis=1),
                             f'an angle beyond {LARGEST_ANGLE_DEG:g} deg'))
        if quaternions is not None:
            norm = np.linalg.norm(quaternions, axis=1)
            problems.append((~np.isfinite(norm), 'a quaternion that is not finite'))
            problems.append((norm < 1e-6, 'a quaternion of length 0 (no attitude)'))
    for bad, problem in problems:
        if bad.any():
            first = int(np.flatnonzero(bad)[0])
            more = f' (and {int(bad.sum()) - 1} more)' if bad.sum() > 1 else ''
            values = np.concatenate([np.atleast_1d(position[first]),
                                     np.atleast_1d((angles if angles is not None
                                                    else quaternions)[first])])
            raise FitError(path, f'{spec.key}.file', f'{spec.measured_file} {what} '
                           f'{first + rows}{more} holds {problem} '
                           f'({", ".join(f"{v:.6g}" for v in values)})',
                           'finite measured poses (drop the sample, or repair it)')
