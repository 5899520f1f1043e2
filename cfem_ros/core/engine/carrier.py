# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Kinematic bodies (carriers): where they are, their odometry, and what hangs on them.

A body with ``motion`` follows a trajectory kept in its columns of the
simulator's body table, which the kernel evaluates at every RK4 stage
(motion.py): the scenario's, until an odometry message (REP-105) for it takes
effect; from then on the cubic between two messages, or an extrapolation
from the latest one (``ODOMETRY_HORIZON``). The bodies joined to a carrier
start moving with it, and are carried along rigidly when it jumps to a
message's pose. ``Carriers`` owns this bookkeeping for one simulator: the
simulator steps, and after each step asks ``place``; the inputs and the
session give it messages (``set_odometry``, ``expect_odometry``).
"""

from __future__ import annotations

import collections
import math

from cfem_ros.core import rotations
from cfem_ros.core.engine.bodies import state_views
from cfem_ros.core.errors import ArgumentError
from cfem_ros.core.model.graph import adjacency
from cfem_ros.core.native import kernel, motion
from cfem_ros.core.native.kernel import TWIST
import numpy as np

#: How long after its last odometry message a kinematic body is extrapolated to
#: second order (velocity and the acceleration from the last two messages), s;
#: beyond it, a warning and constant velocity and body rates.
ODOMETRY_HORIZON = 0.1


def _within_horizon(t: float, later: float) -> bool:
    """Tell whether later is at most ``ODOMETRY_HORIZON`` after t (to rounding)."""
    return later - t <= ODOMETRY_HORIZON * (1.0 + 1e-9)


class Carriers:
    """
    The kinematic bodies of a simulator, and the odometry that drives them.

    Parameters
    ----------
    sim : Simulator
        Whose kinematic bodies these are: its time, state and active joints
        are read, and on a jump the state of what hangs on the carrier is
        moved with it (positions rigidly, velocities by
        ``Simulator.joint_projection``).
    table : ndarray
        The simulator's body table (``Dynamics``), whose trajectory columns
        (``motion.M_KIND`` on) are written here.

    """

    def __init__(self, sim, table: np.ndarray):
        self.sim = sim
        self.table = table
        # body -> (time, body-axis velocity, body rates, (position, quaternion, world
        # velocity, body rates), extrapolation's acceleration and angular one) of its last message
        self._last = {}
        self._horizon_end = {}   # body -> end of its second-order extrapolation, s
        self._ahead = {}   # body -> {time: message} known before it takes effect
        self._cubic_end = {}   # body -> where the cubic it is on ends, s

    def place(self, t: float):
        """Put the kinematic bodies where their trajectories are at time t (motion.py)."""
        kernel.motion_set_time(self.table, float(t))
        kernel.motion_place(self.sim.y, self.table, 0.0)

    def start(self):
        """
        Start the bodies joined to a kinematic one, and given no velocity, moving with it.

        Through the joints (and the bodies between): the carrier's velocity at
        the body's CG and the carrier's angular velocity.
        """
        model, n = self.sim.model, self.sim.n
        pos, vel, quat, rates = state_views(self.sim.y, self.sim.n)
        rot = rotations.matrices(quat)
        carrier = [i if b.motion is not None else -1 for i, b in enumerate(model.bodies)]
        links = adjacency(n, model.joints)     # built once: linear in the bodies
        queue = collections.deque(i for i in range(n) if carrier[i] >= 0)
        while queue:
            i = queue.popleft()
            for _, other in links[i]:
                if carrier[other] >= 0 or not model.bodies[other].dynamic:
                    continue
                carrier[other] = carrier[i]
                queue.append(other)
                if model.bodies[other].velocity_given:
                    continue
                c = carrier[i]
                omega = rot[c] @ rates[c]
                vel[other] = vel[c] + np.cross(omega, pos[other] - pos[c])
                rates[other] = rot[other].T @ omega

    def set_odometry(self, body, t: float, position, quaternion, velocity_body, rates_body):
        """
        Drive a kinematic body from an odometry message (REP-105) from now on.

        Parameters
        ----------
        body : str or int
            A body with ``motion``: the message replaces it.
        t : float
            The message's time, s: now (the body is put at the message's pose).
        position, quaternion : array_like
            CG in world, m; attitude x y z w, body to world.
        velocity_body, rates_body : array_like, shape (3,)
            CG velocity (m/s) and angular velocity (rad/s), body axes.

        Notes
        -----
        If the body's next message is known (``expect_odometry``) and comes
        within ``ODOMETRY_HORIZON`` s, the body moves on the cubic between
        the two (``motion.hermite``): the caller then makes that message
        take effect at its time. Otherwise it is extrapolated: from t it
        moves with this velocity and acceleration for ``ODOMETRY_HORIZON``
        s, then at constant velocity and body rates, with a warning. The
        acceleration is w x v (the velocity turning with the body) plus the
        change of the body-axis velocity since the previous message, itself
        turning with the body (w x a); the angular acceleration, the change
        of the body rates since it (zero for the first message).

        """
        i, t, position, quat, velocity, rates = self._message(
            body, t, position, quaternion, velocity_body, rates_body)
        turn = rotations.matrices(quat[None])[0]
        # the velocity turns with the body (w x v), and changes in body axes as
        # between the last two messages; the body rates change as between them
        acc, alpha = np.cross(turn @ rates, turn @ velocity), np.zeros(3)
        last = self._last.get(i)
        if last is not None and t > last[0]:
            acc += turn @ (velocity - last[1]) / (t - last[0])
            alpha = (rates - last[2]) / (t - last[0])
        ahead = self._ahead.get(i, {})
        for passed in [s for s in ahead if s <= t]:
            del ahead[passed]
        # unless the body arrives here on the cubic that ends on this message, it
        # jumps to the message's pose and twist: what hangs on it jumps with it
        carried = self._cubic_end.pop(i, None) != t
        before = self._pose(i) if carried else None
        self._last[i] = (t, velocity, rates, (position, quat, turn @ velocity, rates),
                         acc, alpha)
        self._horizon_end[i] = t + ODOMETRY_HORIZON
        self._pack(i)
        if carried:
            self._carry_jump(i, before)

    def expect_odometry(self, body, t: float, position, quaternion, velocity_body,
                        rates_body):
        """
        Make known an odometry message that will take effect at t, after now.

        The body's motion up to it is then the cubic between its message
        before and this one (see ``set_odometry``, which the caller still
        calls at t), provided the body has not moved on from that message's
        time yet: a message known too late for that is warned about, and
        only takes effect at its time. Arguments and errors as ``set_odometry``.
        """
        i, t, position, quat, velocity, rates = self._message(
            body, t, position, quaternion, velocity_body, rates_body)
        if t <= self.sim.t:
            raise ArgumentError(f'odometry at t = {t:.9g} s is not after now '
                                f'({self.sim.t:.9g} s); set_odometry applies it now')
        turn = rotations.matrices(quat[None])[0]
        ahead = self._ahead.setdefault(i, {})
        ahead[t] = (position, quat, turn @ velocity, rates)
        base = self._last.get(i)
        if base is None or min(ahead) != t or not _within_horizon(base[0], t):
            return
        if base[0] == self.sim.t:
            self._pack(i)   # the segment from the current message now ends at it
        else:
            self.sim.log.warning(
                'odometry for body %r at t = %.6f s became known after the simulation had '
                'moved on from the message before it (t = %.6f s, now %.6f s): not '
                'interpolated; it takes effect at its time', self.sim.model.bodies[i].name, t,
                base[0], self.sim.t)

    def known(self) -> dict:
        """Return, per body that has had odometry, the time of its latest known message, s."""
        out = {i: base[0] for i, base in self._last.items()}
        for i, ahead in self._ahead.items():
            if ahead:
                out[i] = max(out.get(i, -math.inf), max(ahead))
        return out

    def _message(self, body, t, position, quaternion, velocity_body, rates_body):
        """Check an odometry message; return (body index, t, its arrays, unit quaternion)."""
        i = self.sim.body_index(body)
        name = self.sim.model.bodies[i].name
        if self.sim.model.bodies[i].motion is None:
            raise ArgumentError(f'body {name!r} is not kinematic (no motion): odometry drives '
                                'only kinematic bodies')
        values = [np.asarray(v, dtype=float)
                  for v in (position, quaternion, velocity_body, rates_body)]
        if [v.shape for v in values] != [(3,), (4,), (3,), (3,)] or not all(
                np.isfinite(v).all() for v in values) or not math.isfinite(t):
            raise ArgumentError('odometry must have a finite time, position (3), quaternion (4), '
                                'linear and angular velocity (3 each)')
        position, quat, velocity, rates = values
        norm = np.linalg.norm(quat)
        if abs(norm - 1.0) > 1e-3:
            raise ArgumentError(f'odometry quaternion has norm {norm:.6g}; expected a unit '
                                'quaternion (to 1e-3)')
        return i, float(t), position, quat / norm, velocity, rates

    def _pack(self, i: int):
        """Write body i's trajectory from its current message into its columns."""
        t, _, _, start, acc, alpha = self._last[i]
        ahead = self._ahead.get(i)
        following = min(ahead) if ahead else None
        # a message applied late (its time before now) is extrapolated from: the body jumped
        # to it, and no cubic leads from a state it never had (live or replayed alike)
        if following is not None and _within_horizon(t, following) and t >= self.sim.t:
            data = motion.hermite(t, start, following, ahead[following])
            self._cubic_end[i] = following
        else:
            position, quat, velocity, rates = start
            # an acceleration fixed in the body turns with it: its rate of change w x a
            turn = rotations.matrices(quat[None])[0]
            data = motion.odometry(t, position, quat, velocity, rates, acc, alpha,
                                   ODOMETRY_HORIZON, jerk=np.cross(turn @ rates, acc))
        self.table[i, motion.M_KIND] = motion.KIND_TABLE
        self.table[i, motion.M_DATA:] = 0.0
        self.table[i, motion.M_DATA:motion.M_DATA + len(data)] = data
        self.place(self.sim.t)

    def _pose(self, i: int):
        """Return body i's CG and unit quaternion (copies)."""
        pos, _, quat, _ = state_views(self.sim.y, self.sim.n)
        return pos[i].copy(), quat[i] / np.linalg.norm(quat[i])

    def _carry_jump(self, carrier: int, before):
        """
        Move what hangs on a kinematic body with it, rigidly, after it jumped.

        The bodies joined to it by active joints (and through other free
        bodies) keep their pose relative to it, so their joints hold as they
        did, and their velocities take the least (mass weighted) change that
        the joints allow. Not if they are also joined to a fixed or another
        kinematic body: those stay where they are.
        """
        model, free = self.sim.model, self.sim.free
        hanging, queue, anchored = set(), [carrier], False
        while queue:
            i = queue.pop()
            for k, joint in enumerate(model.joints):
                if not self.sim.active[k] or i not in (joint.parent, joint.child):
                    continue
                other = joint.child if joint.parent == i else joint.parent
                if not free[other]:
                    anchored = anchored or other != carrier
                elif other not in hanging:
                    hanging.add(other)
                    queue.append(other)
        if not hanging or anchored:
            return
        p0, q0 = before
        p1, q1 = self._pose(carrier)
        jump = rotations.multiply(q1[None], rotations.conjugate(q0[None]))   # world axes
        turn = rotations.matrices(jump)[0]
        pos, vel, quat, rates = state_views(self.sim.y, self.sim.n)
        for b in sorted(hanging):
            spin = rotations.matrices(quat[b:b + 1])[0] @ rates[b]   # world axes
            pos[b] = p1 + turn @ (pos[b] - p0)
            quat[b] = rotations.multiply(jump, quat[b:b + 1])[0]
            rates[b] = rotations.matrices(quat[b:b + 1])[0].T @ spin
        # velocities: the least (mass weighted) change that makes them those the
        # joints allow, as an impulse would
        delta = self.sim.joint_projection()
        vel += delta[:, TWIST.span('V_LINEAR')]
        rates += np.einsum('nji,nj->ni', rotations.matrices(quat),
                           delta[:, TWIST.span('V_ANGULAR')])

    def check(self):
        """Warn once per message when a body's odometry is older than the horizon."""
        for i, end in list(self._horizon_end.items()):
            if self.sim.t > end:
                self.sim.log.warning(
                    'no odometry for body %r since t = %.6f s (%.3f s ago, beyond the %.3g s '
                    'horizon): held at constant velocity and body rates',
                    self.sim.model.bodies[i].name, self._last[i][0],
                    self.sim.t - self._last[i][0], ODOMETRY_HORIZON)
                del self._horizon_end[i]
