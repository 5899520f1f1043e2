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

from dataclasses import replace
import json
import logging
import math
import signal
import sys
import time
from typing import Optional

from cfem_ros.core.engine import Simulator
from cfem_ros.core.errors import CfemError
from cfem_ros.core.inputs import release_input, wrench_input
from cfem_ros.core.scenario import load_scenario
from cfem_ros.core.session import Session
from cfem_ros.recording.recorder import Recorder, run_metadata, StateRecorder
from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, SetParametersResult
import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock as ClockMsg
from std_msgs.msg import String

EXIT_OK = 0
EXIT_FAILED = 1
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


class StartupError(CfemError):
    """A parameter or scenario the node cannot start with."""


def _double(description: str, low: float, high: float, read_only: bool = True):
    return ParameterDescriptor(
        description=description, read_only=read_only,
        floating_point_range=[FloatingPointRange(from_value=low, to_value=high, step=0.0)])


#: name -> (default, descriptor, what a right value is)
PARAMETERS = {
    'scenario': ('', ParameterDescriptor(
        description='path of the scenario file (YAML, SPEC section 1)', read_only=True),
        'the path of a scenario file, e.g. -p scenario:=config/store_separation.yaml'),
    'rate_hz': (100.0, _double(
        'samples published per simulated second (stamps 1/rate_hz apart)', 0.01, 1e5),
        'a rate in Hz written as a double, 0.01 to 1e5, e.g. -p rate_hz:=100.0'),
    'real_time_factor': (1.0, _double(
        'simulated seconds per wall second; 0 runs as fast as possible; '
        'ignored with use_sim_time', 0.0, 1e4, read_only=False),
        'a double from 0 (as fast as possible) to 1e4, e.g. -p real_time_factor:=1.0'),
    'duration': (-1.0, _double(
        "simulated seconds to run, then finish and exit; < 0: the scenario's duration; "
        '0: until shut down', -1.0, 1e9),
        "a double: < 0 for the scenario's duration, 0 to run until shut down, "
        'else seconds'),
    'record': ('', ParameterDescriptor(
        description='MCAP file to record this run to (SPEC section 4); empty records nothing',
        read_only=True), 'a file path ending in .mcap, or empty'),
    'overwrite': (False, ParameterDescriptor(
        description='replace the record file if it exists', read_only=True),
        'true or false'),
}


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


def _vector3(msg, v):
    msg.x, msg.y, msg.z = float(v[0]), float(v[1]), float(v[2])


def _time_msg(msg, stamp_ns: int):
    msg.sec, msg.nanosec = divmod(int(stamp_ns), 1_000_000_000)


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
        self.wrenches = {}
        for k, joint in enumerate(model.joints):
            wrench = WrenchStamped()
            wrench.header.frame_id = world
            self.wrenches[k] = (node.create_publisher(
                WrenchStamped, f'joints/{joint.name}/wrench', TOPIC_QOS), wrench)
        self.applied = []   # scheduled loads, per source
        for body, source in sim.applied_sources:
            wrench = WrenchStamped()
            wrench.header.frame_id = world
            self.applied.append((node.create_publisher(
                WrenchStamped, f'bodies/{body}/applied/{source}', TOPIC_QOS), wrench))
        self.event_publisher = node.create_publisher(String, 'events', EVENT_QOS)
        self._events_sent = 0

    def stamp_ns(self, t: float) -> int:
        return self.start_ns + int(round(t * 1e9))

    def sample(self):
        sim = self.sim
        stamp_ns = self.stamp_ns(sim.t)
        position, quat = sim.position, sim.orientation
        velocity, rates = sim.velocity_body(), sim.rates
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
        if self.wrenches:
            force, moment = sim.joint_wrenches()
            for k, (publisher, wrench) in self.wrenches.items():
                _time_msg(wrench.header.stamp, stamp_ns)
                _vector3(wrench.wrench.force, force[k])
                _vector3(wrench.wrench.torque, moment[k])
                publisher.publish(wrench)
        if self.applied:
            for (publisher, wrench), load in zip(self.applied, sim.applied_loads()):
                _time_msg(wrench.header.stamp, stamp_ns)
                _vector3(wrench.wrench.force, load[:3])
                _vector3(wrench.wrench.torque, load[3:])
                publisher.publish(wrench)

    def events(self):
        for event in self.sim.events[self._events_sent:]:
            self.event_publisher.publish(String(data=json.dumps(event)))
            k = self.sim.model.joint_index(event['joint'])
            publisher = self.wrenches.pop(k, None)
            if publisher is not None:
                self.node.destroy_publisher(publisher[0])
        self._events_sent = len(self.sim.events)

    def received(self, item, t):
        """Leave inputs alone: they are not published back."""


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
        values = self._declare_parameters()
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
        self.real_time_factor = values['real_time_factor']

        self._python_log = logging.getLogger(f'cfem_ros.node.{id(self)}')
        self._python_log.propagate = False
        self._python_log.addHandler(_RosLogHandler(self.get_logger()))
        try:
            self.sim = Simulator(model, logger=self._python_log)
        except CfemError as err:
            raise StartupError(str(err)) from None

        self.recorder = self.state_recorder = None
        record = values['record']
        if record:
            try:
                self.recorder = Recorder(record, overwrite=values['overwrite'])
            except CfemError as err:
                raise StartupError(f'parameter record: {err}') from None
            self.state_recorder = StateRecorder(self.recorder, self.sim,
                                                namespace=self.get_namespace())
        self._publishers_sink = _Publishers(self, self.sim)
        outputs = [self._publishers_sink] + ([self.state_recorder] if self.state_recorder else [])
        self.session = Session(self.sim, rate_hz=self.rate_hz, duration=self.duration,
                               outputs=outputs, warn=self.get_logger().warning)
        self.scenario_path = values['scenario']
        self.start_ns: Optional[int] = None
        self._early = []
        self._last_lag_warning = -math.inf
        self._timer = None

        for body in model.bodies:
            self.create_subscription(
                WrenchStamped, f'bodies/{body.name}/wrench',
                lambda msg, name=body.name: self._on_wrench(name, msg), TOPIC_QOS)
        self._release_sub = self.create_subscription(String, 'release', self._on_release,
                                                     TOPIC_QOS)
        self.add_on_set_parameters_callback(self._on_set_parameters)

        mode = 'following /clock' if self.sim_time else (
            'as fast as possible' if self.real_time_factor == 0
            else f'at {self.real_time_factor:g}x real time')
        self.get_logger().info(
            f'scenario {model.name!r} from {self.scenario_path}: {len(model.bodies)} bodies, '
            f'{len(model.joints)} joints, {self.sim.dof} degrees of freedom; dt {model.dt:g} s, '
            f'publishing at {self.rate_hz:g} Hz {mode}'
            + (f'; recording to {record}' if record else ''))
        if self.sim_time:
            self.create_subscription(ClockMsg, '/clock', self._on_clock, CLOCK_QOS)
            self.get_logger().info('waiting for /clock (use_sim_time is true)')
        else:
            self._begin(self.get_clock().now().nanoseconds)

    # ------------------------------------------------------------ parameters

    def _declare_parameters(self) -> dict:
        values = {}
        for name, (default, descriptor, expected) in PARAMETERS.items():
            try:
                values[name] = self.declare_parameter(name, default, descriptor).value
            except ParameterException as err:
                raise StartupError(f'parameter {name}: {err}; expected {expected}') from None
        if not values['scenario']:
            raise StartupError('parameter scenario: not set; expected '
                               + PARAMETERS['scenario'][2])
        return values

    def _on_set_parameters(self, parameters) -> SetParametersResult:
        for parameter in parameters:
            if parameter.name == 'real_time_factor':
                self._set_real_time_factor(float(parameter.value))
            elif parameter.name == 'use_sim_time' and bool(parameter.value) != self.sim_time:
                return SetParametersResult(
                    successful=False, reason='use_sim_time is fixed once the node has started')
        return SetParametersResult(successful=True)

    # ---------------------------------------------------------------- pacing

    def _begin(self, start_ns: int):
        """Start the run: simulated time 0 is stamp start_ns."""
        self.start_ns = int(start_ns)
        self._publishers_sink.start_ns = self.start_ns
        if self.state_recorder is not None:
            self.state_recorder.start_ns = self.start_ns
            self.recorder.add_metadata(run_metadata(
                self.sim.model, self.scenario_path, self.rate_hz, self.start_ns,
                node=self.get_fully_qualified_name(), use_sim_time=str(self.sim_time).lower()))
        for item in self._early:
            self._submit(*item)
        self._early.clear()
        self.session.start()
        if not self.sim_time:
            self._wall_ref = time.monotonic()
            self._sim_ref = 0.0
            self._start_timer()

    def _start_timer(self):
        if self._timer is not None:
            self.destroy_timer(self._timer)
        period = (1.0 / self.rate_hz / self.real_time_factor if self.real_time_factor > 0
                  else 0.001)
        self._timer = self.create_timer(period, self._on_tick,
                                        clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _wall_target(self, now: float) -> float:
        if self.real_time_factor == 0:
            return math.inf
        return self._sim_ref + (now - self._wall_ref) * self.real_time_factor

    def _set_real_time_factor(self, factor: float):
        if self.sim_time or self.start_ns is None:
            self.real_time_factor = factor
            return
        now = time.monotonic()
        target = self._wall_target(now)
        self._sim_ref = self.sim.t if math.isinf(target) else target
        self._wall_ref = now
        self.real_time_factor = factor
        self._start_timer()
        self.get_logger().info(f'real_time_factor set to {factor:g}')

    def _on_tick(self):
        now = time.monotonic()
        target = self._wall_target(now)
        self._run_to(target, deadline=now + TICK_BUDGET)
        lag = target - self.sim.t
        if (math.isfinite(lag) and not self.session.finished
                and lag > max(2.0 / self.rate_hz, 2 * self.sim.dt)
                and now - self._last_lag_warning > LAG_WARNING_PERIOD):
            self._last_lag_warning = now
            self.get_logger().warning(
                f'falling behind real time: simulated time {self.sim.t:.3f} s lags the '
                f'clock by {lag:.3f} s at real_time_factor {self.real_time_factor:g}; '
                'lower real_time_factor or rate_hz')

    def _on_clock(self, msg: ClockMsg):
        clock_ns = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
        if self.start_ns is None:
            self.get_logger().info(f'/clock started at {clock_ns * 1e-9:.9f} s; '
                                   'simulated time 0 is that stamp')
            self._begin(clock_ns)
            return
        if clock_ns < self.start_ns + int(round(self.sim.t * 1e9)):
            self.get_logger().warning('/clock went back; ignored (restart the node to '
                                      'replay from an earlier time)', throttle_duration_sec=5.0)
            return
        self._run_to((clock_ns - self.start_ns) / 1e9)

    def _run_to(self, limit: float, deadline: float = math.inf):
        """Run the session on to simulated time limit, within a wall deadline."""
        session = self.session
        while (not session.finished and session.next_sample_time <= limit
               and time.monotonic() < deadline):
            session.advance(session.next_sample_time)
        if math.isfinite(limit) and not session.finished and time.monotonic() < deadline:
            session.advance(limit)
        if session.finished and self.exit_code is None:
            self._end()

    def _end(self):
        if self.session.failed:
            self.get_logger().error(f'the run failed {self.sim.message}')
            self.exit_code = EXIT_FAILED
        else:
            self.get_logger().info(f'run complete at t = {self.sim.t:.9g} s')
            self.exit_code = EXIT_OK
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None
        self.close()

    def close(self):
        """Finish the recording (safe to call more than once)."""
        if self.recorder is not None:
            self.recorder.finish()
            self.get_logger().info(f'recording {self.recorder.path}: '
                                   f'{self.recorder.message_count} messages')
            self.recorder = None

    # ---------------------------------------------------------------- inputs

    def _on_wrench(self, body: str, msg: WrenchStamped):
        stamp = msg.header.stamp
        header_ns = stamp.sec * 1_000_000_000 + stamp.nanosec
        f, m = msg.wrench.force, msg.wrench.torque
        topic = self.resolve_topic_name(f'bodies/{body}/wrench')
        self._submit(topic, wrench_input(body, [f.x, f.y, f.z], [m.x, m.y, m.z],
                                         msg.header.frame_id, header_ns=header_ns))

    def _on_release(self, msg: String):
        self._submit(self._release_sub.topic_name, release_input(msg.data.strip()))

    def _submit(self, topic: str, item):
        if self.exit_code is not None:
            return
        if self.start_ns is None:
            self._early.append((topic, item))
            return
        if self.sim_time and item.kind == 'wrench' and item.header_ns:
            t = (item.header_ns - self.start_ns) / 1e9
            if t > self.sim.t:
                item = replace(item, time=t)
        try:
            self.session.submit(item)
        except ValueError as err:
            self.get_logger().warning(f'{topic}: message not applied: {err}')
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
        try:
            node = CfemNode()
        except CfemError as err:
            print(f'ERROR: {err}', file=sys.stderr)
            return EXIT_BAD_INPUT
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        while not stop and node.exit_code is None and rclpy.ok():
            executor.spin_once(timeout_sec=0.05)
        if stop:
            node.get_logger().info(
                f'{signal.Signals(stop[0]).name} received at simulated t = {node.sim.t:.9g} s;'
                ' shutting down')
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
