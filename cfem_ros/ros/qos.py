# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The node's QoS profiles, made from the output schema's (``recording.schema``)."""

from cfem_ros.recording import schema
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy


def profile(qos: schema.Qos) -> QoSProfile:
    """Return the rclpy profile of a schema QoS: reliable, keep last, volatile or latched."""
    return QoSProfile(depth=qos.depth, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL if qos.latched
                      else DurabilityPolicy.VOLATILE)


#: Outputs: what ``ros2 topic pub``, ``ros2 topic echo`` and
#: ``ros2 bag play`` use by default (reliable, volatile, keep last 10).
TOPIC_QOS = profile(schema.OUTPUT_QOS)


def input_qos(depth: int) -> QoSProfile:
    """Return the inputs' profile: reliable, volatile, keep the last depth (SPEC section 3)."""
    return QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)


#: /clock: best effort, as ``ros2 bag play --clock`` and rclpy publish it. A busy
#: node keeps the last 100 (1 s of a player's): a command is timed by the /clock its
#: sender published before it (``stamps.ClockLog``), which must not have been lost.
CLOCK_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT)
