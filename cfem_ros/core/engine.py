# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The CFEM engine: Newton-Euler bodies, joint rows, Baumgarte, RK4, releases.

The state of n bodies is one flat array ``y`` of 13 n numbers, in blocks:
CG positions (world, m), CG velocities (world, m/s), quaternions (x, y, z, w,
body to world) and angular velocities (body axes, rad/s). Ground (fixed)
bodies are carried with zero inverse mass and inertia, so every formula is the
same for all bodies.

The loads of the active joints are solved in the Lagrange-multiplier form
(CFEM.md, "Cheaper forms"): each constrained direction k of a joint carries a
multiplier lambda_k, the force (or moment) along it, and

    J M^-1 J^T lambda = -gamma - 2 eta J v - eta^2 g - J M^-1 f

where g are the constraint values (paper eqs. 11-12), J their Jacobian with
respect to the velocities (V, w in world axes), gamma = (dJ/dt) v, and f the
external, gravity and gyroscopic loads. The joint table is data
(``model.JOINT_TABLE``); this module never branches on a joint type.
"""

from __future__ import annotations

import logging
import math
from typing import Optional

from cfem_ros.core import kernel, motion, rotations, sampling
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.loads import H_POINT, ScheduledLoads
from cfem_ros.core.model import Model
from cfem_ros.core.releases import Releases, TRIGGER_CAUSES  # noqa: F401 - kept for users
from cfem_ros.core.sampling import NumericalFailure, SampledState, SampleGrid  # noqa: F401
from cfem_ros.core.topology import JointTables, Topology
import numpy as np

LOG = logging.getLogger('cfem_ros')
#: The warning (a logging format, its arguments the joints and the count) of redundant
#: joints, which a sweep gives once, not once per run.
REDUNDANT_WARNING = ('the joints %s constrain %d direction(s) more than once (redundant '
                     'joints or a closed loop): the motion is exact, the loads of the '
                     'redundant directions are shared in the least-norm sense')

#: Constraint violation (m, or rad for rotation rows) beyond which a run is
#: declared diverged: a million times what the stabilized integration keeps.
DIVERGENCE_VIOLATION = 1e-3

#: Velocity corrections smaller than this (m/s, rad/s) are not reported.
PROJECTION_REPORT = 1e-9

#: How long after its last odometry message a kinematic body is extrapolated to
#: second order (velocity and the acceleration from the last two messages), s;
#: beyond it, a warning and constant velocity and body rates.
ODOMETRY_HORIZON = 0.1


def _within_horizon(t: float, later: float) -> bool:
    """Tell whether later is at most ``ODOMETRY_HORIZON`` after t (to rounding)."""
    return later - t <= ODOMETRY_HORIZON * (1.0 + 1e-9)


#: What ``kernel.advance`` gets for no sample grid.
_NO_GRID = np.zeros(3)
_NO_ROWS = np.empty((0, 0))


def _locate_error(code: int, s: float) -> Exception:
    """Return the error ``kernel.locate``'s code stands for (those of the Python search)."""
    if code == kernel.SINGULAR:
        return NumericalFailure(sampling.SINGULAR)
    if code == kernel.LOADS_NOT_FINITE:
        return NumericalFailure(sampling.LOADS_NOT_FINITE)
    if code == kernel.NAN_VALUE:   # roots.brentq's errors
        return ValueError('The function value at x=%f is NaN; solver cannot continue.' % s)
    if code == kernel.SAME_SIGNS:
        return ValueError('f(a) and f(b) must have different signs')
    return RuntimeError('Failed to converge after %d iterations, value is %f'
                        % (kernel.CROSSING_MAXITER, s))


class Simulator(SampledState):
    """
    Step a model's bodies and joints in time with RK4.

    Parameters
    ----------
    model : Model
        Built by ``scenario.parse_scenario``.
    logger : logging.Logger, optional
        Where warnings go (velocity projection, redundant joints).

    Attributes
    ----------
    t : float
        Simulated time, s.
    y : ndarray, shape (13 n,)
        The state (module docstring).
    status : str
        'running' or 'failed': a non-finite state or joint load, a constraint
        violation beyond ``DIVERGENCE_VIOLATION``, or a singular or
        ill-conditioned solve (``kernel.PIVOT_RTOL``) stops the run at the
        last good state.
    message : str
        Why the run failed, with the time ('' while running).
    events : list of dict
        Releases so far: ``{'event': 'release', 'joint', 'time', 'cause'}``.
    active : ndarray of bool, shape (n_joints,)
        Joints not yet released.

    """

    def __init__(self, model: Model, logger: Optional[logging.Logger] = None):
        self.model = model
        self.log = logger or LOG
        self.dt = float(model.dt)
        self.eta = float(model.baumgarte)
        bodies = model.bodies
        n = self.n = len(bodies)
        # fixed and kinematic bodies are carried with zero inverse mass and inertia
        self.free = np.array([b.dynamic for b in bodies])
        self.mass = np.array([b.mass if b.dynamic else 0.0 for b in bodies])
        self.inv_mass = np.where(self.free, 1.0 / np.where(self.free, self.mass, 1.0), 0.0)
        self.inertia_body = np.array([
            b.inertia if b.dynamic else np.zeros((3, 3)) for b in bodies])
        self.inv_inertia_body = np.array([
            np.linalg.inv(b.inertia) if b.dynamic else np.zeros((3, 3)) for b in bodies])
        self._check_inverses()
        self.gravity = np.asarray(model.gravity, dtype=float)
        self._bodies = np.column_stack([
            self.mass, self.inv_mass, self.inertia_body.reshape(n, 9),
            self.inv_inertia_body.reshape(n, 9)])
        # kinematic bodies' trajectories: extra columns, only if there are any (motion.py)
        trajectories = motion.columns(model)
        self.kinematic = trajectories.shape[1] > 0
        # body -> (time, body-axis velocity, body rates, (position, quaternion, world
        # velocity, body rates), extrapolation's acceleration and angular one) of its last message
        self._odometry = {}
        self._odometry_end = {}   # body -> end of its second-order extrapolation, s
        self._odometry_ahead = {}   # body -> {time: message} known before it takes effect
        self._odometry_cubic_end = {}   # body -> where the cubic it is on ends, s
        if self.kinematic:
            self._bodies = np.ascontiguousarray(np.hstack([self._bodies, trajectories]))
        # applied loads, packed (loads.py): per body force (3), torque (3), 1.0 when in
        # body axes, point (3); then the scenario's scheduled wrenches
        self._scheduled = ScheduledLoads(model, n)
        self._loads = self._scheduled.array

        self.t = 0.0
        self.y = np.concatenate([
            np.concatenate([b.position for b in bodies]),
            np.concatenate([b.velocity_world for b in bodies]),
            np.concatenate([b.orientation_xyzw for b in bodies]),
            np.concatenate([b.rates_body for b in bodies]),
        ]).astype(float)
        self.status = 'running'
        self.message = ''
        self.events = []
        self.steps = 0
        self.max_violation = 0.0
        self._stage_violation = 0.0
        self._info = np.zeros(6)
        if self.kinematic:
            self._place(0.0)
            self._carry()

        pos0, _, quat0, _ = self._split(self.y)
        self.joints = JointTables(model, pos0, quat0)
        self.releases = Releases(self.joints)
        self.active = np.ones(len(model.joints), dtype=bool)
        self._set_topology()
        self._fire_time_triggers()
        self._project_velocities()

    def _place(self, t: float):
        """Put the kinematic bodies where their trajectories are at time t (motion.py)."""
        kernel.motion_set_time(self._bodies, float(t))
        kernel.motion_place(self.y, self._bodies, 0.0)

    def _carry(self):
        """
        Start the bodies joined to a kinematic one, and given no velocity, moving with it.

        Through the joints (and the bodies between): the carrier's velocity at
        the body's CG and the carrier's angular velocity.
        """
        model, n = self.model, self.n
        pos, vel, quat, rates = self._split(self.y)
        rot = rotations.matrices(quat)
        carrier = [i if b.motion is not None else -1 for i, b in enumerate(model.bodies)]
        queue = [i for i in range(n) if carrier[i] >= 0]
        while queue:
            i = queue.pop(0)
            for joint in model.joints:
                ends = (joint.parent, joint.child)
                if i not in ends:
                    continue
                other = ends[1] if ends[0] == i else ends[0]
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

    # ------------------------------------------------------------ hot path

    def _set_topology(self):
        """Rebuild the rows, the solve plan and the workspace for the active joints."""
        top = self._topology = Topology(self.joints.rows, self.active, self.free)
        self.dof = self._check_redundancy()
        self.releases.update(self.active, top.line)
        active = np.flatnonzero(self.active)
        self._outputs_key = tuple(active.tolist())
        self._outputs_order = np.ascontiguousarray(top.line[active], dtype=np.int64)

    def derivative(self, y: np.ndarray) -> np.ndarray:
        """Return dy/dt at state y (external wrenches held constant)."""
        out = np.empty_like(y)
        if kernel.derivative(y, out, *self._topology.kernel_args(self)) < 0.0:
            raise NumericalFailure(sampling.SINGULAR)
        return out

    def _rk4(self, y, h):
        """One classical RK4 step of length h from y, quaternions normalized."""
        out = np.empty_like(y)
        try:
            worst = kernel.rk4_step(y, h, out, *self._topology.kernel_args(self))
        except np.linalg.LinAlgError:
            worst = -1.0
        if worst < 0.0:
            raise NumericalFailure(sampling.SINGULAR)
        self._stage_violation = max(self._stage_violation, worst)
        return out

    # ------------------------------------------------------- starting checks

    def _check_inverses(self):
        """Refuse a body whose inverse mass or inertia is not a finite number."""
        for i, body in enumerate(self.model.bodies):
            if not body.dynamic:
                continue
            if not math.isfinite(self.inv_mass[i]):
                raise ScenarioError(
                    f'model {self.model.name!r}', f'bodies.{body.name}.mass',
                    f'is {body.mass:g} kg, whose inverse is not a finite number',
                    'a mass of at least 1e-300 kg')
            if not np.isfinite(self.inv_inertia_body[i]).all():
                raise ScenarioError(
                    f'model {self.model.name!r}', f'bodies.{body.name}.inertia',
                    'has an inverse that is not a finite number',
                    'principal moments of at least 1e-300 kg m^2')

    def _check_redundancy(self) -> int:
        """Detect redundant rows; warn once; return the remaining DOF."""
        free_dof = 6 * int(self.free.sum())
        top = self._topology
        rank = top.rank(self.y, top.kernel_args(self), self.n)
        if rank < top.m:
            if not getattr(self, '_warned_redundant', False):
                names = sorted({self.model.joints[k].name for k in top.joint})
                self.log.warning(REDUNDANT_WARNING, ', '.join(names), top.m - rank)
                self._warned_redundant = True
            top.dense = 2
        return free_dof - rank

    def _project_velocities(self):
        """Make the initial velocities consistent with the joints (mass weighted)."""
        top = self._topology
        if top.m == 0:
            return
        delta = np.zeros((self.n, 6))
        kernel.project(self.y, *top.kernel_args(self), delta)
        if not np.abs(delta).max() > PROJECTION_REPORT:
            return
        _, vel, quat, rates = self._split(self.y)
        vel += delta[:, :3]
        rates += np.einsum('nji,nj->ni', rotations.matrices(quat), delta[:, 3:])
        for i in np.flatnonzero(np.abs(delta).max(axis=1) > PROJECTION_REPORT):
            self.log.warning(
                'initial velocities of body %r are inconsistent with its joints; '
                'corrected (mass weighted) by %.3g m/s and %.3g deg/s',
                self.model.bodies[i].name, np.linalg.norm(delta[i, :3]),
                math.degrees(np.linalg.norm(delta[i, 3:])))

    # --------------------------------------------------------------- inputs

    def set_wrench(self, body, force, torque, body_axes: bool = False, point=None):
        """
        Hold an external force and moment on a body until replaced.

        Parameters
        ----------
        body : str or int
            Name or index of a body that is not fixed.
        force : array_like, shape (3,)
            N, world axes, or body axes if body_axes.
        torque : array_like, shape (3,)
            N m, same axes as force.
        body_axes : bool
            True: force and torque are in body axes and turn with the body.
        point : array_like, shape (3,), optional
            Where the force acts, body axes, from the CG, m (default: the CG);
            the moment about the CG is torque + r x F, r turning with the body.

        """
        i = self._body(body)
        force = np.asarray(force, dtype=float)
        torque = np.asarray(torque, dtype=float)
        point = np.zeros(3) if point is None else np.asarray(point, dtype=float)
        if force.shape != (3,) or torque.shape != (3,) or point.shape != (3,):
            raise ValueError('force, torque and point must have 3 components each')
        if not (np.isfinite(force).all() and np.isfinite(torque).all()
                and np.isfinite(point).all()):
            raise ValueError('force, torque and point must be finite')
        if not self.free[i]:
            what = 'fixed' if self.model.bodies[i].fixed else 'kinematic (it follows its motion)'
            raise ValueError(f'body {self.model.bodies[i].name!r} is {what} and cannot be loaded')
        self._loads[i, :7] = np.concatenate([force, torque, [1.0 if body_axes else 0.0]])
        self._loads[i, H_POINT:H_POINT + 3] = point

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
        i, t, position, quat, velocity, rates = self._odometry_message(
            body, t, position, quaternion, velocity_body, rates_body)
        turn = rotations.matrices(quat[None])[0]
        # the velocity turns with the body (w x v), and changes in body axes as
        # between the last two messages; the body rates change as between them
        acc, alpha = np.cross(turn @ rates, turn @ velocity), np.zeros(3)
        last = self._odometry.get(i)
        if last is not None and t > last[0]:
            acc += turn @ (velocity - last[1]) / (t - last[0])
            alpha = (rates - last[2]) / (t - last[0])
        ahead = self._odometry_ahead.get(i, {})
        for passed in [s for s in ahead if s <= t]:
            del ahead[passed]
        # unless the body arrives here on the cubic that ends on this message, it
        # jumps to the message's pose and twist: what hangs on it jumps with it
        carried = self._odometry_cubic_end.pop(i, None) != t
        before = self._pose(i) if carried else None
        self._odometry[i] = (t, velocity, rates, (position, quat, turn @ velocity, rates),
                             acc, alpha)
        self._odometry_end[i] = t + ODOMETRY_HORIZON
        self._pack_odometry(i)
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
        i, t, position, quat, velocity, rates = self._odometry_message(
            body, t, position, quaternion, velocity_body, rates_body)
        if t <= self.t:
            raise ValueError(f'odometry at t = {t:.9g} s is not after now ({self.t:.9g} s); '
                             'set_odometry applies it now')
        turn = rotations.matrices(quat[None])[0]
        ahead = self._odometry_ahead.setdefault(i, {})
        ahead[t] = (position, quat, turn @ velocity, rates)
        base = self._odometry.get(i)
        if base is None or min(ahead) != t or not _within_horizon(base[0], t):
            return
        if base[0] == self.t:
            self._pack_odometry(i)   # the segment from the current message now ends at it
        else:
            self.log.warning(
                'odometry for body %r at t = %.6f s became known after the simulation had '
                'moved on from the message before it (t = %.6f s, now %.6f s): not '
                'interpolated; it takes effect at its time', self.model.bodies[i].name, t,
                base[0], self.t)

    def odometry_known(self) -> dict:
        """Return, per body that has had odometry, the time of its latest known message, s."""
        out = {i: base[0] for i, base in self._odometry.items()}
        for i, ahead in self._odometry_ahead.items():
            if ahead:
                out[i] = max(out.get(i, -math.inf), max(ahead))
        return out

    def _odometry_message(self, body, t, position, quaternion, velocity_body, rates_body):
        """Check an odometry message; return (body index, t, its arrays, unit quaternion)."""
        i = self._body(body)
        name = self.model.bodies[i].name
        if self.model.bodies[i].motion is None:
            raise ValueError(f'body {name!r} is not kinematic (no motion): odometry drives '
                             'only kinematic bodies')
        values = [np.asarray(v, dtype=float)
                  for v in (position, quaternion, velocity_body, rates_body)]
        if [v.shape for v in values] != [(3,), (4,), (3,), (3,)] or not all(
                np.isfinite(v).all() for v in values) or not math.isfinite(t):
            raise ValueError('odometry must have a finite time, position (3), quaternion (4), '
                             'linear and angular velocity (3 each)')
        position, quat, velocity, rates = values
        norm = np.linalg.norm(quat)
        if abs(norm - 1.0) > 1e-3:
            raise ValueError(f'odometry quaternion has norm {norm:.6g}; expected a unit '
                             'quaternion (to 1e-3)')
        return i, float(t), position, quat / norm, velocity, rates

    def _pack_odometry(self, i: int):
        """Write body i's trajectory from its current message into its columns."""
        t, _, _, start, acc, alpha = self._odometry[i]
        ahead = self._odometry_ahead.get(i)
        following = min(ahead) if ahead else None
        if following is not None and _within_horizon(t, following):
            data = motion.hermite(t, start, following, ahead[following])
            self._odometry_cubic_end[i] = following
        else:
            position, quat, velocity, rates = start
            # an acceleration fixed in the body turns with it: its rate of change w x a
            turn = rotations.matrices(quat[None])[0]
            data = motion.odometry(t, position, quat, velocity, rates, acc, alpha,
                                   ODOMETRY_HORIZON, jerk=np.cross(turn @ rates, acc))
        self._bodies[i, motion.M_KIND] = motion.KIND_TABLE
        self._bodies[i, motion.M_DATA:] = 0.0
        self._bodies[i, motion.M_DATA:motion.M_DATA + len(data)] = data
        self._place(self.t)

    def _pose(self, i: int):
        """Return body i's CG and unit quaternion (copies)."""
        pos, _, quat, _ = self._split(self.y)
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
        model, free = self.model, self.free
        hanging, queue, anchored = set(), [carrier], False
        while queue:
            i = queue.pop()
            for k, joint in enumerate(model.joints):
                if not self.active[k] or i not in (joint.parent, joint.child):
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
        pos, vel, quat, rates = self._split(self.y)
        for b in sorted(hanging):
            spin = rotations.matrices(quat[b:b + 1])[0] @ rates[b]   # world axes
            pos[b] = p1 + turn @ (pos[b] - p0)
            quat[b] = rotations.multiply(jump, quat[b:b + 1])[0]
            rates[b] = rotations.matrices(quat[b:b + 1])[0].T @ spin
        # velocities: the least (mass weighted) change that makes them those the
        # joints allow, as an impulse would
        delta = np.zeros((self.n, 6))
        kernel.project(self.y, *self._topology.kernel_args(self), delta)
        vel += delta[:, :3]
        rates += np.einsum('nji,nj->ni', rotations.matrices(quat), delta[:, 3:])

    def _odometry_check(self):
        """Warn once per message when a body's odometry is older than the horizon."""
        for i, end in list(self._odometry_end.items()):
            if self.t > end:
                self.log.warning(
                    'no odometry for body %r since t = %.6f s (%.3f s ago, beyond the %.3g s '
                    'horizon): held at constant velocity and body rates',
                    self.model.bodies[i].name, self._odometry[i][0],
                    self.t - self._odometry[i][0], ODOMETRY_HORIZON)
                del self._odometry_end[i]

    @property
    def applied_sources(self) -> list:
        """Return (body, source) of each scheduled load a sample shows (``outputs``)."""
        return self._scheduled.sources()

    def applied_loads(self) -> np.ndarray:
        """Return each applied source's force and moment about its body's CG, world, (k, 6)."""
        first = 13 * self.n + 6 * len(self._outputs_key)
        return self.outputs()[first:first + self._scheduled.outputs_size].reshape(-1, 6)

    def relative_states(self) -> np.ndarray:
        """
        Return each ``model.references`` body's state in its reference's frame, (k, 13).

        Per pair: CG position relative to the reference's CG (3) and attitude
        (x y z w, body to reference), then the CG velocity seen from the
        reference and the relative angular velocity (3 + 3); all in the
        reference's axes (``motion.sample_relative``, computed here in numpy).
        """
        pairs = self.model.references
        out = np.empty((len(pairs), 13))
        if not pairs:
            return out
        body, ref = (np.array(p, dtype=int) for p in zip(*pairs))
        pos, vel, quat, rates = self._split(self.y)
        quat = quat / np.linalg.norm(quat, axis=1)[:, None]
        rot = rotations.matrices(quat)
        omega = np.einsum('nij,nj->ni', rot, rates)
        d = pos[body] - pos[ref]
        v = vel[body] - vel[ref] - np.cross(omega[ref], d)
        turn = rot[ref].transpose(0, 2, 1)
        out[:, :3] = np.einsum('nij,nj->ni', turn, d)
        out[:, 3:7] = rotations.multiply(rotations.conjugate(quat[ref]), quat[body])
        out[:, 7:10] = np.einsum('nij,nj->ni', turn, v)
        out[:, 10:] = np.einsum('nij,nj->ni', turn, omega[body] - omega[ref])
        return out

    def release(self, joint, cause: str = 'command') -> dict:
        """Release an active joint now; return the event."""
        k = self._joint(joint)
        if not self.active[k]:
            raise ValueError(f'joint {self.model.joints[k].name!r} is already released')
        return self._release([k], cause)[0]

    def _release(self, joints, cause):
        events = []
        for k in joints:
            self.active[k] = False
            event = {'event': 'release', 'joint': self.model.joints[k].name,
                     'time': self.t, 'cause': cause}
            events.append(event)
            self.events.append(event)
        self._set_topology()
        return events

    def _body(self, body) -> int:
        if isinstance(body, str):
            try:
                return self.model.body_index(body)
            except ValueError:
                raise ValueError(f'unknown body {body!r}') from None
        return int(body)

    def _joint(self, joint) -> int:
        if isinstance(joint, str):
            try:
                return self.model.joint_index(joint)
            except ValueError:
                raise ValueError(f'unknown joint {joint!r}') from None
        return int(joint)

    # ------------------------------------------------------------- stepping

    def advance_to(self, t_target: float, limit: Optional[float] = None,
                   samples: Optional[SampleGrid] = None, *,
                   release_at_end: bool = True) -> bool:
        """
        Integrate to t_target in RK4 steps of dt, the last one cut to land on it.

        Steps are also cut at release times, and a step in which a release
        condition is crossed is cut at the crossing, located on the step's own
        RK4 map. With ``limit``, stop before the first step that would end
        after it: the steps taken are the same as those toward t_target
        without a limit, so a run paced by a clock is the run without one.
        With ``samples``, the samples on its grid are taken on the way (one
        due now first), and the call returns early after a release or when
        the grid's rows are full, so that the caller can record the events
        and the samples in time order and call again. A joint whose release
        time is where the call ends is released before it returns, unless
        ``release_at_end`` is False: then it stays for the caller to sample
        (a release at t acts after the samples at t) and is released by
        ``release_due()`` or the next call.
        Returns False (and sets ``status`` and ``message``) if the run failed;
        the state is then the last good one.

        Raises
        ------
        ValueError
            If t_target is not finite or before the current time, or limit is NaN.

        """
        t_target = float(t_target)
        if not math.isfinite(t_target):
            raise ValueError(f't_target is {t_target!r}; expected a finite time in s')
        if t_target < self.t:
            raise ValueError(f't_target is {t_target:.9g} s, before the current time '
                             f'{self.t:.9g} s; time only moves forward')
        limit = math.inf if limit is None else float(limit)
        if math.isnan(limit):
            raise ValueError('limit is nan; expected a time in s (inf for none)')
        if self.status != 'running':
            return False
        if samples is not None and samples.rows.shape[1] not in (0, self._outputs_size()):
            raise ValueError(f'sample rows have {samples.rows.shape[1]} columns; the outputs '
                             f'of this state have {self._outputs_size()}')
        steps = self.steps

        def release_now():
            # a release at t acts after the samples at t and at the end of a call
            # that stops at t, as inputs do (the caller takes the sample first)
            return samples is None or samples.next_time > self.t

        try:
            if release_now():
                self._fire_time_triggers()   # left by a call that stopped at its time
            while self.t < t_target or (samples is not None and self.t >= samples.next_time):
                due = self._next_time_trigger()
                due = math.inf if due is None else due
                result = self._run(t_target, due, limit, samples)
                if result == kernel.CONDITION:
                    # a release condition is reached within the next step: locate it
                    goal = t_target if samples is None else min(t_target, samples.next_time)
                    remaining = goal - self.t
                    if remaining <= self.dt * (1.0 + 1e-9):
                        h, t_end = remaining, goal
                    else:
                        h, t_end = self.dt, self.t + self.dt
                    if due < t_end:
                        h, t_end = due - self.t, due
                    self._step(h, t_end)
                if (self.t < t_target or release_at_end) and release_now():
                    self._fire_time_triggers()
                if samples is not None:
                    break   # back to the caller: rows to take, or a release's events
                if result != kernel.CONDITION and self.t < t_target and self.t < due:
                    break   # the next step would end after limit
            if self.t >= t_target and self.steps > steps:
                self._check_violation()   # the kernel checks each step's start, not the end
            if self._odometry_end:
                self._odometry_check()
        except NumericalFailure as err:
            self.fail(str(err))
            return False
        return True

    def _check_violation(self):
        """Fail if the joints are violated beyond ``DIVERGENCE_VIOLATION`` now."""
        violation = self.constraint_violation()
        if violation > DIVERGENCE_VIOLATION:
            raise NumericalFailure(
                f'constraint violation {violation:.3g} exceeds {DIVERGENCE_VIOLATION:g} '
                '(the system diverged; try a smaller dt)')

    def fail(self, reason: str):
        """Stop the run as failed now (``status``, ``message`` with the time and reason)."""
        if self.status == 'running':
            self.status = 'failed'
            self.message = f'at t = {self.t:.9g} s: {reason}'

    def _run(self, t_target, due, limit, samples=None):
        """Take steps in the kernel until a target, a release time, limit or a condition."""
        top = self._topology
        rel = self.releases
        info = self._info
        info[:] = (self.t, 0.0, self.max_violation, kernel.REACHED, DIVERGENCE_VIOLATION, 0.0)
        grid, rows = (_NO_GRID, _NO_ROWS) if samples is None else (samples.state, samples.rows)
        try:
            kernel.advance(self.y, info, t_target, due, limit, self.dt, *top.kernel_args(self),
                           self.joints.joints_i, self.joints.joints_f, rel.watch,
                           rel.watch_limits, rel.watch_lines, grid, self._outputs_order, rows)
        except np.linalg.LinAlgError:
            info[3] = kernel.SINGULAR
        finally:
            self.t = float(info[0])
            self.steps += int(info[1])
            self.max_violation = float(info[2])
        result = int(info[3])
        if result == kernel.NOT_FINITE:
            raise NumericalFailure('the state is no longer finite (the system diverged)')
        if result == kernel.VIOLATION:
            raise NumericalFailure(
                f'constraint violation {info[5]:.3g} exceeds {DIVERGENCE_VIOLATION:g} '
                '(the system diverged; try a smaller dt)')
        if result == kernel.SINGULAR:
            raise NumericalFailure(sampling.SINGULAR)
        if result == kernel.LOADS_NOT_FINITE:
            raise NumericalFailure(sampling.LOADS_NOT_FINITE)
        return result

    def release_due(self) -> list:
        """
        Release the joints whose release time has come, now; return the events.

        ``advance_to`` leaves a release due at the time a call ends to the
        next call, so that a sample taken at that time still shows the
        joint (a release at t acts after the samples at t, whatever its
        cause); a caller that samples calls this after its sample.
        """
        before = len(self.events)
        self._fire_time_triggers()
        return self.events[before:]

    def _next_time_trigger(self) -> Optional[float]:
        due = self.releases.due   # changes with the topology
        switch = self._scheduled.due(self.t)   # scheduled wrenches' start and end (loads.py)
        return due if switch is None else switch if due is None else min(due, switch)

    def _fire_time_triggers(self):
        self._scheduled.switch(self.t, self.y)   # scheduled wrenches (loads.py)
        due = self.releases.timed_out(self.active, self.t)
        if due.size:
            self._release(due, 'time')

    def _joint_forces(self, y):
        return self._joint_loads(y)[0]

    def _step(self, h, t_end):
        """Advance one step of length h to t_end, locating condition releases and stroke ends."""
        self._stage_violation = 0.0
        y0 = self.y
        self._scheduled.set_time(self.t)
        if self.kinematic:
            kernel.motion_set_time(self._bodies, self.t)   # motion.py
        y1, ys, crossing, stroke = self._locate(y0, h)
        if stroke is not None and (crossing is None or crossing[0] >= stroke[0]):
            # an ejector's stroke ends first (or with a release)
            s, wrenches = stroke
            self._commit(ys if s < h else y1, self.t + s if s < h else t_end)
            self._scheduled.end_strokes(wrenches)
            if crossing is not None and crossing[0] <= s:
                for k, cause in zip(crossing[1], crossing[2]):
                    self._release([k], cause)
            self._fire_time_triggers()
        elif crossing is None:
            self._commit(y1, t_end)
        else:
            s, joints, causes = crossing
            self._commit(ys if s < h else y1, self.t + s if s < h else t_end)
            for k, cause in zip(joints, causes):
                self._release([k], cause)

    def _locate(self, y0, h):
        """
        Take the step of h from y0 and locate its release conditions and stroke ends.

        One call of ``kernel.locate``, the compiled form of ``Releases.crossing``
        and ``ScheduledLoads.crossing`` (the same bits). Returns y1 (the step's
        end), ys (the state at the s the step is cut at, if before h), the
        release crossing (s, joints, causes) or None and the stroke end
        (s, wrenches) or None.
        """
        rel = self.releases
        y1, ys = np.empty_like(y0), np.empty_like(y0)
        info = np.empty(7)
        info[0] = self._stage_violation
        joints = np.empty((len(rel.watch), 2), dtype=np.int64)
        wrenches = np.empty(self._scheduled.count, dtype=np.int64)
        try:
            kernel.locate(y0, float(h), y1, ys, *self._topology.kernel_args(self),
                          self.joints.joints_i, self.joints.joints_f, rel.watch,
                          rel.watch_triggers, rel.watch_lines, joints, wrenches, info)
        except np.linalg.LinAlgError:
            info[1] = kernel.SINGULAR
        self._stage_violation = float(info[0])
        code = int(info[1])
        if code != kernel.REACHED:
            raise _locate_error(code, float(info[2]))
        crossing = stroke = None
        if not math.isnan(info[3]):
            found = joints[:int(info[4])]
            crossing = (float(info[3]), found[:, 0].tolist(),
                        [TRIGGER_CAUSES[1 + col] for col in found[:, 1]])
        if not math.isnan(info[5]):
            stroke = (float(info[5]), wrenches[:int(info[6])].tolist())
        return y1, ys, crossing, stroke

    def _commit(self, y1, t1):
        if not np.isfinite(y1).all():
            raise NumericalFailure('the state is no longer finite (the system diverged)')
        if self._stage_violation > DIVERGENCE_VIOLATION:
            raise NumericalFailure(
                f'constraint violation {self._stage_violation:.3g} exceeds '
                f'{DIVERGENCE_VIOLATION:g} (the system diverged; try a smaller dt)')
        self.max_violation = max(self.max_violation, self._stage_violation)
        self.y = y1
        self.t = t1
        self._scheduled.set_time(t1)
        if self.kinematic:
            self._place(t1)   # the state, and accelerations, at t1 (motion.py)
        self.steps += 1
