# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Inputs (external wrenches, release commands) read back from an MCAP log, for replay."""

from __future__ import annotations

from dataclasses import replace
from typing import Optional

from cfem_ros.core.errors import InputError
from cfem_ros.core.run.inputs import InputKind, odometry_input, release_input, wrench_input
from cfem_ros.recording import schema
from cfem_ros.recording.errors import RecordingError
from cfem_ros.recording.reader import decoded_messages, open_mcap


def read_inputs(path: str) -> list:
    """
    Read the wrench, release and odometry topics of a recording, in time order.

    Simulated time 0 is the stamp the recording says it started at (its
    ``cfem_ros`` metadata), else its first ``bodies/*/pose`` message (a
    recording of cfem_ros), else its first message. The stamp used is each
    message's log time.

    Raises
    ------
    InputError
        If the file is missing, not a regular file, not MCAP, damaged,
        holds no input topic, or a message's payload does not decode.

    """
    return read_inputs_and_start(path)[0]


def read_inputs_and_start(path: str) -> tuple:
    """Return ``read_inputs(path)`` and the stamp (ns) it took as simulated time 0."""
    try:
        found, start_ns = _read(path)
    except RecordingError as err:   # run --inputs: an input error, as every other one
        raise InputError(str(err)) from err
    if not found:
        raise InputError(f'{path}: holds no input topic (.../bodies/<body>/wrench, '
                         '.../bodies/<body>/odom or .../release); nothing to replay')
    recorded = start_ns is not None   # by cfem_ros: log times are when inputs took effect
    if start_ns is None:
        start_ns = min(f[0] for f in found)
    found.sort(key=lambda f: f[0])
    return [_late(replace(item, time=max(0.0, (stamp_ns - start_ns) / 1e9)), start_ns, recorded)
            for stamp_ns, item in found], start_ns


def _late(item, start_ns: int, recorded: bool):
    """
    Mark odometry that took effect after its own stamp in the recorded run (``Input.at``).

    The node applied it late, when it came, as the message extrapolated from
    its stamp; the replay does the same at the same time (and does not know
    it ahead), so it moves the carrier as the node did.
    """
    if not (recorded and item.kind is InputKind.ODOM and item.header_ns):
        return item
    own = (item.header_ns - start_ns) / 1e9
    return replace(item, at=own) if own < item.time else item


def _read(path: str) -> tuple:
    """Return the (log time, input) of a log's input messages, and its start stamp or None."""
    with open_mcap(path) as reader:
        start_ns = start_stamp_ns(reader)
        found = []
        for channel, message, decoded in decoded_messages(reader, path):
            wrench = schema.WRENCH_INPUT.pattern.match(channel.topic)
            if wrench:
                w = decoded.wrench
                header = decoded.header
                found.append((message.log_time, wrench_input(
                    wrench['body'], [w.force.x, w.force.y, w.force.z],
                    [w.torque.x, w.torque.y, w.torque.z], header.frame_id,
                    header_ns=header.stamp.sec * 1_000_000_000 + header.stamp.nanosec)))
            elif schema.RELEASE_INPUT.pattern.match(channel.topic):
                found.append((message.log_time, release_input(decoded.data.strip())))
            elif schema.ODOMETRY_INPUT.pattern.match(channel.topic):
                found.append((message.log_time, _odometry(
                    schema.ODOMETRY_INPUT.pattern.match(channel.topic)['body'], decoded)))
    return found, start_ns


def recorded_interpolation(path: str) -> Optional[bool]:
    """
    Tell whether the node that recorded path interpolated odometry (None: it does not say).

    From the ``interpolate_odometry`` of its ``cfem_ros`` metadata; the
    file was read by ``read_inputs`` already, so errors are not expected.
    """
    with open_mcap(path, whole=False) as reader:
        for record in reader.iter_metadata():
            if record.name == 'cfem_ros' and 'interpolate_odometry' in record.metadata:
                return record.metadata['interpolate_odometry'] == 'true'
    return None


def _odometry(body: str, msg):
    """Return the input of a nav_msgs/Odometry message."""
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    v, w = msg.twist.twist.linear, msg.twist.twist.angular
    stamp = msg.header.stamp
    return odometry_input(body, [p.x, p.y, p.z], [q.x, q.y, q.z, q.w], [v.x, v.y, v.z],
                          [w.x, w.y, w.z], msg.header.frame_id,
                          header_ns=stamp.sec * 1_000_000_000 + stamp.nanosec)


def start_stamp_ns(reader) -> Optional[int]:
    """Return the stamp of simulated time 0 of an open recording, if it tells (else None)."""
    for record in reader.iter_metadata():
        if record.name == 'cfem_ros' and 'start_stamp_ns' in record.metadata:
            return int(record.metadata['start_stamp_ns'])
    poses = [c.id for c in reader.get_summary().channels.values()
             if schema.POSE.pattern.match(c.topic)] if reader.get_summary() else []
    if poses:
        for _, _, message in reader.iter_messages(
                topics=None, log_time_order=True):
            if message.channel_id in poses:
                return message.log_time
    return None
