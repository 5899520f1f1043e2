# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
How far the node's run may go: the wall clock in real time, a carrier's odometry.

Both are plain bookkeeping (no rclpy): ``WallPace`` maps the monotonic wall
clock to simulated time at a real-time factor that may change mid-run;
``OdometryGate`` holds the run back where the motion of a carrier needs
odometry that has not come yet.
"""

import math

from cfem_ros.core.engine.carrier import ODOMETRY_HORIZON


class WallPace:
    """Simulated time against the wall clock, at ``factor`` times real time (0: no pacing)."""

    def __init__(self, factor: float):
        self.factor = factor
        self._wall_ref = 0.0
        self._sim_ref = 0.0

    def start(self, now: float):
        """Make simulated time 0 the wall time now (monotonic, s)."""
        self._wall_ref, self._sim_ref = now, 0.0

    def target(self, now: float) -> float:
        """Return the simulated time the wall clock asks for at now (inf: no pacing)."""
        if self.factor == 0:
            return math.inf
        return self._sim_ref + (now - self._wall_ref) * self.factor

    def resume(self, now: float, sim_t: float):
        """Go on from sim_t at the wall time now (after a pause, a step or a reset)."""
        self._wall_ref, self._sim_ref = now, sim_t

    def retime(self, now: float, sim_t: float, factor: float):
        """Go on from now at a new factor, from where the clock (or sim_t, unpaced) was."""
        target = self.target(now)
        self._sim_ref = sim_t if math.isinf(target) else target
        self._wall_ref = now
        self.factor = factor


class OdometryGate:
    """
    How far a run may go toward a time while it waits for a carrier's odometry.

    ``seen`` counts the odometry messages that came (the first two matter);
    ``subscribed``: whether any body may follow odometry.
    """

    def __init__(self, sim, session, *, interpolate: bool, following_clock: bool,
                 subscribed: bool = True):
        self.sim = sim
        self.session = session
        self.interpolate = interpolate
        self.following_clock = following_clock
        self.subscribed = subscribed and sim.kinematic
        self.seen = 0

    def held(self, limit: float) -> float:
        """
        Return how far the simulation may go toward limit.

        Following /clock, the t = 0 sample waits for a carrier's first odometry
        and, when interpolating, the one after it (the motion from t = 0 is
        the cubic between the two). With ``interpolate``, not past a body's
        latest odometry message (the motion beyond it needs the next one)
        while limit is within ``ODOMETRY_HORIZON`` of it; beyond that, on
        (extrapolated, with the engine's warning). -inf: not even t = 0.
        In real time (the t = 0 sample is out at the start), with
        ``interpolate``, the run waits at t = 0 for a carrier's first message
        as long: live odometry comes after its stamp, and what comes after
        the simulation has passed its stamp is late.
        """
        first = 2 if self.interpolate else 1
        if (self.following_clock and not self.session.started and self.sim.kinematic
                and self.seen < first and limit < ODOMETRY_HORIZON):
            return -math.inf
        if not self.interpolate:
            return limit
        if (not self.following_clock and self.subscribed and self.seen == 0
                and limit < ODOMETRY_HORIZON):
            return min(limit, self.sim.t)
        held = limit
        for latest in self.sim.carriers.known().values():
            if limit <= latest + ODOMETRY_HORIZON:
                held = min(held, latest)
        return held
