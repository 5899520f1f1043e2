# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Publish a recording's messages over ROS 2, as ``ros2 bag play`` does (``cfem-sim play``).

Each message goes out as the CDR bytes it was recorded with, on a publisher
of its recorded type and QoS (the channel's ``offered_qos_profiles``, in
rosbag2's string or integer form), at its log time scaled by the rate; with
``clock``, ``/clock`` carries the log time (best effort, as ``ros2 bag play
--clock`` publishes it) before each message and every ``CLOCK_PERIOD`` of
log time between them, so that a node with ``use_sim_time`` follows the log.
"""

from __future__ import annotations

import importlib
import time
from typing import Callable, Optional

from cfem_ros.core.errors import ArgumentError
from cfem_ros.recording.errors import RecordingError
from cfem_ros.recording.reader import open_mcap
import rclpy
from rclpy.exceptions import NameValidationException
from rclpy.expand_topic_name import expand_topic_name
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.validate_full_topic_name import validate_full_topic_name
from rclpy.validate_topic_name import validate_topic_name
from rosgraph_msgs.msg import Clock
import yaml

#: Log time between two /clock messages when no message falls in between, s.
CLOCK_PERIOD = 0.01
#: With clock: log time /clock goes on past the last message, s (more than a node's
#: default input_window, 0.05 s, so that it simulates up to the log's end).
CLOCK_TAIL = 0.1
#: Wall-clock seconds the publishers stay after the last message.
LINGER = 0.5
#: QoS of /clock, as ``ros2 bag play --clock``.
CLOCK_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
#: When a channel has no readable QoS: what ``ros2 bag play`` uses by default.
DEFAULT_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)

_RELIABILITY = {1: ReliabilityPolicy.RELIABLE, 2: ReliabilityPolicy.BEST_EFFORT,
                'reliable': ReliabilityPolicy.RELIABLE,
                'best_effort': ReliabilityPolicy.BEST_EFFORT}
_DURABILITY = {1: DurabilityPolicy.TRANSIENT_LOCAL, 2: DurabilityPolicy.VOLATILE,
               'transient_local': DurabilityPolicy.TRANSIENT_LOCAL,
               'volatile': DurabilityPolicy.VOLATILE}
_HISTORY = {1: HistoryPolicy.KEEP_LAST, 2: HistoryPolicy.KEEP_ALL,
            'keep_last': HistoryPolicy.KEEP_LAST, 'keep_all': HistoryPolicy.KEEP_ALL}


def parse_qos(text: Optional[str]) -> QoSProfile:
    """
    Return the QoS of a channel's ``offered_qos_profiles`` (its first profile).

    rosbag2 writes a YAML list of profiles whose policies are integers (the
    rmw enums: reliability 1 reliable, 2 best effort; durability 1
    transient local, 2 volatile; history 1 keep last, 2 keep all) or, since
    Jazzy, their names. Anything unreadable gives ``DEFAULT_QOS``.
    """
    try:
        profiles = yaml.safe_load(text) if text else None
    except yaml.YAMLError:
        return DEFAULT_QOS
    if isinstance(profiles, dict):
        profiles = [profiles]
    if not isinstance(profiles, list) or not profiles or not isinstance(profiles[0], dict):
        return DEFAULT_QOS
    first = profiles[0]

    def policy(key, table, default):
        value = first.get(key)
        value = value.lower() if isinstance(value, str) else value
        return table.get(value, default)

    history = policy('history', _HISTORY, HistoryPolicy.KEEP_LAST)
    depth = first.get('depth')
    depth = depth if isinstance(depth, int) and depth > 0 else 10
    return QoSProfile(history=history, depth=depth,
                      reliability=policy('reliability', _RELIABILITY,
                                         ReliabilityPolicy.RELIABLE),
                      durability=policy('durability', _DURABILITY, DurabilityPolicy.VOLATILE))


def message_class(type_name: str):
    """Return the Python class of a ROS 2 message type 'pkg/msg/Name', or None."""
    parts = type_name.split('/')
    if len(parts) == 2:
        parts = [parts[0], 'msg', parts[1]]
    if len(parts) != 3 or not all(p.isidentifier() for p in parts):
        return None
    try:
        return getattr(importlib.import_module(f'{parts[0]}.{parts[1]}'), parts[2])
    except Exception:  # noqa: B902 - a message library that fails to load in any way
        return None


def topic_name_problem(name: str) -> Optional[str]:
    """Return why name is not a valid ROS 2 topic name (None if it is)."""
    try:
        validate_topic_name(name)
        validate_full_topic_name(expand_topic_name(name, 'cfem_player', '/'))
    except (NameValidationException, ValueError, RuntimeError) as err:
        return ' '.join(str(err).split())[:160]
    return None


def parse_remaps(remaps) -> dict:
    """Return {from: to} of ``FROM:=TO`` strings; ``ArgumentError`` for a malformed one."""
    out = {}
    for item in remaps or ():
        source, sep, target = item.partition(':=')
        if not sep or not source or not target:
            raise ArgumentError(f'--remap {item!r}; expected FROM:=TO (topic names)')
        problem = topic_name_problem(target)
        if problem:
            raise ArgumentError(f'--remap {item!r}: {target!r} is not a valid ROS 2 topic name '
                                f'({problem}); expected e.g. /flight/store/pose')
        out[source] = target
    return out


def read_log(path: str, topics=None) -> tuple:
    """
    Return a recording's channels and messages, in log time order.

    Returns
    -------
    channels : dict
        Channel id -> (topic, type name, QoS text).
    messages : list of (int, int, bytes)
        (log time ns, channel id, CDR bytes).

    Raises
    ------
    RecordingError
        If the file is missing or not a readable MCAP file.

    """
    with open_mcap(path) as reader:
        summary = reader.get_summary()
        if summary is None:
            raise RecordingError(f'{path}: MCAP file without a summary section; '
                                 'expected a finished recording')
        channels = {}
        for cid, channel in summary.channels.items():
            schema = summary.schemas.get(channel.schema_id)
            channels[cid] = (channel.topic, schema.name if schema else '',
                             channel.metadata.get('offered_qos_profiles', ''))
        wanted = None if not topics else list(topics)
        messages = [(message.log_time, channel.id, bytes(message.data))
                    for _, channel, message in reader.iter_messages(
                        topics=wanted, log_time_order=True)]
    return channels, messages


def play(path: str, *, clock: bool = False, rate: float = 1.0, topics=None, remaps=None,
         node: Optional[Node] = None, log: Callable[[str], None] = print,
         wait: float = 5.0, delay: float = 2.0, settle: float = 0.1) -> int:
    """
    Publish a recording's messages; return how many were published.

    Parameters
    ----------
    path : str
        The MCAP recording.
    clock : bool
        Publish ``/clock`` with the log time.
    rate : float
        Playback speed (2: twice as fast), > 0.
    topics : list of str, optional
        Only these topics (as recorded, before remapping).
    remaps : dict, optional
        Recorded topic -> topic to publish on.
    node : rclpy Node, optional
        Publish from this node (rclpy initialised by the caller); else one is made.
    log : callable
        Where warnings (a type that cannot be imported) go.
    wait : float
        Wall-clock seconds to wait at most for every publisher to have a
        subscriber (discovery) before the first message.
    delay : float
        Wall-clock seconds between discovery and the first message (both
        ends see each other only after a while); with ``clock``, /clock at
        the first message's time is sent every 50 ms meanwhile.
    settle : float
        With ``clock``: wall-clock seconds between a /clock message at a
        message's log time and the message, so that a node following the
        clock has reached that time when the message arrives (a command
        applied on arrival then acts at its recorded time), and again
        between the message and the next /clock (the playback's wall time
        is that much longer). Only for messages without a header: a stamped
        one acts at its stamp, so a 100 Hz odometry stream plays at its own
        pace.

    """
    if not rate > 0.0:
        raise ArgumentError(f'--rate {rate!r}; expected a speed > 0')
    channels, messages = read_log(path, topics)
    remaps = remaps or {}
    own = node is None
    if own:
        # not the command line: rcl would read --remap FROM:=TO as its own deprecated form
        rclpy.init(args=[])
        node = rclpy.create_node('cfem_player')
    try:
        publishers, skipped, unstamped = {}, set(), set()
        by_topic = {}
        for cid, (topic, type_name, qos) in channels.items():
            if topics and topic not in topics:
                continue
            cls = message_class(type_name)
            if cls is None:
                skipped.add(cid)
                log(f'{path}: {topic}: type {type_name!r} is not importable here; not played')
                continue
            target = remaps.get(topic, topic)
            key = (target, type_name)
            if key not in by_topic:
                problem = topic_name_problem(target)
                if problem:
                    skipped.add(cid)
                    log(f'{path}: topic {target!r} is not a valid ROS 2 topic name '
                        f'({problem}); not played (--remap it to a valid name)')
                    continue
                try:
                    by_topic[key] = node.create_publisher(cls, target, parse_qos(qos))
                except Exception as err:  # noqa: B902 - type support that does not load
                    skipped.add(cid)
                    log(f'{path}: {target}: no publisher of type {type_name!r} here '
                        f'({type(err).__name__}: {" ".join(str(err).split())[:120]}); '
                        'not played')
                    continue
            publishers[cid] = by_topic[key]
            if 'header' not in cls.get_fields_and_field_types():
                unstamped.add(cid)
        clock_pub = node.create_publisher(Clock, '/clock', CLOCK_QOS) if clock else None
        messages = [m for m in messages if m[1] in publishers]
        if not messages:
            return 0
        first = messages[0][0]
        tick = Clock()

        def send_clock(ns):
            tick.clock.sec, tick.clock.nanosec = divmod(int(ns), 1_000_000_000)
            clock_pub.publish(tick)

        deadline = time.monotonic() + wait
        watched = list(by_topic.values()) + ([clock_pub] if clock_pub is not None else [])
        while (time.monotonic() < deadline
               and not all(p.get_subscription_count() > 0 for p in watched)):
            time.sleep(0.02)
        deadline = time.monotonic() + delay
        while True:
            if clock_pub is not None:
                send_clock(first)
            if time.monotonic() >= deadline:
                break
            time.sleep(min(0.05, max(0.0, deadline - time.monotonic())))
        time.sleep(settle)
        start = time.monotonic()
        last_clock, settled = first, True   # the first clock was settled above
        period = int(CLOCK_PERIOD * 1e9)
        for log_time, cid, data in messages:
            if clock_pub is not None:
                while last_clock + period < log_time:
                    last_clock += period
                    _sleep_until(start + (last_clock - first) * 1e-9 / rate)
                    send_clock(last_clock)
            _sleep_until(start + (log_time - first) * 1e-9 / rate)
            if clock_pub is not None and log_time != last_clock:
                send_clock(log_time)
                last_clock, settled = log_time, False
            if clock_pub is not None and cid in unstamped:
                # the command alone between two /clock messages, settle apart from both: a
                # node that takes /clock first times it by the /clock before it
                held = time.monotonic()
                if not settled:
                    time.sleep(settle)
                publishers[cid].publish(data)
                time.sleep(settle)
                start += time.monotonic() - held   # the log's times keep their spacing
                settled = True
                continue
            publishers[cid].publish(data)
        if clock_pub is not None:   # a node input_window behind /clock reaches the log's end
            while last_clock < log_time + int(CLOCK_TAIL * 1e9):
                last_clock += period
                _sleep_until(start + (last_clock - first) * 1e-9 / rate)
                send_clock(last_clock)
        time.sleep(LINGER)   # reliable messages still in flight reach their readers
        return len(messages)
    finally:
        if own:
            node.destroy_node()
            rclpy.try_shutdown()


def _sleep_until(when: float):
    delay = when - time.monotonic()
    if delay > 0:
        time.sleep(delay)
