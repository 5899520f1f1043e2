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

from cfem_ros import kernel, rotations
from cfem_ros.model import Model
import numpy as np
from scipy.optimize import brentq

LOG = logging.getLogger('cfem_ros')

#: Constraint violation (m, or rad for rotation rows) beyond which a run is
#: declared diverged: a million times what the stabilized integration keeps.
DIVERGENCE_VIOLATION = 1e-3

#: Velocity corrections smaller than this (m/s, rad/s) are not reported.
PROJECTION_REPORT = 1e-9

#: Indices of the release triggers in ``Simulator.triggers``.
TRIGGER_CAUSES = ('time', 'angle', 'distance', 'force')


class _NumericalFailure(Exception):
    """Raised inside a step; turned into ``status = 'failed'``."""


def _cross(a, b):
    """Row-wise cross products of two (m, 3) arrays (faster than np.cross)."""
    a, b = np.broadcast_arrays(a, b) if a.shape != b.shape else (a, b)
    out = np.empty(a.shape)
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _dot(a, b):
    """Row-wise dot products of two (m, 3) arrays."""
    return np.einsum('ij,ij->i', a, b)


def _apply(matrices, vectors):
    """Row-wise matrix-vector products, (m, 3, 3) @ (m, 3)."""
    return np.einsum('mij,mj->mi', matrices, vectors)


class SampleGrid:
    """
    Samples on the grid k / rate_hz, taken by the kernel inside ``Simulator.advance_to``.

    Steps are cut at the grid's times (as they are when each sample time is
    a target of its own), and at each the sample's outputs
    (``Simulator.outputs``) go to the next of ``rows``; rows with no columns
    only count the samples. Before each call, ``reset`` says where the next
    rows go.

    Parameters
    ----------
    rate_hz : float
        Samples per second.

    """

    def __init__(self, rate_hz: float):
        #: rate (Hz), index of the next sample, samples taken in the last call.
        self.state = np.array([float(rate_hz), 0.0, 0.0])
        self.rows = np.empty((0, 0))

    def reset(self, next_index: int, rows: np.ndarray):
        """Take samples from index next_index on, into rows (C-contiguous float64)."""
        if rows.ndim != 2 or rows.dtype != np.float64 or not rows.flags.c_contiguous:
            raise ValueError('sample rows must be a C-contiguous 2-d float64 array')
        self.state[1:] = (next_index, 0)
        self.rows = rows

    @property
    def taken(self) -> int:
        """Return the number of samples taken since ``reset``."""
        return int(self.state[2])

    @property
    def next_time(self) -> float:
        """Return the time of the next sample to take, s."""
        return self.state[1] / self.state[0]


#: What ``kernel.advance`` gets for no sample grid.
_NO_GRID = np.zeros(3)
_NO_ROWS = np.empty((0, 0))


class _Topology:
    """
    The constraint rows of the active joints and how to solve them, for ``kernel``.

    Rows come grouped by joint, translation rows (primitive 1) before
    rotation rows (primitive 2 with perpendicular vectors); vectors are in
    the body axes of the body that carries them. When the joints form a
    forest (all fixed bodies counted as one ground), ``plan`` lists them
    leaves first for the kernel's linear-time tree solve; otherwise (closed
    loops, two joints on one pair) the dense form is used.
    """

    def __init__(self, tables: dict, active: np.ndarray, free: np.ndarray):
        keep = active[tables['joint']]
        self.joint = tables['joint'][keep]
        self.rows_i = np.array(tables['rows_i'][keep])
        self.rows_f = np.ascontiguousarray(tables['vectors'][keep])
        self.translation = self.rows_i[:, 2].astype(bool)
        # 2: a translation row at the same joint point as the row before (the kernel
        # computes the point's terms once per joint)
        self.rows_i[1:, 2][self.translation[1:] & self.translation[:-1]
                           & (self.joint[1:] == self.joint[:-1])
                           & (self.rows_f[1:, 3:9] == self.rows_f[:-1, 3:9]).all(axis=1)] = 2
        self.m = len(self.joint)
        joints = np.flatnonzero(active)
        first = np.searchsorted(self.joint, joints)
        counts = np.array([[np.count_nonzero(self.translation[self.joint == k]),
                            np.count_nonzero(~self.translation[self.joint == k])]
                           for k in joints], dtype=np.int64).reshape(-1, 2)
        ends = tables['ends'][joints]
        lines = self._forest(joints, ends, free)
        self.dense = 0 if lines is not None else 1
        if lines is None:   # closed loops: every joint as written, no tree
            lines = [(i, ends[i, 1], ends[i, 0], 1) for i in range(len(joints))]
        self.plan = np.array(
            [(first[i], counts[i, 0], counts[i, 1], child, parent, sign, joints[i])
             for i, child, parent, sign in lines], dtype=np.int64).reshape(-1, 7)
        self.roots = np.where(free, 0, -1).astype(np.int64)
        held = set(self.plan[:, kernel.P_CHILD].tolist())
        touched = held | set(self.plan[:, kernel.P_PARENT].tolist())
        for i in np.flatnonzero(free):
            if i not in held:
                self.roots[i] = 1 if i in touched else 2
        # plan line of each model joint (-1 if released)
        self.line = np.full(len(active), -1, dtype=np.int64)
        self.line[self.plan[:, kernel.P_JOINT]] = np.arange(len(self.plan))
        n = len(free)
        self.work = np.zeros(kernel.workspace_size(n, self.m, len(self.plan)))

    @staticmethod
    def _forest(joints, ends, free):
        """
        Orient the joints as a forest, leaves first; None if they close a loop.

        Returns lines (index into joints, tree child, tree parent, +1 if the
        tree child is the joint's child else -1). Trees hang from the ground
        first, then from the lowest-numbered body of each floating group.
        """
        ground = -1
        node = [i if free[i] else ground for i in range(len(free))]
        edges = {}
        for i, (a, b) in enumerate(ends):
            edges.setdefault(node[a], []).append(i)
            edges.setdefault(node[b], []).append(i)
        seen, used, lines = set(), set(), []
        starts = [ground] + [i for i in range(len(free)) if free[i]]
        for start in starts:
            if start in seen or start not in edges:
                continue
            seen.add(start)
            queue = [start]
            while queue:
                here = queue.pop(0)
                for i in edges[here]:
                    if i in used:
                        continue
                    used.add(i)
                    a, b = ends[i]
                    child = b if node[a] == here else a
                    if node[a] == here and node[b] == here:
                        return None
                    if node[child] in seen:
                        return None
                    seen.add(node[child])
                    queue.append(node[child])
                    parent = a if child == b else b
                    lines.append((i, child, parent, 1 if child == b else -1))
        return lines[::-1]

    def kernel_args(self, sim):
        """Arguments of the kernel's solve functions after y."""
        return (sim._bodies, sim.gravity, sim._loads, self.rows_i, self.rows_f, self.plan,
                self.roots, sim.eta, self.dense, self.work)


class Simulator:
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
        'running' or 'failed'.
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
        self.free = np.array([not b.fixed for b in bodies])
        self.mass = np.array([0.0 if b.fixed else b.mass for b in bodies])
        self.inv_mass = np.where(self.free, 1.0 / np.where(self.free, self.mass, 1.0), 0.0)
        self.inertia_body = np.array([
            np.zeros((3, 3)) if b.fixed else b.inertia for b in bodies])
        self.inv_inertia_body = np.array([
            np.zeros((3, 3)) if b.fixed else np.linalg.inv(b.inertia) for b in bodies])
        self.gravity = np.asarray(model.gravity, dtype=float)
        self._bodies = np.column_stack([
            self.mass, self.inv_mass, self.inertia_body.reshape(n, 9),
            self.inv_inertia_body.reshape(n, 9)])
        # external force (3), torque (3), 1.0 when in body axes
        self._loads = np.zeros((n, 7))

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

        self._build_joint_tables()
        self.active = np.ones(len(model.joints), dtype=bool)
        self._set_topology()
        self._fire_time_triggers()
        self._project_velocities()

    # ----------------------------------------------------------------- views

    def _split(self, y):
        """Return views (position, velocity, quaternion, rates) of a state vector."""
        n = self.n
        return (y[:3 * n].reshape(n, 3), y[3 * n:6 * n].reshape(n, 3),
                y[6 * n:10 * n].reshape(n, 4), y[10 * n:].reshape(n, 3))

    @property
    def position(self) -> np.ndarray:
        """CG positions, world, m, shape (n, 3)."""
        return self._split(self.y)[0].copy()

    @property
    def velocity(self) -> np.ndarray:
        """CG velocities, world axes, m/s, shape (n, 3)."""
        return self._split(self.y)[1].copy()

    @property
    def orientation(self) -> np.ndarray:
        """Return unit quaternions (x, y, z, w), body to world, shape (n, 4)."""
        return self._split(self.y)[2].copy()

    @property
    def rates(self) -> np.ndarray:
        """Angular velocities (P, Q, R), body axes, rad/s, shape (n, 3)."""
        return self._split(self.y)[3].copy()

    def velocity_body(self) -> np.ndarray:
        """CG velocities in body axes, m/s, shape (n, 3)."""
        _, vel, quat, _ = self._split(self.y)
        return rotations.to_body(quat, vel)

    # ------------------------------------------------------------- the model

    def _build_joint_tables(self):
        """Turn the joints into row tables in body axes (done once)."""
        model = self.model
        pos0, _, quat0, _ = self._split(self.y)
        rot0 = rotations.matrices(quat0)
        t_rows, r_rows = [], []
        n_j = len(model.joints)
        self.joint_parent = np.array([j.parent for j in model.joints], dtype=int)
        self.joint_child = np.array([j.child for j in model.joints], dtype=int)
        self.joint_anchor_a = np.zeros((n_j, 3))
        self.joint_anchor_b = np.zeros((n_j, 3))
        self.triggers = np.full((n_j, 4), np.nan)
        for k, joint in enumerate(model.joints):
            a, b = joint.parent, joint.child
            anchor_a = rot0[a].T @ (joint.anchor - pos0[a])
            anchor_b = rot0[b].T @ (joint.anchor - pos0[b])
            self.joint_anchor_a[k] = anchor_a
            self.joint_anchor_b[k] = anchor_b
            triad_a = joint.triad @ rot0[a]   # rows: u_i in A's body axes
            triad_b = joint.triad @ rot0[b]
            for i in joint.rows.translation:
                t_rows.append((k, a, b, triad_a[i], anchor_a, anchor_b))
            for i, j in joint.rows.rotation:
                r_rows.append((k, a, b, triad_a[i], triad_b[j]))
            rel = joint.release
            self.triggers[k] = [np.nan if v is None else v
                                for v in (rel.time, rel.angle, rel.distance, rel.force)]
        self.relative0 = rotations.multiply(
            rotations.conjugate(quat0[self.joint_parent]), quat0[self.joint_child])

        rows = sorted(t_rows + [(k, a, b, u, v, None) for k, a, b, u, v in r_rows],
                      key=lambda row: (row[0], row[5] is None))
        self._tables = {
            'joint': np.array([r[0] for r in rows], dtype=np.int64),
            'rows_i': np.array([(r[1], r[2], r[5] is not None) for r in rows],
                               dtype=np.int64).reshape(-1, 3),
            'vectors': np.array([np.concatenate([r[3], r[4], np.zeros(3) if r[5] is None
                                                 else r[5]]) for r in rows]).reshape(-1, 9),
            'ends': np.column_stack([self.joint_parent, self.joint_child]).reshape(-1, 2),
        }
        # for the release conditions: anchors and relative attitude at t = 0
        self._joints_i = np.ascontiguousarray(self._tables['ends'])
        self._joints_f = np.ascontiguousarray(np.column_stack([
            self.joint_anchor_a, self.joint_anchor_b, self.relative0]).reshape(-1, 10))

    # ------------------------------------------------------------ hot path

    def _set_topology(self):
        """Rebuild the rows, the solve plan and the workspace for the active joints."""
        self._topology = _Topology(self._tables, self.active, self.free)
        self.dof = self._check_redundancy()
        top = self._topology
        watched = np.flatnonzero(self.active & np.isfinite(self.triggers[:, 1:]).any(axis=1))
        self._watch = watched.astype(np.int64)
        limits = self.triggers[watched, 1:]
        self._watch_limits = np.ascontiguousarray(np.where(np.isfinite(limits), limits, np.inf))
        self._watch_lines = np.ascontiguousarray(top.line[watched])
        times = self.triggers[self.active, 0]
        times = times[np.isfinite(times)]
        self._due = float(times.min()) if times.size else None
        active = np.flatnonzero(self.active)
        self._outputs_key = tuple(active.tolist())
        self._outputs_order = np.ascontiguousarray(top.line[active], dtype=np.int64)

    def _joint_loads(self, y):
        """
        Each joint's load on its child at a state, and the constraint values.

        Returns
        -------
        force, moment : ndarray, shape (n_joints, 3)
            World axes, N and N m about the joint point; zero for released joints.
        value : ndarray, shape (m,)
            Constraint values of the active rows (m, or rad).

        """
        top = self._topology
        n_j = len(self.model.joints)
        force, moment = np.zeros((n_j, 3)), np.zeros((n_j, 3))
        lines = len(top.plan)
        f_line, m_line = np.empty((lines, 3)), np.empty((lines, 3))
        try:
            ok = kernel.joint_loads(np.ascontiguousarray(y), *top.kernel_args(self),
                                    f_line, m_line)
        except np.linalg.LinAlgError:
            ok = False
        if not ok:
            raise _NumericalFailure('the constraint system is singular')
        force[top.plan[:, kernel.P_JOINT]] = f_line
        moment[top.plan[:, kernel.P_JOINT]] = m_line
        value = kernel.constraint_values(top.work, self.n, top.m, lines).copy()
        return force, moment, value

    def derivative(self, y: np.ndarray) -> np.ndarray:
        """Return dy/dt at state y (external wrenches held constant)."""
        out = np.empty_like(y)
        if kernel.derivative(y, out, *self._topology.kernel_args(self)) < 0.0:
            raise _NumericalFailure('the constraint system is singular')
        return out

    def _rk4(self, y, h):
        """One classical RK4 step of length h from y, quaternions normalized."""
        out = np.empty_like(y)
        try:
            worst = kernel.rk4_step(y, h, out, *self._topology.kernel_args(self))
        except np.linalg.LinAlgError:
            worst = -1.0
        if worst < 0.0:
            raise _NumericalFailure('the constraint system is singular')
        self._stage_violation = max(self._stage_violation, worst)
        return out

    # ------------------------------------------------------- starting checks

    def _jacobian(self, y):
        """Dense Jacobian J and J M^-1, (m, 6 n), of the active rows at y."""
        top = self._topology
        kernel.row_jacobian(y, *top.kernel_args(self))
        views = kernel.carve(top.work, self.n, top.m, len(top.plan))
        return self._dense(views[6]), self._dense(views[7])

    def _dense(self, blocks):
        """Scatter per-row (parent, child) 6-blocks into a dense (m, 6 n) matrix."""
        top = self._topology
        out = np.zeros((top.m, 6 * self.n))
        rows = np.arange(top.m)[:, None]
        six = np.arange(6)
        out[rows, 6 * top.rows_i[:, :1] + six] = blocks[:, :6]
        out[rows, 6 * top.rows_i[:, 1:2] + six] = blocks[:, 6:]
        return out

    def _check_redundancy(self) -> int:
        """Detect redundant rows; warn once; return the remaining DOF."""
        free_dof = 6 * int(self.free.sum())
        top = self._topology
        if top.m == 0 or not top.dense:
            # a forest: each joint's rows are independent, and so are the joints
            return free_dof - top.m
        jac, weighted = self._jacobian(self.y)
        schur = weighted @ jac.T
        scale = 1.0 / np.sqrt(np.maximum(np.diag(schur), 1e-300))
        rank = np.linalg.matrix_rank(schur * scale[:, None] * scale[None, :], tol=1e-9)
        if rank < top.m:
            if not getattr(self, '_warned_redundant', False):
                names = sorted({self.model.joints[k].name for k in top.joint})
                self.log.warning(
                    'the joints %s constrain %d direction(s) more than once (redundant '
                    'joints or a closed loop): the motion is exact, the loads of the '
                    'redundant directions are shared in the least-norm sense',
                    ', '.join(names), top.m - rank)
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

    # -------------------------------------------------------------- outputs

    def joint_wrenches(self):
        """
        Return the loads of the joints on their children at the current state.

        Returns
        -------
        force : ndarray, shape (n_joints, 3)
            Force on the child, world axes, N.
        moment : ndarray, shape (n_joints, 3)
            Moment on the child about the joint point, world axes, N m.
            Released joints have zero force and moment.

        """
        return self._joint_loads(self.y)[:2]

    @property
    def active_joints(self) -> tuple:
        """Return the active joints (model indices, ascending)."""
        return self._outputs_key

    def outputs(self, out: Optional[np.ndarray] = None) -> np.ndarray:
        """
        Return what a sample publishes at the current state, in one kernel call.

        Parameters
        ----------
        out : ndarray, optional
            Where to write it (a fresh array if not given).

        Returns
        -------
        ndarray, shape (13 n + 6 len(active_joints),)
            Per body its pose (CG position, m; quaternion x y z w, body to
            world) and twist (CG velocity, m/s, and angular velocity, rad/s,
            both in body axes); then per active joint its force and moment on
            the child (world axes, N and N m about the joint point).

        """
        if out is None:
            out = np.empty(self._outputs_size())
        try:
            ok = kernel.sample_outputs(self.y, *self._topology.kernel_args(self),
                                       self._outputs_order, out)
        except np.linalg.LinAlgError:
            ok = False
        if not ok:
            raise _NumericalFailure('the constraint system is singular')
        return out

    def joint_points(self, y: Optional[np.ndarray] = None):
        """
        Each joint's point as carried by its parent and by its child.

        Returns
        -------
        on_parent, on_child : ndarray, shape (n_joints, 3)
            World, m.

        """
        pos, _, quat, _ = self._split(self.y if y is None else y)
        rot = rotations.matrices(quat)
        pa, pb = self.joint_parent, self.joint_child
        return (pos[pa] + _apply(rot[pa], self.joint_anchor_a),
                pos[pb] + _apply(rot[pb], self.joint_anchor_b))

    def joint_angles(self, y: Optional[np.ndarray] = None) -> np.ndarray:
        """Rotation of each child relative to its parent since t = 0, rad."""
        quat = self._split(self.y if y is None else y)[2]
        quat = quat / np.linalg.norm(quat, axis=1)[:, None]
        relative = rotations.multiply(
            rotations.conjugate(quat[self.joint_parent]), quat[self.joint_child])
        return rotations.rotation_angle(
            rotations.multiply(rotations.conjugate(self.relative0), relative))

    def constraint_violation(self) -> float:
        """Largest |g| of the active rows now (m, or rad for rotation rows)."""
        if self._topology.m == 0:
            return 0.0
        return float(np.abs(self._joint_loads(self.y)[2]).max())

    # --------------------------------------------------------------- inputs

    def set_wrench(self, body, force, torque, body_axes: bool = False):
        """
        Hold an external force and moment at a body's CG until replaced.

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

        """
        i = self._body(body)
        force = np.asarray(force, dtype=float)
        torque = np.asarray(torque, dtype=float)
        if force.shape != (3,) or torque.shape != (3,):
            raise ValueError('force and torque must have 3 components each')
        if not (np.isfinite(force).all() and np.isfinite(torque).all()):
            raise ValueError('force and torque must be finite')
        if not self.free[i]:
            raise ValueError(f'body {self.model.bodies[i].name!r} is fixed and cannot be loaded')
        self._loads[i] = np.concatenate([force, torque, [1.0 if body_axes else 0.0]])

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
                   samples: Optional[SampleGrid] = None) -> bool:
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
        and the samples in time order and call again.
        Returns False (and sets ``status`` and ``message``) if the run failed;
        the state is then the last good one.
        """
        if self.status != 'running':
            return False
        limit = math.inf if limit is None else limit
        if samples is not None and samples.rows.shape[1] not in (0, self._outputs_size()):
            raise ValueError(f'sample rows have {samples.rows.shape[1]} columns; the outputs '
                             f'of this state have {self._outputs_size()}')
        try:
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
                else:
                    self._fire_time_triggers()
                if samples is not None:
                    break   # back to the caller: rows to take, or a release's events
                if result != kernel.CONDITION and self.t < t_target and self.t < due:
                    break   # the next step would end after limit
        except _NumericalFailure as err:
            self.status = 'failed'
            self.message = f'at t = {self.t:.9g} s: {err}'
            return False
        return True

    def _outputs_size(self) -> int:
        return 13 * self.n + 6 * len(self._outputs_key)

    def _run(self, t_target, due, limit, samples=None):
        """Take steps in the kernel until a target, a release time, limit or a condition."""
        top = self._topology
        info = self._info
        info[:] = (self.t, 0.0, self.max_violation, kernel.REACHED, DIVERGENCE_VIOLATION, 0.0)
        grid, rows = (_NO_GRID, _NO_ROWS) if samples is None else (samples.state, samples.rows)
        try:
            kernel.advance(self.y, info, t_target, due, limit, self.dt, *top.kernel_args(self),
                           self._joints_i, self._joints_f, self._watch, self._watch_limits,
                           self._watch_lines, grid, self._outputs_order, rows)
        except np.linalg.LinAlgError:
            info[3] = kernel.SINGULAR
        finally:
            self.t = float(info[0])
            self.steps += int(info[1])
            self.max_violation = float(info[2])
        result = int(info[3])
        if result == kernel.NOT_FINITE:
            raise _NumericalFailure('the state is no longer finite (the system diverged)')
        if result == kernel.VIOLATION:
            raise _NumericalFailure(
                f'constraint violation {info[5]:.3g} exceeds {DIVERGENCE_VIOLATION:g} '
                '(the system diverged; try a smaller dt)')
        if result == kernel.SINGULAR:
            raise _NumericalFailure('the constraint system is singular')
        return result

    def _next_time_trigger(self) -> Optional[float]:
        return self._due   # set with the topology: active joints' time triggers change with it

    def _fire_time_triggers(self):
        if self._due is None or self.t < self._due:
            return
        due = self.active & (self.triggers[:, 0] <= self.t)
        if due.any():
            self._release(np.flatnonzero(due), 'time')

    def _condition_values(self, y, joints):
        """Angle (rad), distance (m) and force (N) of some joints at y, (k, 3)."""
        out = np.zeros((len(joints), 3))
        kernel.conditions(np.ascontiguousarray(y), self._joints_i, self._joints_f,
                          np.asarray(joints, dtype=np.int64), out)
        if np.isfinite(self.triggers[joints, 3]).any():
            out[:, 2] = np.linalg.norm(self._joint_loads(y)[0], axis=1)[joints]
        return out

    def _step(self, h, t_end):
        """Advance one step of length h to t_end, locating condition releases."""
        self._stage_violation = 0.0
        y0 = self.y
        y1 = self._rk4(y0, h)
        watched = np.flatnonzero(self.active & np.isfinite(self.triggers[:, 1:]).any(axis=1))
        crossing = None
        if watched.size:
            limits = self.triggers[watched, 1:]
            reached = self._condition_values(y1, watched) >= limits
            if reached.any():
                crossing = self._locate(y0, h, watched, limits, reached)
        if crossing is None:
            self._commit(y1, t_end)
        else:
            s, joints, causes = crossing
            self._commit(self._rk4(y0, s) if s < h else y1, self.t + s if s < h else t_end)
            for k, cause in zip(joints, causes):
                self._release([k], cause)
        self._fire_time_triggers()

    def _locate(self, y0, h, watched, limits, reached):
        """Find the earliest crossing in (0, h] on the RK4 map s -> rk4(y0, s)."""
        best = (h, [], [])
        for row, col in zip(*np.nonzero(reached)):
            k = watched[row]

            def excess(s, k=k, col=col):
                if s == 0.0:
                    values = self._condition_values(y0, np.array([k]))
                else:
                    values = self._condition_values(self._rk4(y0, s), np.array([k]))
                return values[0, col] - self.triggers[k, 1 + col]

            if excess(0.0) >= 0.0:
                s = 0.0
            else:
                s = brentq(excess, 0.0, h, xtol=1e-15, rtol=4 * np.finfo(float).eps,
                           maxiter=200)
            if s < best[0] - 1e-15:
                best = (s, [k], [TRIGGER_CAUSES[1 + col]])
            elif abs(s - best[0]) <= 1e-15 and k not in best[1]:
                best[1].append(k)
                best[2].append(TRIGGER_CAUSES[1 + col])
        return best

    def _commit(self, y1, t1):
        if not np.isfinite(y1).all():
            raise _NumericalFailure('the state is no longer finite (the system diverged)')
        if self._stage_violation > DIVERGENCE_VIOLATION:
            raise _NumericalFailure(
                f'constraint violation {self._stage_violation:.3g} exceeds '
                f'{DIVERGENCE_VIOLATION:g} (the system diverged; try a smaller dt)')
        self.max_violation = max(self.max_violation, self._stage_violation)
        self.y = y1
        self.t = t1
        self.steps += 1
