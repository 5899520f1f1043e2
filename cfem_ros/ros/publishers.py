# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The node's outputs (SPEC section 3): a ``Session`` sink that publishes samples and events.

Topics, types, frames, QoS and periods are the output schema's
(``recording.schema``), the same the recorder writes.
"""

from __future__ import annotations

import json

from cfem_ros.core.engine.events import describe_event, Event
from cfem_ros.core.native.kernel import SAMPLE
from cfem_ros.core.run.session import Sink
from cfem_ros.recording import loadarrows, schema, viewframes, visuals
from cfem_ros.recording.samplelayout import InBodyAxes
from cfem_ros.ros.airtopics import AirPublishers
from cfem_ros.ros.qos import profile
from geometry_msgs.msg import Point, PoseStamped, TwistStamped, WrenchStamped
import numpy as np
from rclpy.node import Node
from std_msgs.msg import String
from visualization_msgs.msg import Marker, MarkerArray
try:   # in a ROS 2 install; the pip wheels have no tf2_msgs (recordings carry /tf anyway)
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage
except ImportError:   # pragma: no cover - depends on the install
    TFMessage = None


def _vector3(msg, v):
    msg.x, msg.y, msg.z = float(v[0]), float(v[1]), float(v[2])


def _time_msg(msg, stamp_ns: int):
    msg.sec, msg.nanosec = divmod(int(stamp_ns), 1_000_000_000)


#: A pose's numbers in a sample (CG position, quaternion; ``kernel.SAMPLE``).
POSE = SAMPLE.width('O_POSITION') + SAMPLE.width('O_QUATERNION')


def _fill_state(state: np.ndarray, pose, twist, stamp_ns: int):
    """Fill a PoseStamped and a TwistStamped from a sample's body numbers (``SAMPLE``)."""
    _time_msg(pose.header.stamp, stamp_ns)
    _vector3(pose.pose.position, state[SAMPLE.span('O_POSITION')])
    q = pose.pose.orientation
    q.x, q.y, q.z, q.w = (float(c) for c in state[SAMPLE.span('O_QUATERNION')])
    _time_msg(twist.header.stamp, stamp_ns)
    _vector3(twist.twist.linear, state[SAMPLE.span('O_VELOCITY')])
    _vector3(twist.twist.angular, state[SAMPLE.span('O_RATES')])


def _fill_wrench(wrench, values: np.ndarray, stamp_ns: int):
    """Fill a WrenchStamped from a sample's force and moment (``SAMPLE.O_FORCE`` ...)."""
    _time_msg(wrench.header.stamp, stamp_ns)
    _vector3(wrench.wrench.force, values[SAMPLE.span('O_FORCE')])
    _vector3(wrench.wrench.torque, values[SAMPLE.span('O_MOMENT')])


def _fill(msg, values: dict):
    """Set a message's fields from a dict of the same shape (nested dicts for nested messages)."""
    for name, value in values.items():
        if isinstance(value, dict):
            _fill(getattr(msg, name), value)
        elif name == 'points':   # a triangle list's vertices, an arrow's ends
            setattr(msg, name, [_fill(Point(), p) for p in value])
        else:
            setattr(msg, name, value)
    return msg


class Publishers(Sink):
    """
    Session sink that publishes samples and events (SPEC section 3).

    The publishers it creates on the node are the schema's topics of the
    model (``schema.run_topics``; /tf and /tf_static only where tf2_msgs is
    installed).

    One message object per topic is built once and refilled at each sample
    (publishing serializes it), which halves the cost of a sample.
    """

    def __init__(self, node: Node, sim):
        self.node = node
        self.sim = sim
        self.start_ns = 0
        model = sim.model
        self.world = world = model.frame_id
        self.poses, self.twists = [], []
        for body in model.bodies:
            self.poses.append(self._publisher(schema.POSE, PoseStamped, body=body.name))
            self.twists.append(self._publisher(schema.TWIST, TwistStamped, body=body.name))
        # loads in the frames where they act (the joint's frame, the loaded body's),
        # and in world axes on <topic>_world (SPEC sections 3 and 5)
        self.wrenches = {}   # joint index -> its two (publisher, message)
        self._joint_wrenches()
        self.children = [joint.child for joint in model.joints]
        self.relative = []   # poses and twists in a carrier's frame, per model.references
        for body, ref in model.references:
            names = {'body': model.bodies[body].name, 'reference': model.bodies[ref].name}
            self.relative.append(self._publisher(schema.RELATIVE_POSE, PoseStamped, **names)
                                 + self._publisher(schema.RELATIVE_TWIST, TwistStamped, **names))
        self.air = AirPublishers(node, sim)   # the air each body sees (aero)
        self.applied = []   # scheduled loads, per source: the body's, and world axes
        for body, source in sim.applied_sources:
            self.applied.append((
                self._publisher(schema.APPLIED, WrenchStamped, body=body, source=source),
                self._publisher(schema.APPLIED_WORLD, WrenchStamped, body=body, source=source),
                model.body_index(body)))
        self.event_publisher = self._publisher(schema.EVENTS, String)
        self._events_sent = 0
        self._retired = []   # released joints' publishers, destroyed at the next events
        # what viewers draw: markers on the bodies' tf frames (recording.visuals)
        self.marker_publisher = self._publisher(schema.MARKERS, MarkerArray)
        self.namespace = node.get_namespace().rstrip('/')
        self.tf = None
        moving = [i for i, b in enumerate(model.bodies) if not b.fixed]
        if TFMessage is not None:
            self.tf_static = self._publisher(schema.TF_STATIC, TFMessage)
            if moving:   # the moving bodies, then the carriers' z-up view frames
                self.tf = (self._publisher(schema.TF, TFMessage), TFMessage(
                    transforms=[_fill(TransformStamped(), {
                        'header': {'frame_id': world}, 'child_frame_id': model.bodies[i].name})
                        for i in moving] + [_fill(TransformStamped(), t) for t in
                                            viewframes.transforms(model, {}, sim.position,
                                                                  sim.orientation)]), moving)
        #: The carriers' view and chase frames, from a sample's numbers (as recorded).
        self.views = viewframes.of_model(model)
        self._scene_sent = False
        # the next sending of the markers: one period after the scene's
        self._marker_cadence = schema.Cadence(schema.MARKERS.period, first=1)
        # the load arrows at every sample and at each event that starts or ends a load, at
        # the one scale fixed at t = 0, the recording's (recording.loadarrows)
        self.arrows = loadarrows.LoadArrows(model, self.namespace, sim.applied_sources)
        self.arrow_publisher = (self._publisher(schema.LOAD_MARKERS, MarkerArray)
                                if any(not b.fixed for b in model.bodies) else None)
        if self.arrow_publisher is not None:
            loadarrows.watch_loads(sim)   # the state at a load event stepped over

    def _publisher(self, topic: schema.Topic, kind, **names):
        """
        Return a publisher of a schema topic of these names, or it and its message.

        With a frame, the message is made once, stamped in that frame, and
        refilled at each sample.
        """
        publisher = self.node.create_publisher(kind, topic.relative(**names),
                                               profile(topic.qos))
        if topic.frame is None:
            return publisher
        message = kind()
        message.header.frame_id = topic.frame_id(world=self.world, **names)
        return publisher, message

    def _joint_wrenches(self):
        """Publish the loads of every joint that has no publishers (all, or the released)."""
        for k, joint in enumerate(self.sim.model.joints):
            if k not in self.wrenches:
                self.wrenches[k] = tuple(self._publisher(topic, WrenchStamped, joint=joint.name)
                                         for topic in (schema.JOINT_WRENCH,
                                                       schema.JOINT_WRENCH_WORLD))

    def restart(self, sim, start_ns: int):
        """Publish a new run of the same model (a reset): sim, from stamp start_ns on."""
        self.sim, self.start_ns = sim, int(start_ns)
        self.air.sim = sim
        if self.arrow_publisher is not None:
            loadarrows.watch_loads(sim)
        self._events_sent = 0
        self._marker_cadence.restart()
        self._joint_wrenches()   # the joints released in the run before are joined again
        self._scene(self.start_ns)

    def _scene(self, stamp_ns: int):
        """Publish the markers (and, the first time, the frames on /tf_static)."""
        model = self.sim.model
        stamp = {'sec': stamp_ns // 1_000_000_000, 'nanosec': stamp_ns % 1_000_000_000}
        released = {e['joint'] for e in self.sim.events if e.get('event') == Event.RELEASE}
        contacts = [e for e in self.sim.events if e.get('event') == Event.CONTACT]
        self.marker_publisher.publish(MarkerArray(markers=[
            _fill(Marker(), m) for m in visuals.markers(
                model, stamp, self.namespace, released, contacts)['markers']]))
        if TFMessage is not None and not self._scene_sent:
            self.tf_static.publish(TFMessage(transforms=[
                _fill(TransformStamped(), t)
                for t in visuals.static_transforms(model, stamp)['transforms']]))
        self._scene_sent = True

    def stamp_ns(self, t: float) -> int:
        return self.start_ns + int(round(t * 1e9))

    def _arrows(self, stamp_ns: int, row: np.ndarray, active, held: np.ndarray):
        """Publish the load arrows (``recording.loadarrows``) of a sample's numbers."""
        stamp = {'sec': stamp_ns // 1_000_000_000, 'nanosec': stamp_ns % 1_000_000_000}
        array, _ = self.arrows.message(stamp, row, active, held)
        self.arrow_publisher.publish(MarkerArray(markers=[
            _fill(Marker(), m) for m in array['markers']]))

    def sample(self):
        """Publish a sample of the simulator's current state (``publish`` of its outputs)."""
        self.publish(self.sim.outputs(), self.sim.active_joints)

    def publish(self, row: np.ndarray, active):
        """
        Publish a sample from its numbers: ``Simulator.outputs`` at the current state.

        Every number published is row's, or turned from them by the
        functions the recorder uses (``InBodyAxes``, ``ViewFrames``), so
        that what the node publishes is what it records (``outputs``).
        active: the joints active in the sample (``Simulator.active_joints``).
        """
        sim, model = self.sim, self.sim.model
        n = len(model.bodies)
        stamp_ns = self.stamp_ns(sim.t)
        if not self._scene_sent:
            self._scene(stamp_ns)
        elif self._marker_cadence.take(sim.t):
            self._scene(stamp_ns)   # again, for viewers that subscribe late
        block = row[None, :]
        if self.tf is not None:
            publisher, message, moving = self.tf
            poses = [row[SAMPLE.BODY * i + SAMPLE.O_POSITION:][:POSE] for i in moving]
            if self.views is not None:
                poses += list(self.views.numbers(block).reshape(-1, 7))
            for transform, values in zip(message.transforms, poses):
                _time_msg(transform.header.stamp, stamp_ns)
                _vector3(transform.transform.translation, values[:3])
                r = transform.transform.rotation
                r.x, r.y, r.z, r.w = (float(c) for c in values[3:7])
            publisher.publish(message)
        states = row[:SAMPLE.BODY * n].reshape(n, SAMPLE.BODY)
        for i in range(n):
            (publisher, pose), (twist_publisher, twist) = self.poses[i], self.twists[i]
            _fill_state(states[i], pose, twist, stamp_ns)
            publisher.publish(pose)
            twist_publisher.publish(twist)
        if self.arrow_publisher is not None:
            self._arrows(stamp_ns, row, active, sim.held_wrenches())
        column = SAMPLE.BODY * n
        for k in active:   # world axes, and the child's axes as the recorder turns them
            world = row[column:column + SAMPLE.JOINT]
            if k in self.wrenches:
                local = InBodyAxes(column, SAMPLE.BODY * self.children[k]
                                   + SAMPLE.O_QUATERNION).numbers(block)[0]
                for (publisher, wrench), values in zip(self.wrenches[k], (local, world)):
                    _fill_wrench(wrench, values, stamp_ns)
                    publisher.publish(wrench)
            column += SAMPLE.JOINT
        for local_pub, world_pub, body in self.applied:
            local = InBodyAxes(column, SAMPLE.BODY * body + SAMPLE.O_QUATERNION).numbers(block)[0]
            for (publisher, wrench), values in ((local_pub, local),
                                                (world_pub, row[column:column + SAMPLE.WRENCH])):
                _fill_wrench(wrench, values, stamp_ns)
                publisher.publish(wrench)
            column += SAMPLE.WRENCH
        self.air.publish(stamp_ns, sim.air(outputs=row))
        relative = row[len(row) - SAMPLE.BODY * len(self.relative):].reshape(-1, SAMPLE.BODY)
        for k, (pose_pub, pose, twist_pub, twist) in enumerate(self.relative):
            _fill_state(relative[k], pose, twist, stamp_ns)
            pose_pub.publish(pose)
            twist_pub.publish(twist)

    def prepare(self):
        """Fill every message once without publishing (the first sample's set-up)."""
        sim = self.sim
        position, quat = sim.position, sim.orientation
        velocity, rates = sim.velocity_body(), sim.rates
        for i, ((_, pose), (_, twist)) in enumerate(zip(self.poses, self.twists)):
            _vector3(pose.pose.position, position[i])
            _vector3(twist.twist.linear, velocity[i])
            _vector3(twist.twist.angular, rates[i])
            q = pose.pose.orientation
            q.x, q.y, q.z, q.w = (float(c) for c in quat[i])
        if self.wrenches:
            force, moment = sim.joint_wrenches()
            for k, publishers in self.wrenches.items():
                for _, wrench in publishers:
                    _vector3(wrench.wrench.force, force[k])
                    _vector3(wrench.wrench.torque, moment[k])

    def events(self):
        """Publish the new events, and the load arrows at one that starts or ends a load."""
        for publisher in self._retired:   # their zero went out at the last call
            self.node.destroy_publisher(publisher)
        self._retired = []
        new = self.sim.events[self._events_sent:]
        if self.arrow_publisher is not None:   # at each load event's instant, as recorded
            for t, row, active, held in loadarrows.event_states(self.sim, new):
                self._arrows(self.stamp_ns(t), row, active, held)
        for event in new:
            self.event_publisher.publish(String(data=json.dumps(event)))
            if event['event'] == Event.CONTACT:   # a contact is a warning: shapes touched
                self.node.get_logger().warning(describe_event(event))
                continue
            self.node.get_logger().info(describe_event(event))
            if event['event'] != Event.RELEASE:
                continue
            k = self.sim.model.joint_index(event['joint'])
            for publisher, wrench in self.wrenches.pop(k, ()):   # zero once: plots end at 0
                _time_msg(wrench.header.stamp, self.stamp_ns(event['time']))
                _vector3(wrench.wrench.force, (0.0, 0.0, 0.0))
                _vector3(wrench.wrench.torque, (0.0, 0.0, 0.0))
                publisher.publish(wrench)
                self._retired.append(publisher)
        if self._scene_sent and len(self.sim.events) > self._events_sent:
            self._scene(self.stamp_ns(self.sim.events[-1]['time']))   # released joints
        self._events_sent = len(self.sim.events)

    def received(self, item, t):
        """Leave inputs alone: they are not published back."""
