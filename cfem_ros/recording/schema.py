# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The outputs of a run (SPEC section 3): every topic, its type, frame, QoS and period, once.

The node's publishers (``cfem_ros/ros``), the recorder (``StateRecorder``) and
the readers (``analysis``, ``airtracks``, ``summary``, ``replay``) name
topics only through this table, so a topic, a type or a period is changed
here and nowhere else. Plain data: no rclpy, no mcap.

A topic's ``name`` is relative to the node's namespace (``/cfem`` by
default) unless it starts with ``/``; ``{body}``, ``{joint}``, ``{source}``
and ``{quantity}`` stand for a body's, a joint's, a load source's and an air
quantity's name. A ``frame`` names the ``header.frame_id`` the same way,
``{world}`` being the scenario's ``frame_id`` and ``{reference}`` the body a
relative pose is measured from.
"""

from __future__ import annotations

from dataclasses import dataclass
import functools
import math
import re
from typing import Optional

#: ROS 2 message types, as recordings and ``ros2 topic`` spell them.
POSE_TYPE = 'geometry_msgs/msg/PoseStamped'
TWIST_TYPE = 'geometry_msgs/msg/TwistStamped'
WRENCH_TYPE = 'geometry_msgs/msg/WrenchStamped'
VECTOR3_TYPE = 'geometry_msgs/msg/Vector3Stamped'
STRING_TYPE = 'std_msgs/msg/String'
ODOMETRY_TYPE = 'nav_msgs/msg/Odometry'
TF_TYPE = 'tf2_msgs/msg/TFMessage'
MARKERS_TYPE = 'visualization_msgs/msg/MarkerArray'


@dataclass(frozen=True)
class Qos:
    """
    What a topic is offered with: reliable, keep last ``depth``.

    ``latched``: transient local (a late subscriber asking for it gets the
    last ``depth`` messages), else volatile.
    """

    depth: int
    latched: bool = False


#: Outputs and inputs: what ``ros2 topic pub``, ``echo`` and ``bag play`` use by default.
OUTPUT_QOS = Qos(10)
#: Events: kept for late joiners that ask for transient local.
EVENTS_QOS = Qos(100, latched=True)
#: /tf_static and the markers, as tf2's static broadcaster offers them.
LATCHED_QOS = Qos(1, latched=True)
#: tf2's own QoS for /tf.
TF_QOS = Qos(100)


@dataclass(frozen=True)
class Topic:
    """
    One topic of a run.

    Attributes
    ----------
    name : str
        Relative to the namespace, or absolute if it starts with '/'; with
        ``{body}``-style fields.
    msgtype : str
        Its message type.
    frame : str or None
        The messages' ``header.frame_id``; None for a message without a
        header (or one per marker or transform, see the topic's comment).
    qos : Qos
        What the node offers it with.
    recorded_qos : Qos or None
        What a recording says the node offers, if not ``qos``.
    period : float or None
        Simulated seconds between two sendings, for the topics not sent at
        every sample nor as things happen.

    """

    name: str
    msgtype: str
    frame: Optional[str] = None
    qos: Qos = OUTPUT_QOS
    recorded_qos: Optional[Qos] = None
    period: Optional[float] = None

    @property
    def in_recording(self) -> Qos:
        """Return the QoS a recording gives the topic."""
        return self.recorded_qos or self.qos

    def relative(self, **names) -> str:
        """Return the topic of these names relative to the namespace (or absolute, if it is)."""
        return self.name.format(**names)

    def absolute(self, namespace: str, **names) -> str:
        """Return the topic of these names under namespace (e.g. '/cfem')."""
        if self.name.startswith('/'):
            return self.relative(**names)
        return f"{namespace.rstrip('/')}/{self.relative(**names)}"

    def frame_id(self, **names) -> str:
        """Return the ``header.frame_id`` of these names (``world=`` the scenario's frame)."""
        return self.frame.format(**names)

    @property
    def pattern(self) -> re.Pattern:
        """
        Return a regular expression of the topic under any namespace.

        Its groups: ``ns`` (the namespace, '' at the root) and one per field
        of the name.
        """
        return _pattern(self.name)


@functools.lru_cache(maxsize=None)   # a reader asks for each message: built once per topic
def _pattern(name: str) -> re.Pattern:
    parts = re.split(r'\{(\w+)\}', name)
    text = ''.join(re.escape(p) if i % 2 == 0 else f'(?P<{p}>[^/]+)'
                   for i, p in enumerate(parts))
    return re.compile('^' + (text if name.startswith('/') else '(?P<ns>.*)/' + text) + '$')


# ---------------------------------------------------------------- outputs, per sample

#: A body's pose in the scenario's frame.
POSE = Topic('bodies/{body}/pose', POSE_TYPE, '{world}')
#: A body's velocity and rates, in its own axes.
TWIST = Topic('bodies/{body}/twist', TWIST_TYPE, '{body}')
#: A joint's load on its child body, in the joint's axes (SPEC sections 3 and 5).
JOINT_WRENCH = Topic('joints/{joint}/wrench', WRENCH_TYPE, '{joint}')
#: The same in world axes.
JOINT_WRENCH_WORLD = Topic('joints/{joint}/wrench_world', WRENCH_TYPE, '{world}')
#: A scheduled load on a body (its ``loads:`` or aero source), in the body's axes.
APPLIED = Topic('bodies/{body}/applied/{source}', WRENCH_TYPE, '{body}')
#: The same in world axes.
APPLIED_WORLD = Topic('bodies/{body}/applied_world/{source}', WRENCH_TYPE, '{world}')
#: The air a body with aero tables sees (SPEC section 10); quantity: ``aero.AIR_TOPICS``.
AIR = Topic('bodies/{body}/aero/{quantity}', VECTOR3_TYPE, '{body}')
#: A body's pose and twist in its reference's (carrier's) frame.
RELATIVE_POSE = Topic('bodies/{body}/relative_pose', POSE_TYPE, '{reference}')
RELATIVE_TWIST = Topic('bodies/{body}/relative_twist', TWIST_TYPE, '{reference}')
#: The moving bodies' frames (from ``{world}``) and the carriers' z-up view
#: frames (``viewframes``): one transform per child, each with its own parent.
TF = Topic('/tf', TF_TYPE, qos=TF_QOS, recorded_qos=OUTPUT_QOS)

# ---------------------------------------------------------------- outputs, now and then

#: Releases, contacts, stroke ends, the node's own notes, errors: JSON strings.
EVENTS = Topic('events', STRING_TYPE, qos=EVENTS_QOS)
#: The fixed bodies' frames, once at the start.
TF_STATIC = Topic('/tf_static', TF_TYPE, qos=LATCHED_QOS)
#: The bodies' and joints' shapes, each marker on its body's frame: at the
#: start, at releases and contacts, and every ``period`` for viewers that
#: subscribe late with volatile durability (RViz's default).
MARKERS = Topic('markers', MARKERS_TYPE, qos=LATCHED_QOS, period=1.0)
#: The loads drawn as arrows (``loadarrows``), every ``period``.
LOAD_MARKERS = Topic('load_markers', MARKERS_TYPE)   # every sample, and at load events

# ---------------------------------------------------------------- inputs (recorded as received)

#: A wrench on a body, in the header's frame.
WRENCH_INPUT = Topic('bodies/{body}/wrench', WRENCH_TYPE)
#: A kinematic body's measured motion.
ODOMETRY_INPUT = Topic('bodies/{body}/odom', ODOMETRY_TYPE)
#: Joint or group names to release now.
RELEASE_INPUT = Topic('release', STRING_TYPE)

#: Every topic above.
OUTPUTS = (POSE, TWIST, JOINT_WRENCH, JOINT_WRENCH_WORLD, APPLIED, APPLIED_WORLD, AIR,
           RELATIVE_POSE, RELATIVE_TWIST, TF, EVENTS, TF_STATIC, MARKERS, LOAD_MARKERS)
INPUTS = (WRENCH_INPUT, ODOMETRY_INPUT, RELEASE_INPUT)


def run_topics(model, applied_sources, namespace: str, air_quantities=()) -> dict:
    """
    Return every output topic of a run of model: absolute topic -> its ``Topic``.

    applied_sources: the simulator's (body, source) pairs; air_quantities:
    the names of ``aero.AIR_TOPICS``. Load arrows and /tf are listed only
    when some body moves (nothing to draw or to move otherwise).
    """
    out = {}

    def add(topic: Topic, **names):
        out[topic.absolute(namespace, **names)] = topic

    bodies = model.bodies
    for body in bodies:
        add(POSE, body=body.name)
        add(TWIST, body=body.name)
    for joint in model.joints:
        add(JOINT_WRENCH, joint=joint.name)
        add(JOINT_WRENCH_WORLD, joint=joint.name)
    for body, source in applied_sources:
        add(APPLIED, body=body, source=source)
        add(APPLIED_WORLD, body=body, source=source)
    for entry in model.aero:
        for quantity in air_quantities:
            add(AIR, body=bodies[entry.body].name, quantity=quantity)
    for body, _ in model.references:
        add(RELATIVE_POSE, body=bodies[body].name)
        add(RELATIVE_TWIST, body=bodies[body].name)
    for topic in (EVENTS, TF_STATIC, MARKERS):
        add(topic)
    if any(not b.fixed for b in bodies):
        add(TF)
        add(LOAD_MARKERS)
    return out


class Cadence:
    """
    When a topic with a period is due: after the first sample of each period.

    Times are counted in periods, a sample on a multiple counting as there
    (t = 0.3 with period 0.1 is 3 periods). ``first``: the first period due
    (0: at the first sample; 1: one period after it).
    """

    def __init__(self, period: float, first: int):
        self.period, self.first = period, first
        self.due = first

    def restart(self):
        """Start again (a new run of the same model)."""
        self.due = self.first

    def take(self, t: float) -> bool:
        """Tell whether a sending is due at simulated time t; if so, the next is a period on."""
        periods = t / self.period + 1e-9
        if periods < self.due:
            return False
        self.due = math.floor(periods) + 1
        return True
