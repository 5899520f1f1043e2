# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
MCAP recordings in the ros2 profile (SPEC section 4), without rclpy.

``Recorder`` is the container layer (schemas, channels with their QoS,
messages, statistics and indexes through the ``mcap`` writer, CDR through
``mcap_ros2``); ``StateRecorder`` turns a simulator's arrays into the
messages of SPEC section 3.
"""

from __future__ import annotations

import json
import os
from typing import Optional

from cfem_ros import __version__
from cfem_ros.errors import RecordingError
from cfem_ros.msgdefs import DEFINITIONS
import mcap
from mcap.writer import CompressionType, Writer
from mcap_ros2._dynamic import serialize_dynamic
import numpy as np

POSE = 'geometry_msgs/msg/PoseStamped'
TWIST = 'geometry_msgs/msg/TwistStamped'
WRENCH = 'geometry_msgs/msg/WrenchStamped'
STRING = 'std_msgs/msg/String'

#: What the node offers (and rosbag2 would note): reliable, volatile, keep last 10.
OFFERED_QOS = (
    '- history: keep_last\n'
    '  depth: 10\n'
    '  reliability: reliable\n'
    '  durability: volatile\n'
    '  deadline:\n    sec: 9223372036\n    nsec: 854775807\n'
    '  lifespan:\n    sec: 9223372036\n    nsec: 854775807\n'
    '  liveliness: automatic\n'
    '  liveliness_lease_duration:\n    sec: 9223372036\n    nsec: 854775807\n'
    '  avoid_ros_namespace_conventions: false'
)
#: What the node offers on its events topic: transient local, keep last 100,
#: so that a late subscriber asking for it still gets the releases.
EVENTS_QOS = OFFERED_QOS.replace('depth: 10', 'depth: 100').replace(
    'durability: volatile', 'durability: transient_local')

#: Chunk size in bytes: small, so that a hard kill loses little.
CHUNK_SIZE = 64 * 1024


def stamp(stamp_ns: int) -> dict:
    """builtin_interfaces/Time of integer nanoseconds."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return {'sec': sec, 'nanosec': nanosec}


def seconds_to_ns(t: float) -> int:
    """Integer nanoseconds nearest to t seconds."""
    return int(round(t * 1e9))


def run_metadata(model, scenario: str, rate_hz: float, start_ns: int, **extra) -> dict:
    """Describe a run for its ``cfem_ros`` metadata record (what it is, where t = 0 is)."""
    return {'scenario': os.path.abspath(scenario), 'name': model.name,
            'start_stamp_ns': int(start_ns), 'dt': repr(model.dt), 'rate_hz': repr(rate_hz),
            'frame_id': model.frame_id,
            'gravity': '[' + ', '.join(repr(float(g)) for g in model.gravity) + ']', **extra}


def _vector(v) -> dict:
    return {'x': float(v[0]), 'y': float(v[1]), 'z': float(v[2])}


class Recorder:
    """
    Write one MCAP file in the ros2 profile.

    The file is complete (summary, statistics, indexes) once ``finish`` has
    run; use the recorder as a context manager so that it runs on errors too.

    Parameters
    ----------
    path : str
        The ``.mcap`` file to write.
    overwrite : bool
        Replace an existing file; without it an existing file is an error.
    metadata : dict of str to str, optional
        Written as an MCAP metadata record named ``cfem_ros``.

    """

    def __init__(self, path: str, *, overwrite: bool = False,
                 metadata: Optional[dict] = None):
        self.path = path
        directory = os.path.dirname(os.path.abspath(path))
        try:
            os.makedirs(directory, exist_ok=True)
            self._stream = open(path, 'wb' if overwrite else 'xb')
        except FileExistsError:
            raise RecordingError(
                f'{path}: already exists; pass --overwrite to replace it') from None
        except OSError as err:
            raise RecordingError(f'{path}: cannot write ({err.strerror})') from err
        self._writer = Writer(self._stream, chunk_size=CHUNK_SIZE,
                              compression=CompressionType.NONE)
        self._writer.start(profile='ros2',
                           library=f'cfem_ros {__version__}; mcap {mcap.__version__}')
        self._schemas = {}
        self._encoders = {}
        self._channels = {}
        self.message_count = 0
        self._finished = False
        if metadata:
            self.add_metadata(metadata)

    def add_metadata(self, metadata: dict):
        """Write a metadata record named ``cfem_ros`` (values as strings)."""
        self._writer.add_metadata('cfem_ros', {k: str(v) for k, v in metadata.items()})

    def channel(self, topic: str, msgtype: str, qos: str = OFFERED_QOS) -> tuple:
        """Register a topic's channel once, with its offered QoS; return (channel id, type)."""
        channel = self._channels.get(topic)
        if channel is not None:
            return channel
        if msgtype not in self._schemas:
            text = DEFINITIONS[msgtype]
            self._schemas[msgtype] = self._writer.register_schema(
                name=msgtype, encoding='ros2msg', data=text.encode())
            self._encoders[msgtype] = serialize_dynamic(msgtype, text)[msgtype]
        channel = self._writer.register_channel(
            topic=topic, message_encoding='cdr', schema_id=self._schemas[msgtype],
            metadata={'offered_qos_profiles': qos})
        self._channels[topic] = (channel, msgtype)
        return self._channels[topic]

    def write(self, topic: str, msgtype: str, message: dict, stamp_ns: int):
        """Encode and write one message; log and publish time = stamp_ns."""
        channel, kind = self.channel(topic, msgtype)
        data = self._encoders[kind](message)
        self._writer.add_message(channel_id=channel, log_time=int(stamp_ns),
                                 publish_time=int(stamp_ns), data=data,
                                 sequence=self.message_count)
        self.message_count += 1

    def finish(self):
        """Write the summary and close the file (idempotent)."""
        if self._finished:
            return
        self._finished = True
        try:
            self._writer.finish()
        finally:
            self._stream.close()

    def __enter__(self) -> 'Recorder':
        return self

    def __exit__(self, *exc_info):
        self.finish()


class StateRecorder:
    """
    Record a simulator's outputs and inputs as the node publishes them.

    Parameters
    ----------
    recorder : Recorder
    sim : Simulator
    namespace : str
        Prefix of every topic (SPEC section 3), '/cfem' by default.
    start_ns : int
        Stamp of simulated time 0, ns.

    """

    def __init__(self, recorder: Recorder, sim, namespace: str = '/cfem', start_ns: int = 0):
        self.recorder = recorder
        self.sim = sim
        self.namespace = namespace.rstrip('/')
        self.start_ns = int(start_ns)
        self.world = sim.model.frame_id
        model = sim.model
        self._pose_topics = [self.topic(f'bodies/{b.name}/pose') for b in model.bodies]
        self._twist_topics = [self.topic(f'bodies/{b.name}/twist') for b in model.bodies]
        self._wrench_topics = [self.topic(f'joints/{j.name}/wrench') for j in model.joints]
        self._events_written = 0

    def topic(self, relative: str) -> str:
        """Absolute topic name of a topic relative to the namespace."""
        return f'{self.namespace}/{relative}'

    def stamp_ns(self, t: float) -> int:
        """Stamp of simulated time t, ns."""
        return self.start_ns + seconds_to_ns(t)

    def sample(self):
        """Record poses, twists and active joints' wrenches at the current state."""
        sim = self.sim
        stamp_ns = self.stamp_ns(sim.t)
        when = stamp(stamp_ns)
        position, quat = sim.position, sim.orientation
        velocity, rates = sim.velocity_body(), sim.rates
        write = self.recorder.write
        for i, body in enumerate(sim.model.bodies):
            write(self._pose_topics[i], POSE, {
                'header': {'stamp': when, 'frame_id': self.world},
                'pose': {'position': _vector(position[i]),
                         'orientation': dict(zip('xyzw', map(float, quat[i])))},
            }, stamp_ns)
            write(self._twist_topics[i], TWIST, {
                'header': {'stamp': when, 'frame_id': body.name},
                'twist': {'linear': _vector(velocity[i]), 'angular': _vector(rates[i])},
            }, stamp_ns)
        if sim.active.any():
            force, moment = sim.joint_wrenches()
            for k in np.flatnonzero(sim.active):
                write(self._wrench_topics[k], WRENCH, {
                    'header': {'stamp': when, 'frame_id': self.world},
                    'wrench': {'force': _vector(force[k]), 'torque': _vector(moment[k])},
                }, stamp_ns)

    def events(self):
        """Record the simulator's events not yet recorded, at their own times."""
        topic = self.topic('events')
        for event in self.sim.events[self._events_written:]:
            self.recorder.channel(topic, STRING, qos=EVENTS_QOS)
            self.recorder.write(topic, STRING,
                                {'data': json.dumps(event)}, self.stamp_ns(event['time']))
        self._events_written = len(self.sim.events)

    def received(self, item, t: float):
        """
        Record an input as received, logged at the simulated time t it took effect.

        The log time is what ``cfem-sim run --inputs`` replays it at; a
        wrench's header keeps the stamp it arrived with (the log time if it
        had none).
        """
        stamp_ns = self.stamp_ns(t)
        if item.kind == 'release':
            self.recorder.write(self.topic('release'), STRING, {'data': item.target}, stamp_ns)
            return
        header_ns = stamp_ns if item.header_ns is None else item.header_ns
        self.recorder.write(self.topic(f'bodies/{item.target}/wrench'), WRENCH, {
            'header': {'stamp': stamp(header_ns), 'frame_id': item.frame_id},
            'wrench': {'force': _vector(item.force), 'torque': _vector(item.torque)},
        }, stamp_ns)
