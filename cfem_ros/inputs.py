# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Input topics (external wrenches, release commands) read from an MCAP log."""

from __future__ import annotations

from dataclasses import dataclass
import re
from typing import Optional

from cfem_ros.errors import InputError
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
import numpy as np

WRENCH_TOPIC = re.compile(r'^(?P<ns>.*)/bodies/(?P<body>[^/]+)/wrench$')
RELEASE_TOPIC = re.compile(r'^(?P<ns>.*)/release$')
POSE_TOPIC = re.compile(r'^(?P<ns>.*)/bodies/[^/]+/pose$')


@dataclass(frozen=True)
class Input:
    """
    One input message, at simulated time ``time`` (s).

    ``kind`` is 'wrench' (body, force, torque, frame_id) or 'release' (joint).
    """

    time: float
    stamp_ns: int
    kind: str
    target: str
    force: Optional[np.ndarray] = None
    torque: Optional[np.ndarray] = None
    frame_id: str = ''


def read_inputs(path: str) -> list:
    """
    Read the wrench and release topics of a recording, in time order.

    Simulated time 0 is the stamp the recording says it started at (its
    ``cfem_ros`` metadata), else its first ``bodies/*/pose`` message (a
    recording of cfem_ros), else its first message. The stamp used is each
    message's log time.

    Raises
    ------
    InputError
        If the file is missing, not MCAP, or holds no input topic.

    """
    try:
        with open(path, 'rb') as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            start_ns = _start_ns(reader)
            found = []
            for _, channel, message, decoded in reader.iter_decoded_messages():
                wrench = WRENCH_TOPIC.match(channel.topic)
                if wrench:
                    w = decoded.wrench
                    found.append((message.log_time, 'wrench', wrench['body'],
                                  np.array([w.force.x, w.force.y, w.force.z]),
                                  np.array([w.torque.x, w.torque.y, w.torque.z]),
                                  decoded.header.frame_id))
                elif RELEASE_TOPIC.match(channel.topic):
                    found.append((message.log_time, 'release', decoded.data.strip(),
                                  None, None, ''))
    except OSError as err:
        raise InputError(f'{path}: cannot read ({err.strerror})') from err
    except (McapError, ValueError, KeyError, AttributeError) as err:
        raise InputError(f'{path}: not a readable ROS 2 MCAP recording ({err})') from err
    if not found:
        raise InputError(f'{path}: holds no input topic (.../bodies/<body>/wrench or '
                         '.../release); nothing to replay')
    if start_ns is None:
        start_ns = min(f[0] for f in found)
    found.sort(key=lambda f: f[0])
    return [Input(time=max(0.0, (stamp_ns - start_ns) * 1e-9), stamp_ns=stamp_ns, kind=kind,
                  target=target, force=force, torque=torque, frame_id=frame)
            for stamp_ns, kind, target, force, torque, frame in found]


def _start_ns(reader) -> Optional[int]:
    """Stamp of simulated time 0 of a recording, if it tells."""
    for record in reader.iter_metadata():
        if record.name == 'cfem_ros' and 'start_stamp_ns' in record.metadata:
            return int(record.metadata['start_stamp_ns'])
    poses = [c.id for c in reader.get_summary().channels.values()
             if POSE_TOPIC.match(c.topic)] if reader.get_summary() else []
    if poses:
        for _, _, message in reader.iter_messages(
                topics=None, log_time_order=True):
            if message.channel_id in poses:
                return message.log_time
    return None


def apply_wrench(sim, body: str, force, torque, frame_id: str):
    """
    Hold an external wrench on a body, in world or body axes by frame_id.

    Raises
    ------
    ValueError
        With the reason: unknown body, unknown frame, non-finite numbers.

    """
    world = sim.model.frame_id
    if frame_id not in (world, body):
        raise ValueError(f'frame_id {frame_id!r} is neither the world frame {world!r} '
                         f'nor the body {body!r}')
    sim.set_wrench(body, force, torque, body_axes=(frame_id == body))


def apply_input(sim, item: Input):
    """Apply one input now (ValueError with the reason if it cannot be)."""
    if item.kind == 'wrench':
        apply_wrench(sim, item.target, item.force, item.torque, item.frame_id)
    else:
        sim.release(item.target, cause='command')
