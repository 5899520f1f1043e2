# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The node advertises the output schema's topics, types and QoS (issue 34).

A node is made in this process, following /clock (so that no run starts),
for a scenario with every kind of output; its publishers must be the
schema's topics of the model (``schema.run_topics``), the topics the
recorder writes for the same model (``test/recording/test_schema.py``).
"""

import pathlib

from cfem_ros.core.engine.aero import AIR_TOPICS
from cfem_ros.recording import schema
from cfem_ros.ros import publishers
from cfem_ros.ros.node import CfemNode
from cfem_ros.ros.qos import profile
import pytest
import rclpy
from rclpy.signals import SignalHandlerOptions

SCENARIO = pathlib.Path(__file__).resolve().parents[2] / 'config' / 'store_release_near_pylon.yaml'
#: What every rclpy node publishes.
ROS_OWN = {'/rosout', '/parameter_events'}


@pytest.fixture
def node():
    context = rclpy.Context()
    rclpy.init(args=['--ros-args', '-p', f'scenario:={SCENARIO}', '-p', 'use_sim_time:=true'],
               context=context, signal_handler_options=SignalHandlerOptions.NO)
    made = None
    try:
        made = CfemNode(context=context)
        yield made
    finally:
        if made is not None:
            made.close()
            made.destroy_node()
        rclpy.try_shutdown(context=context)


def test_the_node_advertises_the_schema_s_topics(node):
    sim = node.sim
    expected = schema.run_topics(sim.model, sim.applied_sources, node.get_namespace(),
                                 [name for name, _ in AIR_TOPICS])
    assert {id(t) for t in expected.values()} == {id(t) for t in schema.OUTPUTS}
    if publishers.TFMessage is None:   # no tf2_msgs in this install: the node sends no tf
        expected = {k: t for k, t in expected.items() if t.msgtype != schema.TF_TYPE}
    advertised = {p.topic_name: p for p in node.publishers if p.topic_name not in ROS_OWN}
    assert set(advertised) == set(expected)
    for name, topic in expected.items():
        kind = advertised[name].msg_type
        assert f"{kind.__module__.split('.')[0]}/msg/{kind.__name__}" == topic.msgtype, name
        qos, wanted = advertised[name].qos_profile, profile(topic.qos)
        assert (qos.depth, qos.durability, qos.reliability) == (
            wanted.depth, wanted.durability, wanted.reliability), name
