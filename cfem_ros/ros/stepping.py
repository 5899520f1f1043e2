# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The node's stepping loop: when the run starts, how it is paced, how it ends.

In real time a steady-clock timer ticks once per sample period divided by
``real_time_factor`` and runs the session on to where the wall clock says;
following ``/clock``, each message runs it on to that time, a slice of wall
time at a go. ``Stepping`` is a part of ``node.CfemNode``, on its state.
"""

import json
import math
import time
from typing import Optional

from cfem_ros.ros.stamps import divergence_advice
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
    """The run's start, pacing and end (a part of ``CfemNode``)."""

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
            self._clock_wall = time.monotonic()
            self.create_timer(CLOCK_STILL_S / 2, self._watch_clock,
                              clock=Clock(clock_type=ClockType.STEADY_TIME))
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

    def _on_clock(self, msg: ClockMsg, info=None):
        """
        Follow a /clock message: take the inputs waiting, then run toward its time.

        The inputs already in the node's queues were sent before this /clock
        (a player sends a message's /clock, then it): taken first, each takes
        effect at its stamp however long the node was busy before (SPEC 3).
        """
        if self._took_clock(msg, info):
            self._take_waiting_inputs()
            self._catch_up()

    def _took_clock(self, msg: ClockMsg, info) -> bool:
        """Take a /clock message's time; return whether the run may go on toward it."""
        clock_ns = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
        if clock_ns < 0:
            self._refusals.warning(f'/clock: {clock_ns * 1e-9:.9g} s is a negative time; '
                                   'ignored')
            return False
        if self.start_ns is None:
            self.get_logger().info(f'/clock started at {clock_ns * 1e-9:.9f} s; '
                                   'simulated time 0 is that stamp')
            self._clocks.took(clock_ns, info)
            self._begin(clock_ns)
            return False
        if clock_ns < self.start_ns + int(round(self.sim.t * 1e9)):
            self.get_logger().warning('/clock went back; ignored (restart the node to '
                                      'replay from an earlier time)', throttle_duration_sec=5.0)
            return False
        limit = (clock_ns - self.start_ns) / 1e9
        if limit - self.sim.t > MAX_CLOCK_JUMP:
            self._refusals.warning(
                f'/clock jumped {limit - self.sim.t:.6g} s ahead of the simulation (at '
                f't = {self.sim.t:.6g} s); more than {MAX_CLOCK_JUMP:g} s at once is ignored '
                '(restart the node to follow a clock that far away)')
            return False
        if limit > self._clock_limit:
            self._clock_wall, self._clock_still = time.monotonic(), 0
        self._clocks.took(clock_ns, info)
        self._clock_limit = limit
        return True

    def _clock_of(self, info) -> float:
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
                self._clock_moved = self._took_clock(msg, clock_info) or self._clock_moved
        clock_ns = self._clocks.before(info)
        if clock_ns is None or self.start_ns is None:
            return self._clock_limit
        return max(0.0, (clock_ns - self.start_ns) / 1e9)

    def _clock_target(self) -> float:
        """
        Return the simulated time the run may go to: ``input_window`` behind /clock.

        When /clock stands still (the end of a replay: ``CLOCK_STILL_S`` of
        wall time, seen by two looks of the clock watch with the node's
        queues taken in between), the run goes on to /clock itself.
        """
        if self._clock_still >= 2:
            return self._clock_limit
        return self._clock_limit - self.input_window

    def _watch_clock(self):
        """Count the looks that find /clock still for CLOCK_STILL_S; then run on to it."""
        if self._clock_limit is None or self.exit_code is not None:
            return
        if time.monotonic() - self._clock_wall < CLOCK_STILL_S:
            self._clock_still = 0
            return
        self._clock_still += 1
        if self._clock_still == 2:
            self._take_waiting_inputs()
            self._catch_up()

    def _catch_up(self):
        """Run toward /clock's time for TICK_BUDGET of wall time; a timer does the rest."""
        target = self._clock_target()
        self._run_to(target, deadline=time.monotonic() + TICK_BUDGET)
        session = self.session
        behind = (self.exit_code is None and not session.finished
                  and session.next_sample_time <= self.gate.held(target))
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
        if limit < 0.0 and not session.started:   # following /clock: t = 0 not yet
            return
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
