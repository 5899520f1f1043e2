# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
When a live input takes effect: at its header stamp (SPEC section 3).

Simulated time is stamp - the start stamp. A stamped wrench or odometry
message whose time is still ahead waits for it; one stamped before the
simulation's current time is late: it applies at once and is counted
(``late_inputs``); late odometry then says where the body is now by its own
extrapolation from its stamp (``Input.at``), so an offline replay of the
recording, which logs it where it took effect, moves the body as the node
did. A zero stamp means "unstamped": the message applies when it arrives,
as release commands (a String, no stamp) always do.

``OdometryCheck`` warns, once per topic, when an odometry stream's positions
and velocities disagree by more than the spacing of its samples explains
(stamps that are not the measurement times, velocities in the wrong axes).
Plain bookkeeping: no rclpy.
"""

from __future__ import annotations

from collections import deque
from dataclasses import replace
import math
from typing import Callable, Optional

from cfem_ros.core import rotations
from cfem_ros.core.engine.events import Failure
from cfem_ros.core.engine.kernelcalls import SMALLER_DT
from cfem_ros.core.run.inputs import Input, InputKind, odometry_parts, stamp_problem
import numpy as np

#: What a position may differ from the velocities' account of it by, beyond what the
#: spacing explains: a fraction of the distance travelled, and an absolute floor (m).
ODOMETRY_RELATIVE = 0.01
ODOMETRY_ABSOLUTE = 1e-6
#: What a late input's warning advises, in real time and following /clock.
CURE_REAL_TIME = 'lower real_time_factor, or follow /clock'
#: /clock messages a ClockLog remembers (10 s of a player's 100 Hz).
CLOCK_LOG_SIZE = 1000
CURE_CLOCK = ('raise input_window (the simulated seconds the node stays behind /clock), or '
              'play the inputs on time')


def next_ns(t: float) -> float:
    """Return the first whole nanosecond at or after t, s (what a recording's log time holds)."""
    ns = math.ceil(t * 1e9)
    while ns / 1e9 < t:
        ns += 1
    return ns / 1e9


class InputTiming:
    """
    Give a live input the simulated time it takes effect at, from its stamp.

    Parameters
    ----------
    sim : Simulator
        Whose current time ``sim.t`` tells late from early.
    warn : callable
        Takes a warning line (the first late input of each topic).
    cure : str
        What the warning advises for late inputs (the node's pacing decides:
        a lower ``real_time_factor``, or a wider ``input_window``).

    Attributes
    ----------
    start_ns : int or None
        The stamp of simulated time 0.
    late_inputs : int
        Stamped inputs that came after their time (applied at once).
    late_topics : dict
        Topic -> its late inputs (what the diagnostics line names).

    """

    def __init__(self, sim, warn: Callable[[str], None], cure: str = CURE_REAL_TIME):
        self.sim = sim
        self.warn = warn
        self.cure = cure
        self.start_ns: Optional[int] = None
        self.late_inputs = 0
        self.late_topics = {}

    def timed(self, topic: str, item: Input, now: Optional[float]) -> Input:
        """
        Return item with the time it takes effect at (None: at once).

        now: where the simulation should be by its clock (``/clock``, or the
        wall clock in real time; None: no clock, as fast as possible), the
        time of an unstamped input and of a late one if that is ahead.
        """
        if stamp_problem(item.header_ns):
            return item   # refused by the session, with the reason
        if (item.kind in (InputKind.WRENCH, InputKind.ODOM) and item.header_ns
                and self.start_ns is not None):
            own = (item.header_ns - self.start_ns) / 1e9
            if own >= self.sim.t:
                return replace(item, time=own)
            self._late(topic, own)
            if item.kind is InputKind.ODOM:
                item = replace(item, at=own)
        at = next_ns(self.sim.t)   # a recording's log time holds it exactly
        if now is not None and math.isfinite(now):
            at = max(at, now)
        return replace(item, time=at) if at > self.sim.t else item

    def _late(self, topic: str, own: float):
        self.late_inputs += 1
        first = topic not in self.late_topics
        self.late_topics[topic] = self.late_topics.get(topic, 0) + 1
        if not first:
            return
        self.warn(f'{topic}: a message stamped {own:.6f} s (simulated time), '
                  f'{self.sim.t - own:.6f} s before the simulated time it arrived at '
                  f'(t = {self.sim.t:.6f} s), was applied at once; further late messages are '
                  f'counted (late_inputs); the simulation runs ahead of its inputs: {self.cure}')

    def summary(self) -> str:
        """Return ``late_inputs N`` and, if any, the topics they came on with their counts."""
        if not self.late_inputs:
            return 'late_inputs 0'
        return f'late_inputs {self.late_inputs} (' + ', '.join(
            f'{count} on {topic}' for topic, count in sorted(self.late_topics.items())) + ')'


def source_ns(info) -> int:
    """Return a message's source timestamp (its sender's system time of sending), ns; 0: none."""
    return int(info.get('source_timestamp') or 0) if info else 0


class ClockLog:
    """
    The /clock times a node took, with their senders' source timestamps.

    An unstamped input (a release command) takes effect at the last /clock
    its sender had published before it: the order in which a player (one
    process, one system clock) sent them, which holds across topics, not the
    order in which a busy node happened to take them. Plain bookkeeping.
    """

    def __init__(self, size: int = CLOCK_LOG_SIZE):
        self._log = deque(maxlen=size)   # (source ns, clock ns), as taken
        #: The /clock taken last, ns (None before the first).
        self.latest: Optional[int] = None

    def took(self, clock_ns: int, info):
        """Note a /clock of clock_ns taken with this MessageInfo."""
        self.latest = int(clock_ns)
        source = source_ns(info)
        if source:
            self._log.append((source, self.latest))

    def before(self, info) -> Optional[int]:
        """
        Return the /clock sent last before a message of this MessageInfo, ns.

        Without a source timestamp, the /clock taken last; before every
        /clock remembered, the first of them.
        """
        source = source_ns(info)
        if not source or not self._log:
            return self.latest
        for sent, clock_ns in reversed(self._log):
            if sent <= source:
                return clock_ns
        return self._log[0][1]


class OdometryCheck:
    """
    Warn once per topic when odometry positions and velocities disagree.

    Between two messages (in stamp order) the position should move by the
    mean of their world velocities times the time between their stamps, to
    within half the change of velocity times that time (what a smooth motion
    can differ from the trapezoid by) plus ``ODOMETRY_RELATIVE`` of the
    distance and ``ODOMETRY_ABSOLUTE``.
    """

    def __init__(self, warn: Callable[[str], None]):
        self.warn = warn
        self._last = {}   # topic -> (stamp ns, position, world velocity)
        self.warned = set()

    def check(self, topic: str, item: Input):
        """Compare an odometry message with the topic's previous one."""
        if item.kind is not InputKind.ODOM or not item.header_ns or topic in self.warned:
            return
        position, quaternion, velocity, _ = odometry_parts(item.values)
        if not np.isfinite(item.values).all() or not 0.999 < np.linalg.norm(quaternion) < 1.001:
            return   # refused elsewhere
        world = rotations.matrices(quaternion[None] / np.linalg.norm(quaternion))[0] @ velocity
        last = self._last.get(topic)
        self._last[topic] = (item.header_ns, position.copy(), world)
        if last is None or item.header_ns <= last[0]:
            return
        span = (item.header_ns - last[0]) / 1e9
        moved = position - last[1]
        explained = 0.5 * (world + last[2]) * span
        allowed = (0.5 * np.linalg.norm(world - last[2]) * span
                   + ODOMETRY_RELATIVE * np.linalg.norm(explained) + ODOMETRY_ABSOLUTE)
        error = np.linalg.norm(moved - explained)
        if error > allowed:
            self.warned.add(topic)
            self.warn(
                f'{topic}: positions and velocities disagree: between the stamps '
                f'{last[0] * 1e-9:.6f} s and {item.header_ns * 1e-9:.6f} s the position moved '
                f'{np.linalg.norm(moved):.6g} m, the velocities account for '
                f'{np.linalg.norm(explained):.6g} m (off by {error:.6g} m, more than the '
                f'{allowed:.3g} m the sample spacing explains); check that the stamps are the '
                'measurement times and the twist is in the body axes (REP-105). Warned once '
                'for this topic')


def divergence_advice(message: str, failure, late_inputs: int, odometry_warned) -> str:
    """
    Return a failure message whose advice names the cure.

    The engine says "try a smaller dt" when the joints diverge (failure
    ``Failure.DIVERGED``, ``Simulator.failure``); when inputs came late or
    an odometry stream disagreed with itself, the jumps they made are the
    likelier cause, and a smaller dt would not cure them.
    """
    if failure is not Failure.DIVERGED or not (late_inputs or odometry_warned):
        return message
    causes = []
    if late_inputs:
        causes.append(f'{late_inputs} inputs came after their stamps (late_inputs) and moved '
                      'bodies in jumps')
    if odometry_warned:
        causes.append('odometry on ' + ', '.join(sorted(odometry_warned))
                      + ' has positions and velocities that disagree')
    return message.replace(SMALLER_DT, '; ' + ' and '.join(causes)
                           + ': a smaller dt would not help; fix the inputs')
