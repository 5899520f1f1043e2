# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The air each body with aero tables sees, published by the node (SPEC section 10).

Four ``schema.AIR`` topics per body (``bodies/<body>/aero/<quantity>``, the
quantities of ``core.engine.aero.AIR_TOPICS``), ``frame_id`` = the body, from the
numbers a sample holds (``Simulator.air``), the same the recordings hold.
"""

from __future__ import annotations

from cfem_ros.core.engine.aero import AIR_TOPICS
from cfem_ros.recording import schema
from cfem_ros.ros.qos import profile
from geometry_msgs.msg import Vector3Stamped


class AirPublishers:
    """The aero topics of a node's simulator: created once, sent at each sample."""

    def __init__(self, node, sim):
        self.sim = sim
        self.topics = []   # per body with aero tables: (publisher, message) per topic
        for entry in sim.model.aero:
            body = sim.model.bodies[entry.body].name
            pairs = []
            for name, _ in AIR_TOPICS:
                message = Vector3Stamped()
                message.header.frame_id = schema.AIR.frame_id(body=body)
                pairs.append((node.create_publisher(
                    Vector3Stamped, schema.AIR.relative(body=body, quantity=name),
                    profile(schema.AIR.qos)), message))
            self.topics.append(pairs)

    def publish(self, stamp_ns: int, air):
        """Send every body's air (``Simulator.air`` of a sample's outputs), stamped stamp_ns."""
        if not self.topics:
            return
        sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
        for pairs, numbers in zip(self.topics, air):
            for k, (publisher, message) in enumerate(pairs):
                message.header.stamp.sec, message.header.stamp.nanosec = sec, nanosec
                v = message.vector
                v.x, v.y, v.z = (float(c) for c in numbers[3 * k:3 * k + 3])
                publisher.publish(message)
