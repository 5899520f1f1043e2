# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The node's /tf holds the carriers' view frames (where tf2_msgs is installed).

The pip wheels have no tf2_msgs, so the node's /tf is published only in a
ROS 2 install; here a stand-in TFMessage class lets the node's publishers be
built on a node that only collects what is published, and one /tf message
of a banked, turning carrier is checked against the recorder's numbers.
"""

import types

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.recording import viewframes, visuals
from cfem_ros.ros import publishers as cfem_publishers
import numpy as np
import pytest

SCENARIO = {
    'name': 'view_node', 'frame_id': 'world', 'gravity': [0.0, 0.0, 9.80665],
    'duration': 0.2, 'dt': 0.001,
    'bodies': {
        'aircraft': {'orientation_rpy_deg': [20, 15, 30],
                     'motion': {'velocity': [250, 0, 0], 'angular_velocity_deg': [0, 0, 10]},
                     'shape': {'box': [10, 8, 1]}},
        'store': {'mass': 100.0, 'inertia': [1, 5, 5], 'position': [0, 0, 1.0]},
    },
}


class _TFMessage:
    def __init__(self, transforms=()):
        self.transforms = list(transforms)


class _Node:
    """What _Publishers asks of a node: publishers that keep what they publish."""

    def __init__(self):
        self.published = {}

    def create_publisher(self, kind, topic, qos):
        sent = self.published.setdefault(topic, [])
        return types.SimpleNamespace(publish=lambda m: sent.append(
            [(t.header.frame_id, t.child_frame_id, t.transform.translation.z,
              t.transform.rotation.z, t.transform.rotation.w) for t in m.transforms]
            if topic == '/tf' else m))

    def get_namespace(self):
        return '/cfem'


@pytest.fixture
def publishers(monkeypatch):
    pytest.importorskip('geometry_msgs.msg')
    from geometry_msgs.msg import TransformStamped
    monkeypatch.setattr(cfem_publishers, 'TFMessage', _TFMessage)
    monkeypatch.setattr(cfem_publishers, 'TransformStamped', TransformStamped, raising=False)
    sim = Simulator(parse_scenario(SCENARIO))
    node = _Node()
    return cfem_publishers.Publishers(node, sim), node, sim


def test_the_node_s_tf_holds_the_view_frames(publishers):
    out, node, sim = publishers
    sim.advance_to(0.1)
    out.sample()
    (sent,) = node.published['/tf']
    assert [(parent, child) for parent, child, *_ in sent] == [
        ('world', 'aircraft'), ('world', 'store'), ('map', 'aircraft_view'),
        ('map', 'store_chase')]
    expected = viewframes.view_poses(visuals.up_rotation(sim.model.gravity),
                                     sim.position[:1], sim.orientation[:1])[0]
    _, _, z, qz, qw = sent[2]
    np.testing.assert_allclose([z, qz, qw], expected[[2, 5, 6]], rtol=0, atol=1e-15)
    assert abs(qz) > 0.1   # the carrier's heading, turned into the z-up root
    # the store's chase frame: at its CG (z up), turned as the carrier's view frame
    _, _, z, qz_chase, qw_chase = sent[3]
    chase = viewframes.state_poses(sim.model, sim.position, sim.orientation)[1]
    np.testing.assert_allclose([z, qz_chase, qw_chase], chase[[2, 5, 6]], rtol=0, atol=1e-15)
    assert (qz_chase, qw_chase) == (qz, qw)
