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

import logging
import math
import os
import signal
import sys
import time
from typing import Optional

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.engine.startcheck import CannotStart, refuse_start
from cfem_ros.core.errors import CfemError
from cfem_ros.core.scenario.parse import load_scenario
from cfem_ros.recording import schema
from cfem_ros.recording.errors import OutputError
from cfem_ros.ros import control as simulation_control, parameters
from cfem_ros.ros.noderun import NodeRun
from cfem_ros.ros.pacing import WallPace
from cfem_ros.ros.parameters import PARAMETERS, StartupError  # noqa: F401 - for users
from cfem_ros.ros.publishers import Publishers
from cfem_ros.ros.recording import NodeRecording
from cfem_ros.ros.refusals import bounded, RosLogHandler, Throttle
from cfem_ros.ros.runcontrol import RunControl
from cfem_ros.ros.stepping import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_OK, Stepping
from cfem_ros.ros.subscriptions import Subscriptions
from rcl_interfaces.msg import SetParametersResult
import rclpy
from rclpy.exceptions import InvalidTopicNameException
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rclpy.validate_full_topic_name import validate_full_topic_name

#: Environment variable: seconds to sleep at the end of set-up (tests use it
#: to prove that the start stamp is taken after set-up).
SETUP_DELAY_ENV = 'CFEM_NODE_SETUP_DELAY'
#: Most wall time the node spins on after its run ended for a goal's result, s; and
#: how long after the result was made (sending it takes a few turns of the executor).
SETTLE_S = 2.0
SETTLE_AFTER_S = 0.2


def _topic_name_error(node, model, err) -> str:
    """One line for a body or joint whose name makes a topic ROS 2 refuses."""
    reason = str(err).split('\n', 1)[0].removeprefix('Invalid topic name: ').rstrip(':')
    for kind, items in (('bodies', model.bodies), ('joints', model.joints)):
        for item in items:
            topic = (schema.JOINT_WRENCH.relative(joint=item.name) if kind == 'joints'
                     else schema.POSE.relative(body=item.name))
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

    The node holds its parts and they act on one another through the node's
    public attributes: ``run`` (``noderun.NodeRun``: the simulator, its
    session, the publishers and the recording), ``stepping`` (its start,
    pacing and end, ``stepping.Stepping``), ``inputs`` (the subscriptions,
    ``subscriptions.Subscriptions``), ``control`` (pause, play, step, reset,
    set a body's state: ``runcontrol.RunControl``) and
    ``simulation_services`` (the ``simulation_interfaces`` services on it,
    ``control.SimulationServices``; None without the types).

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
        #: Simulated seconds the run stays behind /clock (use_sim_time).
        self.input_window = values['input_window'] if self.sim_time else 0.0
        self.scenario_path = values['scenario']
        #: Refused inputs: one warning line per topic and reason per second.
        self.refusals = Throttle(self.get_logger())
        self._diagnosed = False

        python_log = logging.getLogger(f'cfem_ros.node.{id(self)}')
        python_log.propagate = False
        python_log.setLevel(logging.INFO)   # the ROS logger filters by its own level
        python_log.addHandler(RosLogHandler(self.get_logger()))
        try:
            sim = Simulator(model, logger=python_log)
        except CfemError as err:
            raise StartupError(str(err)) from None
        try:   # what cfem-sim check refuses, the node refuses in its words
            warnings = refuse_start(sim, values['scenario'])
        except CannotStart as err:
            raise StartupError(str(err)) from None
        for text in warnings:
            self.get_logger().warning(f"{values['scenario']}: {text}")

        self.stepping = Stepping(self)   # /clock, subscribed before the inputs
        # topics first: a name ROS refuses stops the node before a file is made
        try:
            publishers = Publishers(self, sim)
            self.inputs = Subscriptions(self, model, values['input_queue_depth'])
        except InvalidTopicNameException as err:
            raise StartupError(_topic_name_error(self, model, err)) from None

        recording = (NodeRecording(self, sim, values['record'], values['overwrite'])
                     if values['record'] else None)
        self.run = NodeRun(sim, publishers, recording, rate_hz=self.rate_hz,
                           duration=self.duration, following_clock=self.sim_time,
                           interpolate=bool(values['interpolate_odometry']),
                           warn=self.refusals.warning, log_warning=self.get_logger().warning)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.control = RunControl(self, paused=bool(values['paused']))
        self.simulation_services = simulation_control.serve(self, self.control)

        mode = 'following /clock' if self.sim_time else (
            'as fast as possible' if self.pace.factor == 0
            else f'at {self.pace.factor:g}x real time')
        self.get_logger().info(
            f'scenario {model.name!r} from {self.scenario_path}: {len(model.bodies)} bodies, '
            f'{len(model.joints)} joints, {sim.dof} degrees of freedom; dt {model.dt:g} s, '
            f'publishing at {self.rate_hz:g} Hz {mode}'
            + (f"; recording to {values['record']}" if values['record'] else ''))
        warm_up(model, publishers)
        if self.sim_time:
            self.get_logger().info(f'waiting for /clock (use_sim_time is true); the simulation '
                                   f'stays input_window {self.input_window:g} s behind it')
        else:
            self.stepping.begin(None)

    @property
    def sim(self) -> Simulator:
        """Return the simulator of the run now (a reset makes another)."""
        return self.run.sim

    @property
    def recording(self) -> Optional[NodeRecording]:
        """Return the node's recording; None when it records nothing, or once finished."""
        return self.run.recording

    def _on_set_parameters(self, parameters) -> SetParametersResult:
        for parameter in parameters:
            if parameter.name == 'real_time_factor':
                self.stepping.set_real_time_factor(float(parameter.value))
            elif parameter.name == 'use_sim_time' and bool(parameter.value) != self.sim_time:
                return SetParametersResult(
                    successful=False, reason='use_sim_time is fixed once the node has started')
        return SetParametersResult(successful=True)

    def close(self):
        """Finish the recording, and say how many inputs were refused (safe to call twice)."""
        self.refusals.flush()
        self.inputs.log_refused()
        if not self._diagnosed:
            self._diagnosed = True
            self.get_logger().info(f'diagnostics: {self.run.timing.summary()}, '
                                   f'{self.inputs.queues.summary()}')
        self.run.finish_recording()

    def recording_failed(self, err):
        """
        End the run after a write of the recording failed (a full disk, a file size limit).

        The recording keeps what is complete and says so (``NodeRecording.failed``);
        the node ends with ``EXIT_FAILED``: a recording node whose recording
        failed does not go on publishing a run no file will hold.
        """
        self.stepping.stop_timer()
        self.run.recording_failed(err)
        self.exit_code = EXIT_FAILED


def settle(executor, node):
    """
    Spin on after the run ended until a simulate_steps goal's result is out (SETTLE_S at most).

    A goal whose steps reach the run's end gets its result before the node
    exits: the result is made in a task of the executor, then sent when the
    client's request for it is served.
    """
    services = node.simulation_services
    if services is None:
        return
    deadline = time.monotonic() + SETTLE_S
    while rclpy.ok() and time.monotonic() < deadline and (
            services.settling() or time.monotonic() - services.finished_at < SETTLE_AFTER_S):
        executor.spin_once(timeout_sec=0.01)


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
        if not stop:
            settle(executor, node)
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
