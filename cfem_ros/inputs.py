# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Input topics (external wrenches, release commands) read from an MCAP log."""

from __future__ import annotations

from dataclasses import dataclass, replace
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
    One input message: an external wrench or a release command.

    Attributes
    ----------
    time : float or None
        Simulated time at which it takes effect, s; None: as soon as it is
        received.
    kind : str
        'wrench' or 'release'.
    target : str
        The body (wrench) or joint (release) it names.
    force, torque : ndarray, shape (3,), or None
        N and N m (wrench only).
    frame_id : str
        The world frame (world axes) or the body (body axes); wrench only.
    header_ns : int or None
        The message's own header stamp as received, ns (wrench only).

    """

    time: Optional[float]
    kind: str
    target: str
    force: Optional[np.ndarray] = None
    torque: Optional[np.ndarray] = None
    frame_id: str = ''
    header_ns: Optional[int] = None


def wrench_input(body: str, force, torque, frame_id: str, *, time: Optional[float] = None,
                 header_ns: Optional[int] = None) -> Input:
    """Build an external wrench input (arrays copied as floats)."""
    return Input(time=time, kind='wrench', target=body,
                 force=np.array(force, dtype=float), torque=np.array(torque, dtype=float),
                 frame_id=frame_id, header_ns=header_ns)


def release_input(joint: str, *, time: Optional[float] = None) -> Input:
    """Build a release command."""
    return Input(time=time, kind='release', target=joint)


def input_topic(item: Input) -> str:
    """Topic of an input, relative to the namespace."""
    return 'release' if item.kind == 'release' else f'bodies/{item.target}/wrench'


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
                    header = decoded.header
                    found.append((message.log_time, wrench_input(
                        wrench['body'], [w.force.x, w.force.y, w.force.z],
                        [w.torque.x, w.torque.y, w.torque.z], header.frame_id,
                        header_ns=header.stamp.sec * 1_000_000_000 + header.stamp.nanosec)))
                elif RELEASE_TOPIC.match(channel.topic):
                    found.append((message.log_time, release_input(decoded.data.strip())))
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
    return [replace(item, time=max(0.0, (stamp_ns - start_ns) * 1e-9))
            for stamp_ns, item in found]


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


def validate_input(sim, item: Input):
    """
    Check that an input can take effect on sim now.

    Raises
    ------
    ValueError
        With the reason: unknown body, frame or joint, a fixed body,
        non-finite numbers, a joint already released.

    """
    model = sim.model
    if item.kind == 'release':
        names = [joint.name for joint in model.joints]
        if item.target not in names:
            raise ValueError(f'unknown joint {item.target!r} '
                             f'(joints: {", ".join(names) or "none"})')
        if not sim.active[names.index(item.target)]:
            raise ValueError(f'joint {item.target!r} is already released')
        return
    names = [body.name for body in model.bodies]
    if item.target not in names:
        raise ValueError(f'unknown body {item.target!r} (bodies: {", ".join(names)})')
    if item.frame_id not in (model.frame_id, item.target):
        raise ValueError(f'frame_id {item.frame_id!r} is neither the world frame '
                         f'{model.frame_id!r} nor the body {item.target!r}')
    if not (np.isfinite(item.force).all() and np.isfinite(item.torque).all()):
        raise ValueError('force and torque must be finite')
    if model.bodies[names.index(item.target)].fixed:
        raise ValueError(f'body {item.target!r} is fixed and cannot be loaded')


def apply_input(sim, item: Input):
    """Apply one input now (ValueError with the reason if it cannot be)."""
    validate_input(sim, item)
    if item.kind == 'wrench':
        sim.set_wrench(item.target, item.force, item.torque,
                       body_axes=(item.frame_id == item.target))
    else:
        sim.release(item.target, cause='command')
