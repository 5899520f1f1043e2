# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
``cfem_pub``: send the node a release command or a wrench, without ``ros2``.

The pip-installed ROS 2 wheels have no ``ros2`` command; this is the one-line
equivalent of ``ros2 topic pub --once`` for the node's two input topics::

    cfem_pub release pivot
    cfem_pub release fwd_hook aft_hook          # one message: one instant
    cfem_pub release station_1                  # a release group
    cfem_pub wrench store --force 0 0 -5000 --frame world
    cfem_pub wrench store --force 0 0 -5000 --frame store@0.18,0,-0.25

It waits (``--wait`` seconds) for the node's subscription to match and
publishes once with the node's QoS. Several names go in one message (names
apart), which the node releases at one step boundary. A release waits for
the node's events on ``events`` and prints them (exit status 1 if a name
gets none: the node refused it).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

from cfem_ros.core.engine.events import Event
from cfem_ros.core.run.inputs import parse_frame_id
from cfem_ros.recording import schema
from cfem_ros.ros.qos import TOPIC_QOS
from geometry_msgs.msg import PoseStamped, WrenchStamped
import rclpy
from std_msgs.msg import String

#: Seconds to stay after publishing a wrench (ros2 topic pub --once keeps 0.1 s).
KEEP_ALIVE = 0.3
#: Seconds to wait for the node's release event by default (``--confirm``): generous, for a
#: node that runs behind real time on a busy machine, or follows a /clock that is slower.
RELEASE_CONFIRMATION = 10.0
#: Seconds to wait for a pose of the body, whose frame_id is the world frame.
POSE_WAIT = 2.0


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser of cfem_pub."""
    parser = argparse.ArgumentParser(
        prog='cfem_pub', description="Publish one message on a cfem_node's input topic.")
    parser.add_argument('--ns', default='/cfem', help="the node's namespace (default /cfem)")
    parser.add_argument('--wait', type=float, default=10.0, metavar='S',
                        help='seconds to wait for the node to subscribe (default 10)')
    sub = parser.add_subparsers(dest='command', required=True, metavar='COMMAND')
    release = sub.add_parser('release', help='release joints or release groups now, '
                             'in one instant')
    release.add_argument('joint', nargs='+', metavar='NAME',
                         help='a joint or a release group (several: released together)')
    release.add_argument('--confirm', type=float, default=RELEASE_CONFIRMATION, metavar='S',
                         help='seconds to wait for the release events (default '
                         f'{RELEASE_CONFIRMATION:g}): a node behind real time, or following '
                         '/clock, releases when its simulation gets there')
    wrench = sub.add_parser('wrench', help='hold an external force and moment on a body')
    wrench.add_argument('body', help='the body to load')
    wrench.add_argument('--force', type=float, nargs=3, default=[0.0] * 3,
                        metavar=('FX', 'FY', 'FZ'), help='N (default 0 0 0)')
    wrench.add_argument('--torque', type=float, nargs=3, default=[0.0] * 3,
                        metavar=('MX', 'MY', 'MZ'), help='N m, about the CG (default 0 0 0)')
    wrench.add_argument('--frame', default='world',
                        help='the world frame (world axes, default "world") or the body '
                        '(body axes); either followed by @x,y,z applies the force at that '
                        'point (body axes, from the CG, m), e.g. store@0.18,0,-0.25')
    wrench.add_argument('--stamp', type=float, default=0.0, metavar='SEC',
                        help='header stamp, s; with use_sim_time the node applies the wrench '
                        'at that time (default 0: on receipt)')
    return parser


#: Largest header stamp, s (the stamp's seconds are an int32).
MAX_STAMP = 2.0 ** 31 - 1
#: Longest --wait, s (a day).
MAX_WAIT = 86400.0


def _refusal(args, topic: str):
    """Return why the arguments cannot be published (None if they can), before ROS starts."""
    if not (math.isfinite(args.wait) and 0.0 <= args.wait <= MAX_WAIT):
        return f'--wait: is {args.wait:g}; expected seconds from 0 to {MAX_WAIT:g}'
    if args.command == 'release' and not (math.isfinite(args.confirm)
                                          and 0.0 <= args.confirm <= MAX_WAIT):
        return (f'release: --confirm: is {args.confirm:g}; expected seconds from 0 to '
                f'{MAX_WAIT:g}')
    if args.command == 'wrench' and not (math.isfinite(args.stamp)
                                         and 0.0 <= args.stamp <= MAX_STAMP):
        return (f'wrench: --stamp: is {args.stamp:g}; expected seconds from 0 to '
                f'{MAX_STAMP:.0f} (a ROS time; 0: on receipt)')
    from rclpy.exceptions import InvalidTopicNameException
    from rclpy.validate_full_topic_name import validate_full_topic_name
    try:
        validate_full_topic_name(topic if topic.startswith('/') else '/' + topic)
    except InvalidTopicNameException as err:
        reason = str(err).splitlines()[0].replace('Invalid topic name: ', '')
        return (f'the topic {topic!r} (from --ns and the body) is not a ROS 2 name: '
                f'{reason.rstrip(":")}; expected names of letters, digits and _')
    return None


def _message(args):
    if args.command == 'release':
        return String, schema.RELEASE_INPUT.relative(), String(data=' '.join(args.joint))
    msg = WrenchStamped()
    sec, nanosec = divmod(int(round(args.stamp * 1e9)), 1_000_000_000)
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
    msg.header.frame_id = args.frame
    force, torque = msg.wrench.force, msg.wrench.torque
    force.x, force.y, force.z = args.force
    torque.x, torque.y, torque.z = args.torque
    return WrenchStamped, schema.WRENCH_INPUT.relative(body=args.body), msg


def main(argv=None) -> int:
    """Publish once; return 0, 1 if no node listened or a release had no event, 2 if refused."""
    args = build_parser().parse_args(argv)
    if args.command == 'wrench' and not all(map(math.isfinite, args.force + args.torque)):
        print(f'ERROR: wrench: force {args.force} and torque {args.torque} must be finite; '
              'the node would refuse it; nothing published', file=sys.stderr)
        return 2
    frame = None
    if args.command == 'wrench':
        try:
            frame, _ = parse_frame_id(args.frame)
        except ValueError as err:
            print(f'ERROR: wrench: --frame: {err}; the node would refuse it; nothing '
                  'published', file=sys.stderr)
            return 2
    namespace = args.ns.rstrip('/')
    topic = (schema.RELEASE_INPUT.absolute(namespace) if args.command == 'release'
             else schema.WRENCH_INPUT.absolute(namespace, body=args.body))
    refused = _refusal(args, topic)
    if refused:
        print(f'ERROR: {refused}; nothing published', file=sys.stderr)
        return 2
    kind, _, msg = _message(args)
    rclpy.init()
    try:
        node = rclpy.create_node('cfem_pub')
        publisher = node.create_publisher(kind, topic, TOPIC_QOS)
        events = []
        if args.command == 'release':
            node.create_subscription(String, schema.EVENTS.absolute(namespace),
                                     lambda m: events.append(json.loads(m.data)), TOPIC_QOS)
        if not _spin_until(node, lambda: publisher.get_subscription_count() > 0, args.wait):
            print(f'ERROR: nothing subscribes to {topic} after {args.wait:g} s; is cfem_node '
                  'running, with the same ROS_DOMAIN_ID and namespace?', file=sys.stderr)
            return 1
        if args.command == 'wrench' and frame != args.body:
            # the world frame is that of the body's poses
            poses = []
            node.create_subscription(PoseStamped, schema.POSE.absolute(namespace, body=args.body),
                                     poses.append, TOPIC_QOS)
            if _spin_until(node, lambda: poses, min(args.wait, POSE_WAIT)):
                world = poses[0].header.frame_id
                if frame != world:
                    print(f'ERROR: wrench: --frame {args.frame!r} is neither the world frame '
                          f'{world!r} nor the body {args.body!r} (optionally followed by '
                          '@x,y,z); the node would refuse it; nothing published',
                          file=sys.stderr)
                    return 2
            else:
                print(f'warning: no pose of {args.body!r} within {POSE_WAIT:g} s; frame '
                      f'{args.frame!r} not checked', file=sys.stderr)
        publisher.publish(msg)
        print(f'published on {topic}: {msg}')
        if args.command != 'release':
            # like ros2 topic pub --once: stay a moment so that the message leaves
            _spin_until(node, lambda: False, KEEP_ALIVE)
            return 0
        names = list(dict.fromkeys(args.joint))

        def confirmed():
            return [e for e in events if e.get('event') == Event.RELEASE
                    and (e.get('joint') in names or e.get('group') in names)]

        def answered(name):
            return any(name in (e.get('joint'), e.get('group')) for e in confirmed())

        _spin_until(node, lambda: all(map(answered, names)), args.confirm)
        # the rest of a group's joints come in the same instant
        _spin_until(node, lambda: False, KEEP_ALIVE)
        for event in confirmed():
            print(f'{namespace}/events: {json.dumps(event)}')
        missing = [name for name in names if not answered(name)]
        if not missing:
            return 0
        print(f'ERROR: no release event for {", ".join(map(repr, missing))} within '
              f"{args.confirm:g} s (--confirm); the node's log says why (unknown joint or "
              'release group, or already released), or its simulation is not there yet',
              file=sys.stderr)
        return 1
    finally:
        rclpy.try_shutdown()


def _spin_until(node, condition, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        rclpy.spin_once(node, timeout_sec=0.02)
    return True


def entry_point():
    """Console script wrapper: exit with main's status."""
    sys.exit(main())


if __name__ == '__main__':
    entry_point()
