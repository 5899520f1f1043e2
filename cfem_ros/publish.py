# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
``cfem_pub``: send the node a release command or a wrench, without ``ros2``.

The pip-installed ROS 2 wheels have no ``ros2`` command; this is the one-line
equivalent of ``ros2 topic pub --once`` for the node's two input topics::

    cfem_pub release pivot
    cfem_pub wrench store --force 0 0 -5000 --frame world

It waits (``--wait`` seconds) for the node's subscription to match, publishes
once with the node's QoS and waits until the message is acknowledged.
"""

from __future__ import annotations

import argparse
import sys

from cfem_ros.node import TOPIC_QOS
from geometry_msgs.msg import WrenchStamped
import rclpy
from rclpy.duration import Duration
from std_msgs.msg import String


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser of cfem_pub."""
    parser = argparse.ArgumentParser(
        prog='cfem_pub', description="Publish one message on a cfem_node's input topic.")
    parser.add_argument('--ns', default='/cfem', help="the node's namespace (default /cfem)")
    parser.add_argument('--wait', type=float, default=10.0, metavar='S',
                        help='seconds to wait for the node to subscribe (default 10)')
    sub = parser.add_subparsers(dest='command', required=True, metavar='COMMAND')
    release = sub.add_parser('release', help='release a joint now')
    release.add_argument('joint', help='the joint to release')
    wrench = sub.add_parser('wrench', help='hold an external force and moment on a body')
    wrench.add_argument('body', help='the body to load')
    wrench.add_argument('--force', type=float, nargs=3, default=[0.0] * 3,
                        metavar=('FX', 'FY', 'FZ'), help='N (default 0 0 0)')
    wrench.add_argument('--torque', type=float, nargs=3, default=[0.0] * 3,
                        metavar=('MX', 'MY', 'MZ'), help='N m, about the CG (default 0 0 0)')
    wrench.add_argument('--frame', default='world',
                        help='the world frame (world axes, default "world") or the body '
                        '(body axes)')
    wrench.add_argument('--stamp', type=float, default=0.0, metavar='SEC',
                        help='header stamp, s; with use_sim_time the node applies the wrench '
                        'at that time (default 0: on receipt)')
    return parser


def _message(args):
    if args.command == 'release':
        return String, 'release', String(data=args.joint)
    msg = WrenchStamped()
    sec, nanosec = divmod(int(round(args.stamp * 1e9)), 1_000_000_000)
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
    msg.header.frame_id = args.frame
    force, torque = msg.wrench.force, msg.wrench.torque
    force.x, force.y, force.z = args.force
    torque.x, torque.y, torque.z = args.torque
    return WrenchStamped, f'bodies/{args.body}/wrench', msg


def main(argv=None) -> int:
    """Publish once; return 0, or 1 if no node listened within --wait seconds."""
    args = build_parser().parse_args(argv)
    kind, relative, msg = _message(args)
    topic = f'{args.ns.rstrip("/")}/{relative}'
    rclpy.init()
    try:
        node = rclpy.create_node('cfem_pub')
        publisher = node.create_publisher(kind, topic, TOPIC_QOS)
        clock = node.get_clock()
        deadline = clock.now() + Duration(seconds=args.wait)
        while publisher.get_subscription_count() == 0:
            if clock.now() > deadline:
                print(f'ERROR: nothing subscribes to {topic} after {args.wait:g} s; is cfem_node '
                      'running, with the same ROS_DOMAIN_ID and namespace?', file=sys.stderr)
                return 1
            rclpy.spin_once(node, timeout_sec=0.05)
        publisher.publish(msg)
        if not publisher.wait_for_all_acked(Duration(seconds=5.0)):
            print(f'ERROR: {topic}: the message was not acknowledged within 5 s',
                  file=sys.stderr)
            return 1
        print(f'published on {topic}: {msg}')
        return 0
    finally:
        rclpy.try_shutdown()


def entry_point():
    """Console script wrapper: exit with main's status."""
    sys.exit(main())


if __name__ == '__main__':
    entry_point()
