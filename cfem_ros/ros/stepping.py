# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The node's stepping loop: when the run starts, how it is paced, how it ends.

In real time a steady-clock timer ticks once per sample period divided by
``real_time_factor`` and runs the session on to where the wall clock says;
following ``/clock``, each message runs it on to that time, a slice of wall
time at a go. ``Stepping`` is a part that ``node.CfemNode`` holds: it keeps
the clock's state and its timers, and acts on the node's run (``node.run``,
``noderun.NodeRun``) and inputs (``node.inputs``) through their public faces.
"""

import json
import math
import time
from typing import Optional

from cfem_ros.core.engine.events import Event, Status
from cfem_ros.ros.qos import CLOCK_QOS
from cfem_ros.ros.stamps import ClockLog, divergence_advice
from cfem_ros.ros.subscriptions import taken
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg
from std_msgs.msg import String

EXIT_OK = 0
EXIT_FAILED = 1
#: The run stopped at a contact (scenario `contacts:` with on_contact: stop).
EXIT_CONTACT = 3
EXIT_BAD_INPUT = 2

#: Wall time one real-time tick may spend stepping before it yields, s.
TICK_BUDGET = 0.05
#: Seconds between two "falling behind" warnings.
LAG_WARNING_PERIOD = 5.0
#: Most simulated seconds one /clock message may move the simulation on (a jump beyond is
#: ignored with a warning); a jump within it is simulated TICK_BUDGET of wall time at a go.
MAX_CLOCK_JUMP = 3600.0
#: Wall seconds /clock stands still before the run goes on to it, past input_window.
CLOCK_STILL_S = 1.0


class Stepping:
    """
    The run's start, pacing and end: the clocks and timers of a node's run.

    Parameters
    ----------
    node : CfemNode
        The node that holds it: its timers, logger and subscriptions are
        made on it, and its ``run``, ``inputs`` and ``control`` are the
        parts stepped, fed and obeyed.

    Attributes
    ----------
    clock_limit : float or None
        The simulated time /clock last gave, s (None before the first).
    clock_moved : bool
        A /clock was taken to time an input (``clock_of``): the run goes on after it.

    """

    def __init__(self, node):
        self.node = node
        #: The /clock times taken, by their senders' source timestamps (``clock_of``).
        self._clocks = ClockLog()
        self._clock_subscriptions = []
        if node.sim_time:   # before the inputs: in each wait, /clock is taken before them
            self._clock_subscriptions.append(node.create_subscription(
                ClockMsg, '/clock', self._on_clock, CLOCK_QOS))
        self.clock_limit: Optional[float] = None
        self._clock_wall = math.inf   # when /clock last moved on (monotonic s)
        self._clock_still = 0   # the clock watch's looks since then
        self.clock_moved = False
        self._last_lag_warning = -math.inf
        self._timer = None
        self._catch_up_timer = None   # goes on toward /clock's time, a slice at a time

    def begin(self, start_ns: Optional[int]):
        """
        Start the run: simulated time 0 is stamp start_ns (None: the ROS time now).

        In real time the start stamp and the wall-clock reference are taken
        together, after all set-up: sample k is published at about stamp
        start_ns + k / rate_hz in ROS time.
        """
        node, run = self.node, self.node.run
        if start_ns is None:
            # the timer's ticks fall on the sample times: it starts with the clocks
            self._start_timer()
            start_ns = node.get_clock().now().nanoseconds
            node.pace.start(time.monotonic())
        run.begin(start_ns)
        if node.sim_time:
            self.clock_limit = 0.0
            self._clock_wall = time.monotonic()
            node.create_timer(CLOCK_STILL_S / 2, self._watch_clock,
                              clock=Clock(clock_type=ClockType.STEADY_TIME))
        if run.recording is not None:
            run.recording.begin(run.start_ns, node.scenario_path, node.rate_hz,
                                use_sim_time=str(node.sim_time).lower(),
                                interpolate_odometry=str(run.gate.interpolate).lower())
        node.inputs.submit_early()
        if not node.sim_time or node.control.paused:
            run.session.start()   # paused: the initial state is published, then it waits
        # following /clock, the session starts on its first advance, once a carrier's
        # first odometry has come (``OdometryGate``): odometry stamped at t = 0 is applied before
        # the t = 0 sample, as in the offline replay

    def _start_timer(self):
        node = self.node
        self.stop_timer()
        period = 1.0 / node.rate_hz / node.pace.factor if node.pace.factor > 0 else 0.001
        self._timer = node.create_timer(period, self._on_tick,
                                        clock=Clock(clock_type=ClockType.STEADY_TIME))

    def stop_timer(self):
        """Stop the real-time timer (the run ended), if it ticks."""
        if self._timer is not None:
            self.node.destroy_timer(self._timer)
            self._timer = None

    def set_real_time_factor(self, factor: float):
        """Go on at another real-time factor from where the run is (parameter change)."""
        node = self.node
        if node.sim_time or node.run.start_ns is None:
            node.pace.factor = factor
            return
        node.pace.retime(time.monotonic(), node.run.sim.t, factor)
        self._start_timer()
        node.get_logger().info(f'real_time_factor set to {factor:g}')

    def reset_stamp(self) -> int:
        """Return the stamp of a reset run's t = 0: the latest /clock, or the ROS time now."""
        node = self.node
        if node.sim_time:
            return node.run.start_ns + round((self.clock_limit or 0.0) * 1e9)
        return node.get_clock().now().nanoseconds

    def restarted(self):
        """Follow /clock again from the reset run's t = 0."""
        if self.node.sim_time:
            self.clock_limit = 0.0

    def _on_tick(self):
        node = self.node
        if node.control.paused:
            return
        run = node.run
        now = time.monotonic()
        target = node.pace.target(now)
        self.run_to(target, deadline=now + TICK_BUDGET)
        lag = run.gate.held(target) - run.sim.t   # waiting for odometry is not falling behind
        if (math.isfinite(lag) and not run.session.finished
                and lag > max(2.0 / node.rate_hz, 2 * run.sim.dt)
                and now - self._last_lag_warning > LAG_WARNING_PERIOD):
            self._last_lag_warning = now
            node.get_logger().warning(
                f'falling behind real time: simulated time {run.sim.t:.3f} s lags the '
                f'clock by {lag:.3f} s at real_time_factor {node.pace.factor:g}; '
                'lower real_time_factor or rate_hz')

    def _on_clock(self, msg: ClockMsg, info=None):
        """
        Follow a /clock message: take the inputs waiting, then run toward its time.

        The inputs already in the node's queues were sent before this /clock
        (a player sends a message's /clock, then it): taken first, each takes
        effect at its stamp however long the node was busy before (SPEC 3).
        """
        if self._took_clock(msg, info):
            self.node.inputs.take_waiting()
            self.catch_up()

    def _took_clock(self, msg: ClockMsg, info) -> bool:
        """Take a /clock message's time; return whether the run may go on toward it."""
        node, run = self.node, self.node.run
        clock_ns = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
        if clock_ns < 0:
            node.refusals.warning(f'/clock: {clock_ns * 1e-9:.9g} s is a negative time; '
                                  'ignored')
            return False
        if run.start_ns is None:
            node.get_logger().info(f'/clock started at {clock_ns * 1e-9:.9f} s; '
                                   'simulated time 0 is that stamp')
            self._clocks.took(clock_ns, info)
            self.begin(clock_ns)
            return False
        if clock_ns < run.start_ns + int(round(run.sim.t * 1e9)):
            node.get_logger().warning('/clock went back; ignored (restart the node to '
                                      'replay from an earlier time)', throttle_duration_sec=5.0)
            return False
        limit = (clock_ns - run.start_ns) / 1e9
        if limit - run.sim.t > MAX_CLOCK_JUMP:
            node.refusals.warning(
                f'/clock jumped {limit - run.sim.t:.6g} s ahead of the simulation (at '
                f't = {run.sim.t:.6g} s); more than {MAX_CLOCK_JUMP:g} s at once is ignored '
                '(restart the node to follow a clock that far away)')
            return False
        if limit > self.clock_limit:
            self._clock_wall, self._clock_still = time.monotonic(), 0
        self._clocks.took(clock_ns, info)
        self.clock_limit = limit
        return True

    def clock_of(self, info) -> float:
        """
        Return the simulated time of the last /clock sent before an unstamped input.

        The /clock messages waiting are taken first (their times noted, the
        run not moved on); then the input's source timestamp picks the /clock
        its sender had sent before it (``ClockLog``), whichever the node took
        last: a release command takes effect at the same time on an idle or
        a busy node.
        """
        for sub in self._clock_subscriptions:
            for msg, clock_info in taken(sub):
                self.clock_moved = self._took_clock(msg, clock_info) or self.clock_moved
        clock_ns = self._clocks.before(info)
        start_ns = self.node.run.start_ns
        if clock_ns is None or start_ns is None:
            return self.clock_limit
        return max(0.0, (clock_ns - start_ns) / 1e9)

    def _clock_target(self) -> float:
        """
        Return the simulated time the run may go to: ``input_window`` behind /clock.

        When /clock stands still (the end of a replay: ``CLOCK_STILL_S`` of
        wall time, seen by two looks of the clock watch with the node's
        queues taken in between), the run goes on to /clock itself.
        """
        if self._clock_still >= 2:
            return self.clock_limit
        return self.clock_limit - self.node.input_window

    def _watch_clock(self):
        """Count the looks that find /clock still for CLOCK_STILL_S; then run on to it."""
        if self.clock_limit is None or self.node.exit_code is not None:
            return
        if time.monotonic() - self._clock_wall < CLOCK_STILL_S:
            self._clock_still = 0
            return
        self._clock_still += 1
        if self._clock_still == 2:
            self.node.inputs.take_waiting()
            self.catch_up()

    def catch_up(self):
        """Run toward /clock's time for TICK_BUDGET of wall time; a timer does the rest."""
        node = self.node
        target = self._clock_target()
        self.run_to(target, deadline=time.monotonic() + TICK_BUDGET)
        run = node.run
        session = run.session
        behind = (node.exit_code is None and not session.finished
                  and session.next_sample_time <= run.gate.held(target))
        if behind and self._catch_up_timer is None:   # signals and messages come between
            self._catch_up_timer = node.create_timer(
                0.001, self.catch_up, clock=Clock(clock_type=ClockType.STEADY_TIME))
        elif not behind and self._catch_up_timer is not None:
            node.destroy_timer(self._catch_up_timer)
            self._catch_up_timer = None

    def run_to(self, limit: float, deadline: float = math.inf):
        """Run the session on to simulated time limit, within a wall deadline (not paused)."""
        node, run = self.node, self.node.run
        session = run.session
        if node.control.paused:
            return
        limit = run.gate.held(limit)
        if limit < 0.0 and not session.started:   # following /clock: t = 0 not yet
            return
        while (not session.finished and session.next_sample_time <= limit
               and time.monotonic() < deadline):
            session.advance(session.next_sample_time)
        if math.isfinite(limit) and not session.finished and time.monotonic() < deadline:
            session.advance(limit)
        if session.finished and node.exit_code is None:
            self.end()

    def end(self):
        """End the node's run (reached its duration, failed or stopped at a contact)."""
        node, run = self.node, self.node.run
        sim = run.sim
        if sim.status is Status.CONTACT:
            node.get_logger().warning(f'run stopped: {sim.message}')
            node.exit_code = EXIT_CONTACT
        elif run.session.stopped:   # a failure or a table's outside: stop (exit 1)
            sim.message = divergence_advice(sim.message, sim.failure, run.timing.late_inputs,
                                            run.odometry_check.warned)
            node.get_logger().error(f'the run failed {sim.message}')
            run.publishers.event_publisher.publish(String(data=json.dumps(
                {'event': Event.ERROR, 'time': sim.t, 'message': sim.message})))
            if run.recording is not None:
                run.recording.state.failed()
            node.exit_code = EXIT_FAILED
        else:
            node.get_logger().info(f'run complete at t = {sim.t:.9g} s')
            node.exit_code = EXIT_OK
        self.stop_timer()
        node.close()
