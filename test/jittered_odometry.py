# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Publish a carrier's live odometry, stamped at its measurement times, with jittered arrival.

A process of its own (the node test starts it): a 2 g pull-up at 250 m/s
(the same as test_player's log), one message every ``PERIOD_NS`` stamped
with the ROS time of its measurement, each sent 0-30 ms after its stamp
(random, seeded), in stamp order as one DDS writer delivers them. It starts
once the node subscribes, sends ``--count`` messages and exits.

Usage: python jittered_odometry.py NAMESPACE BODY COUNT SEED
"""

import sys
import time

from nav_msgs.msg import Odometry
import numpy as np
import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from scipy.spatial.transform import Rotation

SPEED = 250.0
RATE = -9.80665 / SPEED   # pitch rate of a 2 g pull-up, rad/s
PERIOD_NS = 20_000_000   # 50 Hz
LATEST_DELAY = 0.030   # s


def odometry(t: float, stamp_ns: int, body: str) -> Odometry:
    """Return the pull-up at t s (since the stream began), stamped stamp_ns."""
    msg = Odometry()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    msg.header.frame_id, msg.child_frame_id = 'world', body
    phi = RATE * t
    p = msg.pose.pose.position
    p.x, p.y, p.z = SPEED / RATE * np.sin(phi), 0.0, SPEED / RATE * (np.cos(phi) - 1)
    q = msg.pose.pose.orientation
    q.x, q.y, q.z, q.w = (float(c) for c in Rotation.from_rotvec([0, phi, 0]).as_quat())
    msg.twist.twist.linear.x = SPEED
    msg.twist.twist.angular.y = RATE
    return msg


def main(namespace: str, body: str, count: int, seed: int) -> int:
    rclpy.init()
    node = rclpy.create_node('jittered_odometry')
    publisher = node.create_publisher(
        Odometry, f'{namespace}/bodies/{body}/odom',
        QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                   durability=DurabilityPolicy.VOLATILE))
    deadline = time.monotonic() + 120.0
    while publisher.get_subscription_count() == 0:
        if time.monotonic() > deadline:
            print('no subscriber', file=sys.stderr)
            return 1
        time.sleep(0.01)
    rng = np.random.default_rng(seed)
    clock = node.get_clock()
    first = clock.now().nanoseconds
    sent, lag = 0, 0
    for k in range(count):
        stamp = first + k * PERIOD_NS
        # arrival: 0-30 ms after the measurement, never before the message before it
        send_at = max(stamp + int(rng.uniform(0.0, LATEST_DELAY) * 1e9), sent)
        while clock.now().nanoseconds < send_at:
            time.sleep(0.0005)
        publisher.publish(odometry(k * PERIOD_NS / 1e9, stamp, body))
        sent = clock.now().nanoseconds
        lag = max(lag, sent - stamp)
    print(f'largest send lag {lag / 1e9:.6f} s')   # beyond 30 ms: this process was held up
    print(f'last stamp {stamp}')
    time.sleep(0.5)   # reliable: delivered before this writer goes
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])))
