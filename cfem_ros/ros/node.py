# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The ``cfem_node`` ROS 2 node (SPEC section 3): a thin adapter around Session.

The node turns parameters into a ``Session``, topics into ``Input`` items and
samples into messages; the stepping itself (and with it every number) is the
one ``cfem-sim run`` uses, so a recording of the node replays offline to the
same values. Pacing:

- real time (``use_sim_time`` false): a steady-clock timer ticks once per
  sample period divided by ``real_time_factor``; each tick runs the
  simulation on to where the wall clock says it should be. At factor 0
  ticks run back to back, each doing a slice of work.
- sim time (``use_sim_time`` true): nothing runs until the first ``/clock``
  message, whose time becomes the start stamp; each ``/clock`` message then
  runs the simulation on to that time and never past it.
"""

from __future__ import annotations

import json
import logging
import math
import os
import re
import signal
import sys
import time
from typing import Optional

from cfem_ros.core import rotations
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.engine.strokes import describe_event
from cfem_ros.core.errors import CfemError
from cfem_ros.core.run.inputs import Input, odometry_input, release_input, wrench_input
from cfem_ros.core.run.session import Session
from cfem_ros.core.scenario.parse import load_scenario
from cfem_ros.recording import loadarrows, viewframes, visuals
from cfem_ros.recording.errors import OutputError
from cfem_ros.ros import control as simulation_control, parameters
from cfem_ros.ros.airtopics import AirPublishers
from cfem_ros.ros.pacing import OdometryGate, WallPace
from cfem_ros.ros.parameters import PARAMETERS, StartupError  # noqa: F401 - for users
from cfem_ros.ros.recording import NodeRecording
from cfem_ros.ros.runcontrol import RunControl
from cfem_ros.ros.stamps import divergence_advice, InputTiming, OdometryCheck
from geometry_msgs.msg import Point, PoseStamped, TwistStamped, WrenchStamped
from nav_msgs.msg import Odometry
import numpy as np
from rcl_interfaces.msg import SetParametersResult
import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import InvalidTopicNameException
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rclpy.validate_full_topic_name import validate_full_topic_name
from rosgraph_msgs.msg import Clock as ClockMsg
from std_msgs.msg import String
from visualization_msgs.msg import Marker, MarkerArray
try:   # in a ROS 2 install; the pip wheels have no tf2_msgs (recordings carry /tf anyway)
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage
except ImportError:   # pragma: no cover - depends on the install
    TFMessage = None

EXIT_OK = 0
EXIT_FAILED = 1
#: The run stopped at a contact (scenario `contacts:` with on_contact: stop).
EXIT_CONTACT = 3
EXIT_BAD_INPUT = 2

#: Outputs and inputs: what ``ros2 topic pub``, ``ros2 topic echo`` and
#: ``ros2 bag play`` use by default (reliable, volatile, keep last 10).
TOPIC_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.VOLATILE)
#: Events: kept for late joiners that ask for transient local.
EVENT_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: /clock: best effort, as ``ros2 bag play --clock`` and rclpy publish it.
CLOCK_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)

#: Wall time one real-time tick may spend stepping before it yields, s.
TICK_BUDGET = 0.05
#: Seconds between two "falling behind" warnings.
LAG_WARNING_PERIOD = 5.0
#: Most simulated seconds one /clock message may move the simulation on (a jump beyond is
#: ignored with a warning); a jump within it is simulated TICK_BUDGET of wall time at a go.
MAX_CLOCK_JUMP = 3600.0
#: Seconds between two warnings of the same kind (topic and reason) about
#: refused messages; the ones in between are counted, and the count given.
REFUSAL_WARNING_PERIOD = 1.0
#: Bytes of a refused message's string kept in the log and the recording.
REFUSED_STRING_BYTES = 256
#: Environment variable: seconds to sleep at the end of set-up (tests use it
#: to prove that the start stamp is taken after set-up).
SETUP_DELAY_ENV = 'CFEM_NODE_SETUP_DELAY'


class _RosLogHandler(logging.Handler):
    """Forward the engine's Python warnings to the node's ROS logger."""

    def __init__(self, ros_logger):
        super().__init__(logging.INFO)
        self.ros_logger = ros_logger

    def emit(self, record):
        level = record.levelno
        message = self.format(record)
        if level >= logging.ERROR:
            self.ros_logger.error(message)
        elif level >= logging.WARNING:
            self.ros_logger.warning(message)
        else:
            self.ros_logger.info(message)


def bounded(text: str, limit: int = REFUSED_STRING_BYTES) -> str:
    """
    Return text if it holds at most limit bytes (UTF-8), else its first limit bytes and a mark.

    The mark (``... [N bytes, truncated]``) makes the result differ from any
    name of limit bytes or fewer, so a cut string never names a body, frame
    or joint.
    """
    data = text.encode('utf-8', 'surrogatepass')
    if len(data) <= limit:
        return text
    head = data[:limit].decode('utf-8', 'ignore')
    return f'{head}... [{len(data)} bytes, truncated]'


_QUOTED = re.compile(r"'(?:[^'\\]|\\.)*'|\"(?:[^\"\\]|\\.)*\"")
_NUMBER = re.compile(r'(?<![\w.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?!\w)'
                     r'|\bnan\b|\binf\b')


class _Throttle:
    """
    Warnings of one kind at most once per period, with the count of those held back.

    The kind of a warning is its text with quoted names and numbers taken
    out (``unknown joint 'x'`` and ``unknown joint 'y'`` are one kind), so
    the number of kinds is bounded whatever the messages hold.
    """

    def __init__(self, logger, period: float = REFUSAL_WARNING_PERIOD):
        self.logger = logger
        self.period = period
        self._kinds = {}   # kind -> [time of the last line, lines held back since]
        #: Warnings asked for, by kind.
        self.counts = {}

    def warning(self, message: str):
        """Log ``topic: reason`` unless a line of its kind was logged less than period ago."""
        topic, _, reason = message.partition(': ')
        kind = f"{topic}: {_NUMBER.sub('#', _QUOTED.sub(chr(39) * 2, reason))}"
        self.counts[kind] = self.counts.get(kind, 0) + 1
        now = time.monotonic()
        entry = self._kinds.get(kind)
        if entry is not None and now - entry[0] < self.period:
            entry[1] += 1
            return
        if entry is not None and entry[1]:
            message += (f' ({entry[1]} more like it in the last {now - entry[0]:.1f} s '
                        'not shown)')
        self._kinds[kind] = [now, 0]
        self.logger.warning(message)

    def flush(self):
        """Log the count of warnings held back since their kind's last line, for each kind."""
        for kind, entry in self._kinds.items():
            if entry[1]:
                self.logger.warning(f'{entry[1]} more warnings of the kind "{kind}" not shown')
                entry[1] = 0


def _vector3(msg, v):
    msg.x, msg.y, msg.z = float(v[0]), float(v[1]), float(v[2])


def _time_msg(msg, stamp_ns: int):
    msg.sec, msg.nanosec = divmod(int(stamp_ns), 1_000_000_000)


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


#: tf2's own QoS for /tf: reliable, volatile, keep last 100.
TF_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE)


def _latched(depth: int = 1) -> QoSProfile:
    """Return the QoS of what a late subscriber must still get: transient local, reliable."""
    return QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)


class _Publishers:
    """
    Session sink that publishes samples and events (SPEC section 3).

    One message object per topic is built once and refilled at each sample
    (publishing serializes it), which halves the cost of a sample.
    """

    def __init__(self, node: Node, sim):
        self.node = node
        self.sim = sim
        self.start_ns = 0
        model = sim.model
        world = model.frame_id
        self.poses, self.twists = [], []
        for body in model.bodies:
            pose, twist = PoseStamped(), TwistStamped()
            pose.header.frame_id, twist.header.frame_id = world, body.name
            self.poses.append((node.create_publisher(
                PoseStamped, f'bodies/{body.name}/pose', TOPIC_QOS), pose))
            self.twists.append((node.create_publisher(
                TwistStamped, f'bodies/{body.name}/twist', TOPIC_QOS), twist))
        # loads in the frames where they act (the joint's frame, the loaded body's),
        # and in world axes on <topic>_world (SPEC sections 3 and 5)
        self.wrenches = {}   # joint index -> its two (publisher, message)
        self._joint_wrenches()
        self.children = [joint.child for joint in model.joints]
        self.relative = []   # poses and twists in a carrier's frame, per model.references
        for body, ref in model.references:
            pose, twist = PoseStamped(), TwistStamped()
            name = model.bodies[body].name
            pose.header.frame_id = twist.header.frame_id = model.bodies[ref].name
            self.relative.append((
                node.create_publisher(PoseStamped, f'bodies/{name}/relative_pose', TOPIC_QOS),
                pose,
                node.create_publisher(TwistStamped, f'bodies/{name}/relative_twist', TOPIC_QOS),
                twist))
        self.air = AirPublishers(node, sim, TOPIC_QOS)   # the air each body sees (aero)
        self.applied = []   # scheduled loads, per source: the body's, and world axes
        for body, source in sim.applied_sources:
            self.applied.append((self._wrench(f'bodies/{body}/applied/{source}', body),
                                 self._wrench(f'bodies/{body}/applied_world/{source}', world),
                                 model.body_index(body)))
        self.event_publisher = node.create_publisher(String, 'events', EVENT_QOS)
        self._events_sent = 0
        self._retired = []   # released joints' publishers, destroyed at the next events
        # what viewers draw: markers on the bodies' tf frames (recording.visuals)
        self.marker_publisher = node.create_publisher(MarkerArray, 'markers', _latched())
        self.namespace = node.get_namespace().rstrip('/')
        self.tf = None
        self.carriers, self.up = viewframes.carriers(model), visuals.up_rotation(model.gravity)
        moving = [i for i, b in enumerate(model.bodies) if not b.fixed]
        if TFMessage is not None:
            self.tf_static = node.create_publisher(TFMessage, '/tf_static', _latched())
            if moving:   # the moving bodies, then the carriers' z-up view frames
                self.tf = (node.create_publisher(TFMessage, '/tf', TF_QOS), TFMessage(
                    transforms=[_fill(TransformStamped(), {
                        'header': {'frame_id': world}, 'child_frame_id': model.bodies[i].name})
                        for i in moving] + [_fill(TransformStamped(), t) for t in
                                            viewframes.transforms(model, {}, sim.position,
                                                                  sim.orientation)]), moving)
        self._scene_sent = False
        # the next sendings, counted in periods: the markers at 1, the arrows at 0
        self._markers_due, self._arrows_due = 1, 0
        self.arrows = loadarrows.LoadArrows(model, self.namespace, sim.applied_sources)
        self.arrow_publisher = (node.create_publisher(MarkerArray, 'load_markers', TOPIC_QOS)
                                if any(not b.fixed for b in model.bodies) else None)

    def _joint_wrenches(self):
        """Publish the loads of every joint that has no publishers (all, or the released)."""
        world = self.sim.model.frame_id
        for k, joint in enumerate(self.sim.model.joints):
            if k not in self.wrenches:
                self.wrenches[k] = (self._wrench(f'joints/{joint.name}/wrench', joint.name),
                                    self._wrench(f'joints/{joint.name}/wrench_world', world))

    def restart(self, sim, start_ns: int):
        """Publish a new run of the same model (a reset): sim, from stamp start_ns on."""
        self.sim, self.start_ns = sim, int(start_ns)
        self.air.sim = sim
        self._events_sent = 0
        self._markers_due, self._arrows_due = 1, 0
        self._joint_wrenches()   # the joints released in the run before are joined again
        self._scene(self.start_ns)

    def _wrench(self, topic: str, frame_id: str):
        """Return a WrenchStamped publisher on topic and its message, stamped in frame_id."""
        message = WrenchStamped()
        message.header.frame_id = frame_id
        return self.node.create_publisher(WrenchStamped, topic, TOPIC_QOS), message

    def _scene(self, stamp_ns: int):
        """Publish the markers (and, the first time, the frames on /tf_static)."""
        model = self.sim.model
        stamp = {'sec': stamp_ns // 1_000_000_000, 'nanosec': stamp_ns % 1_000_000_000}
        released = {e['joint'] for e in self.sim.events if e.get('event') == 'release'}
        contacts = [e for e in self.sim.events if e.get('event') == 'contact']
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

    def _arrows(self, stamp_ns: int):
        """Publish the load arrows (``recording.loadarrows``) at the current state."""
        sim = self.sim
        stamp = {'sec': stamp_ns // 1_000_000_000, 'nanosec': stamp_ns % 1_000_000_000}
        array, _ = self.arrows.message(stamp, sim.outputs(), sim.active_joints,
                                       sim.held_wrenches())
        self.arrow_publisher.publish(MarkerArray(markers=[
            _fill(Marker(), m) for m in array['markers']]))

    def sample(self):
        sim = self.sim
        stamp_ns = self.stamp_ns(sim.t)
        if not self._scene_sent:
            self._scene(stamp_ns)
        elif sim.t / visuals.MARKER_PERIOD + 1e-9 >= self._markers_due:
            self._scene(stamp_ns)   # again, for viewers that subscribe late
            self._markers_due = math.floor(sim.t / visuals.MARKER_PERIOD + 1e-9) + 1
        position, quat = sim.position, sim.orientation
        velocity, rates = sim.velocity_body(), sim.rates
        if self.tf is not None:
            publisher, message, moving = self.tf
            views = viewframes.view_poses(self.up, position[self.carriers], quat[self.carriers])
            for transform, values in zip(message.transforms, np.vstack(
                    [np.hstack([position[moving], quat[moving]]), views])):
                _time_msg(transform.header.stamp, stamp_ns)
                _vector3(transform.transform.translation, values[:3])
                r = transform.transform.rotation
                r.x, r.y, r.z, r.w = (float(c) for c in values[3:])
            publisher.publish(message)
        for i in range(len(self.poses)):
            publisher, pose = self.poses[i]
            _time_msg(pose.header.stamp, stamp_ns)
            _vector3(pose.pose.position, position[i])
            q = pose.pose.orientation
            q.x, q.y, q.z, q.w = (float(c) for c in quat[i])
            publisher.publish(pose)
            publisher, twist = self.twists[i]
            _time_msg(twist.header.stamp, stamp_ns)
            _vector3(twist.twist.linear, velocity[i])
            _vector3(twist.twist.angular, rates[i])
            publisher.publish(twist)
        if self.arrow_publisher is not None and \
                sim.t / loadarrows.PERIOD + 1e-9 >= self._arrows_due:   # a few per second
            self._arrows_due = math.floor(sim.t / loadarrows.PERIOD + 1e-9) + 1
            self._arrows(stamp_ns)
        if self.wrenches:
            force, moment = sim.joint_wrenches()
            turned = quat[self.children]
            axes = rotations.to_body(turned, force), rotations.to_body(turned, moment)
            for k, publishers in self.wrenches.items():
                for (publisher, wrench), (f, m) in zip(publishers, (
                        (axes[0][k], axes[1][k]), (force[k], moment[k]))):
                    _time_msg(wrench.header.stamp, stamp_ns)
                    _vector3(wrench.wrench.force, f)
                    _vector3(wrench.wrench.torque, m)
                    publisher.publish(wrench)
        if self.applied:
            loads = sim.applied_loads()
            turned = quat[[body for _, _, body in self.applied]]
            axes = np.hstack([rotations.to_body(turned, loads[:, :3]),
                              rotations.to_body(turned, loads[:, 3:])])
            for (local, world, _), load, load_axes in zip(self.applied, loads, axes):
                for (publisher, wrench), values in ((local, load_axes), (world, load)):
                    _time_msg(wrench.header.stamp, stamp_ns)
                    _vector3(wrench.wrench.force, values[:3])
                    _vector3(wrench.wrench.torque, values[3:])
                    publisher.publish(wrench)
        self.air.publish(stamp_ns)
        if self.relative:
            for (pose_pub, pose, twist_pub, twist), state in zip(
                    self.relative, sim.relative_states()):
                _time_msg(pose.header.stamp, stamp_ns)
                _vector3(pose.pose.position, state[:3])
                q = pose.pose.orientation
                q.x, q.y, q.z, q.w = (float(c) for c in state[3:7])
                pose_pub.publish(pose)
                _time_msg(twist.header.stamp, stamp_ns)
                _vector3(twist.twist.linear, state[7:10])
                _vector3(twist.twist.angular, state[10:])
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
        for publisher in self._retired:   # their zero went out at the last call
            self.node.destroy_publisher(publisher)
        self._retired = []
        for event in self.sim.events[self._events_sent:]:
            self.event_publisher.publish(String(data=json.dumps(event)))
            if event['event'] == 'contact':
                self.node.get_logger().warning(
                    f"contact between {' and '.join(event['bodies'])} at t = "
                    f"{event['time']:.9g} s, point {event['point']} (world, m), "
                    f"parts {event.get('parts', [0, 0])}")
                continue
            if event.get('event') != 'release':
                self.node.get_logger().info(describe_event(event))
                continue
            group = f" in group {event['group']!r}" if event.get('group') else ''
            self.node.get_logger().info(
                f"{event['event']} of joint {event['joint']!r} at t = {event['time']:.9g} s "
                f"(cause: {event['cause']}){group}")
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


def _topic_name_error(node, model, err) -> str:
    """One line for a body or joint whose name makes a topic ROS 2 refuses."""
    reason = str(err).split('\n', 1)[0].removeprefix('Invalid topic name: ').rstrip(':')
    for kind, items in (('bodies', model.bodies), ('joints', model.joints)):
        for item in items:
            topic = f'{kind}/{item.name}/wrench' if kind == 'joints' else (
                f'bodies/{item.name}/pose')
            try:
                validate_full_topic_name(node.resolve_topic_name(topic))
            except Exception:  # noqa: B902 - rclpy raises several kinds; any is this name
                return (f'{node.scenario_path}: {kind}.{bounded(item.name, 64)!r}: the name '
                        f'makes an invalid ROS 2 topic ({reason}); expected a name of '
                        'letters, digits and underscores that keeps topic names within '
                        '247 characters')
    return f'{node.scenario_path}: a name makes an invalid ROS 2 topic ({reason})'


def warm_up(model, publishers):
    """
    Take a step and a sample on a spare simulator, before time starts.

    Every first call (lazy imports, caches) is paid here, and the first
    sample's messages are filled once, so that the start stamp, taken after
    this, is not behind the samples.
    """
    quiet = logging.getLogger(f'cfem_ros.node.warm_up.{id(publishers)}')
    quiet.propagate = False
    quiet.addHandler(logging.NullHandler())
    spare = Simulator(model, logger=quiet)
    spare.outputs()
    spare.velocity_body()
    spare.joint_wrenches()
    spare.advance_to(spare.dt)
    spare.outputs()
    publishers.prepare()
    delay = os.environ.get(SETUP_DELAY_ENV, '')
    if delay:
        time.sleep(float(delay))


class CfemNode(Node):
    """
    The cfem_sim node: steps a scenario, takes wrenches and releases, publishes.

    Parameters
    ----------
    context : rclpy.context.Context, optional
        The context to live in (the default one if None).

    Raises
    ------
    StartupError
        For a missing or bad parameter, or a bad scenario; the message is the
        one ``cfem-sim`` gives.

    """

    def __init__(self, *, context=None):
        super().__init__('cfem_sim', namespace='cfem', context=context)
        self.exit_code: Optional[int] = None
        values = parameters.declare(self)
        parameters.warn_unknown(self)
        try:
            model = load_scenario(values['scenario'])
        except CfemError as err:
            raise StartupError(str(err)) from None
        duration = values['duration']
        if duration < 0:
            duration = model.duration
        self.duration = math.inf if duration == 0 else duration
        self.sim_time = bool(self.get_parameter('use_sim_time').value)
        self.rate_hz = values['rate_hz']
        self.pace = WallPace(values['real_time_factor'])
        self.scenario_path = values['scenario']
        #: Refused inputs: one warning line per topic and reason per second.
        self._refusals = _Throttle(self.get_logger())
        self._refused = {}   # topic -> messages refused
        self._diagnosed = False

        self._python_log = logging.getLogger(f'cfem_ros.node.{id(self)}')
        self._python_log.propagate = False
        self._python_log.setLevel(logging.INFO)   # the ROS logger filters by its own level
        self._python_log.addHandler(_RosLogHandler(self.get_logger()))
        try:
            self.sim = Simulator(model, logger=self._python_log)
        except CfemError as err:
            raise StartupError(str(err)) from None

        # topics first: a name ROS refuses stops the node before a file is made
        try:
            self._publishers_sink = _Publishers(self, self.sim)
            for body in model.bodies:
                self.create_subscription(
                    WrenchStamped, f'bodies/{body.name}/wrench',
                    lambda msg, name=body.name: self._on_wrench(name, msg), TOPIC_QOS)
                if body.motion is not None:   # a kinematic body may follow odometry
                    self.create_subscription(
                        Odometry, f'bodies/{body.name}/odom',
                        lambda msg, name=body.name: self._on_odometry(name, msg), TOPIC_QOS)
        except InvalidTopicNameException as err:
            raise StartupError(_topic_name_error(self, model, err)) from None
        self._release_sub = self.create_subscription(String, 'release', self._on_release,
                                                     TOPIC_QOS)

        self.recording = (NodeRecording(self, self.sim, values['record'], values['overwrite'])
                          if values['record'] else None)
        self._interpolate = bool(values['interpolate_odometry'])
        self.odometry_check = OdometryCheck(self.get_logger().warning)
        self.new_session()
        self._clock_limit: Optional[float] = None   # simulated time /clock last gave
        self.start_ns: Optional[int] = None
        self._early = []
        self._last_lag_warning = -math.inf
        self._timer = None
        self._catch_up_timer = None   # goes on toward /clock's time, a slice at a time
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.control = RunControl(self, paused=bool(values['paused']))
        self.simulation_services = simulation_control.serve(self, self.control)

        mode = 'following /clock' if self.sim_time else (
            'as fast as possible' if self.pace.factor == 0
            else f'at {self.pace.factor:g}x real time')
        self.get_logger().info(
            f'scenario {model.name!r} from {self.scenario_path}: {len(model.bodies)} bodies, '
            f'{len(model.joints)} joints, {self.sim.dof} degrees of freedom; dt {model.dt:g} s, '
            f'publishing at {self.rate_hz:g} Hz {mode}'
            + (f"; recording to {values['record']}" if values['record'] else ''))
        warm_up(model, self._publishers_sink)
        if self.sim_time:
            self.create_subscription(ClockMsg, '/clock', self._on_clock, CLOCK_QOS)
            self.get_logger().info('waiting for /clock (use_sim_time is true)')
        else:
            self._begin(None)

    def new_session(self):
        """Make the session (and what times its inputs) of a run of self.sim from t = 0."""
        outputs = [self._publishers_sink] + ([self.recording.state] if self.recording else [])
        self.session = Session(self.sim, rate_hz=self.rate_hz, duration=self.duration,
                               outputs=outputs, warn=self._refusals.warning,
                               interpolate_odometry=self._interpolate)
        self.gate = OdometryGate(self.sim, self.session, interpolate=self._interpolate,
                                 following_clock=self.sim_time,
                                 subscribed=any(b.motion is not None
                                                for b in self.sim.model.bodies))
        late = getattr(self, 'timing', None)
        self.timing = InputTiming(self.sim, self._refusals.warning)
        if late is not None:
            self.timing.late_inputs = late.late_inputs

    # ------------------------------------------------------------ parameters

    def _on_set_parameters(self, parameters) -> SetParametersResult:
        for parameter in parameters:
            if parameter.name == 'real_time_factor':
                self._set_real_time_factor(float(parameter.value))
            elif parameter.name == 'use_sim_time' and bool(parameter.value) != self.sim_time:
                return SetParametersResult(
                    successful=False, reason='use_sim_time is fixed once the node has started')
        return SetParametersResult(successful=True)

    # ---------------------------------------------------------------- pacing

    def _begin(self, start_ns: Optional[int]):
        """
        Start the run: simulated time 0 is stamp start_ns (None: the ROS time now).

        In real time the start stamp and the wall-clock reference are taken
        together, after all set-up: sample k is published at about stamp
        start_ns + k / rate_hz in ROS time.
        """
        if start_ns is None:
            # the timer's ticks fall on the sample times: it starts with the clocks
            self._start_timer()
            start_ns = self.get_clock().now().nanoseconds
            self.pace.start(time.monotonic())
        self.start_ns = self.timing.start_ns = int(start_ns)
        if self.sim_time:
            self._clock_limit = 0.0
        self._publishers_sink.start_ns = self.start_ns
        if self.recording is not None:
            self.recording.begin(self.start_ns, self.scenario_path, self.rate_hz,
                                 use_sim_time=str(self.sim_time).lower(),
                                 interpolate_odometry=str(self.gate.interpolate).lower())
        for item in self._early:
            self._submit(*item)
        self._early.clear()
        if not self.sim_time or self.control.paused:
            self.session.start()   # paused: the initial state is published, then it waits
        # following /clock, the session starts on its first advance, once a carrier's
        # first odometry has come (``OdometryGate``): odometry stamped at t = 0 is applied before
        # the t = 0 sample, as in the offline replay

    def _start_timer(self):
        if self._timer is not None:
            self.destroy_timer(self._timer)
        period = 1.0 / self.rate_hz / self.pace.factor if self.pace.factor > 0 else 0.001
        self._timer = self.create_timer(period, self._on_tick,
                                        clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _set_real_time_factor(self, factor: float):
        if self.sim_time or self.start_ns is None:
            self.pace.factor = factor
            return
        self.pace.retime(time.monotonic(), self.sim.t, factor)
        self._start_timer()
        self.get_logger().info(f'real_time_factor set to {factor:g}')

    def _on_tick(self):
        if self.control.paused:
            return
        now = time.monotonic()
        target = self.pace.target(now)
        self._run_to(target, deadline=now + TICK_BUDGET)
        lag = self.gate.held(target) - self.sim.t   # waiting for odometry is not falling behind
        if (math.isfinite(lag) and not self.session.finished
                and lag > max(2.0 / self.rate_hz, 2 * self.sim.dt)
                and now - self._last_lag_warning > LAG_WARNING_PERIOD):
            self._last_lag_warning = now
            self.get_logger().warning(
                f'falling behind real time: simulated time {self.sim.t:.3f} s lags the '
                f'clock by {lag:.3f} s at real_time_factor {self.pace.factor:g}; '
                'lower real_time_factor or rate_hz')

    def _on_clock(self, msg: ClockMsg):
        clock_ns = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
        if clock_ns < 0:
            self._refusals.warning(f'/clock: {clock_ns * 1e-9:.9g} s is a negative time; '
                                   'ignored')
            return
        if self.start_ns is None:
            self.get_logger().info(f'/clock started at {clock_ns * 1e-9:.9f} s; '
                                   'simulated time 0 is that stamp')
            self._begin(clock_ns)
            return
        if clock_ns < self.start_ns + int(round(self.sim.t * 1e9)):
            self.get_logger().warning('/clock went back; ignored (restart the node to '
                                      'replay from an earlier time)', throttle_duration_sec=5.0)
            return
        limit = (clock_ns - self.start_ns) / 1e9
        if limit - self.sim.t > MAX_CLOCK_JUMP:
            self._refusals.warning(
                f'/clock jumped {limit - self.sim.t:.6g} s ahead of the simulation (at '
                f't = {self.sim.t:.6g} s); more than {MAX_CLOCK_JUMP:g} s at once is ignored '
                '(restart the node to follow a clock that far away)')
            return
        self._clock_limit = limit
        self._catch_up()

    def _catch_up(self):
        """Run toward /clock's time for TICK_BUDGET of wall time; a timer does the rest."""
        self._run_to(self._clock_limit, deadline=time.monotonic() + TICK_BUDGET)
        session = self.session
        behind = (self.exit_code is None and not session.finished
                  and session.next_sample_time <= self.gate.held(self._clock_limit))
        if behind and self._catch_up_timer is None:   # signals and messages come between
            self._catch_up_timer = self.create_timer(
                0.001, self._catch_up, clock=Clock(clock_type=ClockType.STEADY_TIME))
        elif not behind and self._catch_up_timer is not None:
            self.destroy_timer(self._catch_up_timer)
            self._catch_up_timer = None

    def _run_to(self, limit: float, deadline: float = math.inf):
        """Run the session on to simulated time limit, within a wall deadline (not paused)."""
        session = self.session
        if self.control.paused:
            return
        limit = self.gate.held(limit)
        while (not session.finished and session.next_sample_time <= limit
               and time.monotonic() < deadline):
            session.advance(session.next_sample_time)
        if math.isfinite(limit) and not session.finished and time.monotonic() < deadline:
            session.advance(limit)
        if session.finished and self.exit_code is None:
            self._end()

    def _end(self):
        if self.sim.status == 'contact':
            self.get_logger().warning(f'run stopped: {self.sim.message}')
            self.exit_code = EXIT_CONTACT
        elif self.session.failed:
            self.sim.message = divergence_advice(self.sim.message, self.timing.late_inputs,
                                                 self.odometry_check.warned)
            self.get_logger().error(f'the run failed {self.sim.message}')
            self._publishers_sink.event_publisher.publish(String(data=json.dumps(
                {'event': 'error', 'time': self.sim.t, 'message': self.sim.message})))
            if self.recording is not None:
                self.recording.state.failed()
            self.exit_code = EXIT_FAILED
        else:
            self.get_logger().info(f'run complete at t = {self.sim.t:.9g} s')
            self.exit_code = EXIT_OK
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None
        self.close()

    def close(self):
        """Finish the recording, and say how many inputs were refused (safe to call twice)."""
        self._refusals.flush()
        if self._refused:
            self.get_logger().info('messages refused: ' + ', '.join(
                f'{count} on {topic}' for topic, count in sorted(self._refused.items())))
            self._refused = {}
        if getattr(self, 'timing', None) is not None and not self._diagnosed:
            self._diagnosed = True
            self.get_logger().info(f'diagnostics: late_inputs {self.timing.late_inputs}')
        if self.recording is not None:
            recording, self.recording = self.recording, None
            recording.finish()

    def recording_failed(self, err):
        """
        End the run after a write of the recording failed (a full disk, a file size limit).

        The recording keeps what is complete and says so (``NodeRecording.failed``);
        the node ends with ``EXIT_FAILED``: a recording node whose recording
        failed does not go on publishing a run no file will hold.
        """
        recording, self.recording = self.recording, None
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None
        recording.failed(err, self.start_ns)
        self.exit_code = EXIT_FAILED

    # ---------------------------------------------------------------- inputs

    def _on_wrench(self, body: str, msg: WrenchStamped):
        stamp = msg.header.stamp
        header_ns = stamp.sec * 1_000_000_000 + stamp.nanosec
        f, m = msg.wrench.force, msg.wrench.torque
        topic = self.resolve_topic_name(f'bodies/{body}/wrench')
        self._submit(topic, wrench_input(body, [f.x, f.y, f.z], [m.x, m.y, m.z],
                                         bounded(msg.header.frame_id), header_ns=header_ns))

    def _on_odometry(self, body: str, msg: Odometry):
        self.gate.seen += 1
        stamp = msg.header.stamp
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        v, w = msg.twist.twist.linear, msg.twist.twist.angular
        topic = self.resolve_topic_name(f'bodies/{body}/odom')
        self._submit(topic, odometry_input(
            body, [p.x, p.y, p.z], [q.x, q.y, q.z, q.w], [v.x, v.y, v.z], [w.x, w.y, w.z],
            bounded(msg.header.frame_id),
            header_ns=stamp.sec * 1_000_000_000 + stamp.nanosec))

    def _on_release(self, msg: String):
        self._submit(self._release_sub.topic_name, release_input(bounded(msg.data.strip())))

    def _arrival_time(self) -> Optional[float]:
        """
        Return the simulated time at which an input arriving now takes effect (None: at once).

        In real time, where the wall clock says the simulation is, in whole
        nanoseconds (as the recording logs it, so a replay applies it at the
        same time), never past the end of the run.
        """
        if self.sim_time or self.pace.factor == 0:
            return None
        target = self.pace.target(time.monotonic())
        return min(round(target * 1e9) / 1e9, self.duration)

    def _submit(self, topic: str, item: Input):
        """
        Give an input to the session; a refused one is logged (throttled) and counted.

        Strings are already cut to ``REFUSED_STRING_BYTES`` (``bounded``):
        longer ones never name a frame or joint, so they are refused, and
        recorded and logged in that bounded form.
        """
        if self.exit_code is not None:
            return
        if self.start_ns is None:
            self._early.append((topic, item))
            return
        # at its stamp if that is still ahead; else at the clock's time, which is ahead of
        # the simulation while it waits for odometry (``OdometryGate``), or at once
        self.odometry_check.check(topic, item)
        item = self.timing.timed(topic, item,
                                 self._clock_limit if self.sim_time else self._arrival_time())
        try:
            self.session.submit(item)
        except ValueError as err:
            self._refused[topic] = self._refused.get(topic, 0) + 1
            self._refusals.warning(f'{topic}: message not applied: {err}')
        if item.kind == 'odom' and self.gate.interpolate:   # what waited for it goes on
            if self.sim_time and self._clock_limit is not None:
                self._catch_up()
            elif not self.sim_time and self.pace.factor > 0:
                self._run_to(self.pace.target(time.monotonic()))
        if self.session.finished and self.exit_code is None:
            self._end()


def main(args=None) -> int:
    """Entry point of the cfem_node console script; return the exit status."""
    args = sys.argv if args is None else args
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stop = []
    previous = {sig: signal.signal(sig, lambda signum, frame: stop.append(signum))
                for sig in (signal.SIGINT, signal.SIGTERM)}
    node = None
    try:
        executor = SingleThreadedExecutor()
        try:
            node = CfemNode()
        except CfemError as err:
            print(f'ERROR: {err}', file=sys.stderr)
            return EXIT_BAD_INPUT
        executor.add_node(node)
        while not stop and node.exit_code is None and rclpy.ok():
            try:
                executor.spin_once(timeout_sec=0.05)
            except (OSError, OutputError) as err:   # from a callback's write
                if node.recording is None:
                    raise
                node.recording_failed(err)
            except ValueError as err:   # rclpy's time source on a /clock it cannot hold
                node.get_logger().warning(f'a message was not applied: {err}',
                                          throttle_duration_sec=5.0)
        if stop:
            node.get_logger().info(
                f'{signal.Signals(stop[0]).name} received at simulated t = {node.sim.t:.9g} s;'
                ' shutting down')
        try:
            node.close()
        except OutputError as err:   # the last chunk and the summary did not fit
            node.recording_failed(err)
        return EXIT_OK if node.exit_code is None else node.exit_code
    finally:
        if node is not None:
            node.close()
            node.destroy_node()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        rclpy.try_shutdown()


def entry_point():
    """Console script wrapper: exit with main's status."""
    sys.exit(main())


if __name__ == '__main__':
    entry_point()
