# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The CFEM engine: Newton-Euler bodies, joint rows, Baumgarte, RK4, releases.

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

import numpy as np
from scipy.optimize import brentq

from cfem_ros import rotations
from cfem_ros.model import Model

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
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
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


class _Rows:
    """The constraint rows of the active joints, as flat arrays.

    Translation rows (primitive 1) come first, then rotation rows (primitive
    2 with perpendicular vectors). Vectors are in the body axes of the body
    that carries them.
    """

    def __init__(self, tables: dict, active: np.ndarray, n_bodies: int):
        t = active[tables['t_joint']]
        r = active[tables['r_joint']]
        self.t_joint = tables['t_joint'][t]
        self.t_a = tables['t_a'][t]
        self.t_b = tables['t_b'][t]
        self.t_axis_a = tables['t_axis_a'][t]
        self.t_anchor_a = tables['t_anchor_a'][t]
        self.t_anchor_b = tables['t_anchor_b'][t]
        self.r_joint = tables['r_joint'][r]
        self.r_a = tables['r_a'][r]
        self.r_b = tables['r_b'][r]
        self.r_vec_a = tables['r_vec_a'][r]
        self.r_vec_b = tables['r_vec_b'][r]
        self.n_t = len(self.t_joint)
        self.m = self.n_t + len(self.r_joint)
        a = np.concatenate([self.t_a, self.r_a])
        b = np.concatenate([self.t_b, self.r_b])
        self.a = a
        self.b = b
        # Column indices of each row's two 6-blocks in the dense Jacobian.
        six = np.arange(6)
        self.cols_a = 6 * a[:, None] + six
        self.cols_b = 6 * b[:, None] + six
        self.row_index = np.arange(self.m)[:, None]
        self.n_cols = 6 * n_bodies
        self.redundant = False


class Simulator:
    """Step a model's bodies and joints in time with RK4.

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
        self.force_ext = np.zeros((n, 3))
        self.torque_ext = np.zeros((n, 3))
        self.wrench_body_axes = np.zeros(n, dtype=bool)

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

        self._build_joint_tables()
        self.active = np.ones(len(model.joints), dtype=bool)
        self._rows = _Rows(self._tables, self.active, n)
        self.dof = self._check_redundancy()
        self._fire_time_triggers()
        self._project_velocities()

    # ----------------------------------------------------------------- views

    def _split(self, y):
        """Views (position, velocity, quaternion, rates) of a state vector."""
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
        """Unit quaternions (x, y, z, w), body to world, shape (n, 4)."""
        return self._split(self.y)[2].copy()

    @property
    def rates(self) -> np.ndarray:
        """Angular velocities (P, Q, R), body axes, rad/s, shape (n, 3)."""
        return self._split(self.y)[3].copy()

    def velocity_body(self) -> np.ndarray:
        """CG velocities in body axes, m/s, shape (n, 3)."""
        _, vel, quat, _ = self._split(self.y)
        return np.einsum('nji,nj->ni', rotations.matrices(quat), vel)

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

        def column(rows, i, shape):
            return np.array([r[i] for r in rows], dtype=float).reshape(shape)

        self._tables = {
            't_joint': np.array([r[0] for r in t_rows], dtype=int),
            't_a': np.array([r[1] for r in t_rows], dtype=int),
            't_b': np.array([r[2] for r in t_rows], dtype=int),
            't_axis_a': column(t_rows, 3, (-1, 3)),
            't_anchor_a': column(t_rows, 4, (-1, 3)),
            't_anchor_b': column(t_rows, 5, (-1, 3)),
            'r_joint': np.array([r[0] for r in r_rows], dtype=int),
            'r_a': np.array([r[1] for r in r_rows], dtype=int),
            'r_b': np.array([r[2] for r in r_rows], dtype=int),
            'r_vec_a': column(r_rows, 3, (-1, 3)),
            'r_vec_b': column(r_rows, 4, (-1, 3)),
        }

    # ------------------------------------------------------------ kinematics

    def _kinematics(self, y):
        """Rotation matrices, world rates and world inertias of a state."""
        pos, vel, quat, rates = self._split(y)
        rot = rotations.matrices(quat)
        omega = _apply(rot, rates)
        inv_inertia = rot @ self.inv_inertia_body @ rot.transpose(0, 2, 1)
        return pos, vel, rot, omega, inv_inertia

    def _constraint_terms(self, pos, vel, rot, omega):
        """Jacobian blocks, values, velocities and gamma of the active rows.

        Returns
        -------
        jac_a, jac_b : ndarray, shape (m, 6)
            d(row rate)/d(V, w) of the parent and of the child, world axes.
        value : ndarray, shape (m,)
            g (m) for translation rows, e_A . e_B for rotation rows.
        rate : ndarray, shape (m,)
            dg/dt = J v.
        gamma : ndarray, shape (m,)
            (dJ/dt) v, the part of d2g/dt2 free of accelerations.
        directions : ndarray, shape (m, 3)
            World direction of each row's load: the force direction e for
            translation rows, the moment direction f x e for rotation rows.

        """
        rows = self._rows
        m = rows.m
        jac_a = np.zeros((m, 6))
        jac_b = np.zeros((m, 6))
        value = np.empty(m)
        rate = np.empty(m)
        gamma = np.empty(m)
        directions = np.empty((m, 3))
        nt = rows.n_t
        if nt:
            a, b = rows.t_a, rows.t_b
            e = _apply(rot[a], rows.t_axis_a)
            rho_a = _apply(rot[a], rows.t_anchor_a)
            rho_b = _apply(rot[b], rows.t_anchor_b)
            w_a, w_b = omega[a], omega[b]
            point_b = pos[b] + rho_b
            d = point_b - pos[a] - rho_a
            d_dot = vel[b] + _cross(w_b, rho_b) - vel[a] - _cross(w_a, rho_a)
            w_a_e = _cross(w_a, e)
            jac_a[:nt, :3] = -e
            jac_a[:nt, 3:] = -_cross(point_b - pos[a], e)
            jac_b[:nt, :3] = e
            jac_b[:nt, 3:] = _cross(rho_b, e)
            value[:nt] = _dot(d, e)
            rate[:nt] = _dot(e, d_dot) + _dot(d, w_a_e)
            centripetal = _cross(w_b, _cross(w_b, rho_b)) - _cross(w_a, _cross(w_a, rho_a))
            gamma[:nt] = (2.0 * _dot(w_a_e, d_dot) + _dot(e, centripetal)
                          + _dot(d, _cross(w_a, w_a_e)))
            directions[:nt] = e
        if m > nt:
            a, b = rows.r_a, rows.r_b
            e = _apply(rot[a], rows.r_vec_a)
            f = _apply(rot[b], rows.r_vec_b)
            c = _cross(f, e)
            w_a, w_b = omega[a], omega[b]
            relative = w_b - w_a
            jac_a[nt:, 3:] = -c
            jac_b[nt:, 3:] = c
            value[nt:] = _dot(e, f)
            rate[nt:] = _dot(relative, c)
            gamma[nt:] = _dot(relative, _cross(_cross(w_b, f), e) + _cross(f, _cross(w_a, e)))
            directions[nt:] = c
        return jac_a, jac_b, value, rate, gamma, directions

    def _dense(self, block_a, block_b):
        """Scatter per-row 6-blocks into a dense (m, 6 n) matrix."""
        rows = self._rows
        out = np.zeros((rows.m, rows.n_cols))
        out[rows.row_index, rows.cols_a] = block_a
        out[rows.row_index, rows.cols_b] = block_b
        return out

    def _weighted(self, jac, bodies, inv_inertia):
        """Rows of J M^-1 for one side of each row: (m, 6)."""
        out = np.empty_like(jac)
        out[:, :3] = jac[:, :3] * self.inv_mass[bodies][:, None]
        out[:, 3:] = _apply(inv_inertia[bodies], jac[:, 3:])
        return out

    def _solve(self, y):
        """Accelerations and joint loads at a state.

        Returns
        -------
        acc : ndarray, shape (n, 3)
            CG accelerations, world, m/s^2.
        alpha : ndarray, shape (n, 3)
            Angular accelerations, world axes, rad/s^2.
        lam : ndarray, shape (m,)
            Row loads: N for translation rows, N m for rotation rows.
        directions : ndarray, shape (m, 3)
            World directions of the row loads.
        value : ndarray, shape (m,)
            Constraint values at the state.

        """
        pos, vel, rot, omega, inv_inertia = self._kinematics(y)
        inertia = rot @ self.inertia_body @ rot.transpose(0, 2, 1)
        force = self.mass[:, None] * self.gravity + self._external(self.force_ext, rot)
        torque = self._external(self.torque_ext, rot) - _cross(omega, _apply(inertia, omega))
        acc = force * self.inv_mass[:, None]
        alpha = _apply(inv_inertia, torque)
        rows = self._rows
        if rows.m == 0:
            empty = np.empty(0)
            return acc, alpha, empty, np.empty((0, 3)), empty
        jac_a, jac_b, value, rate, gamma, directions = self._constraint_terms(
            pos, vel, rot, omega)
        a, b = rows.a, rows.b
        free_rate = (_dot(jac_a[:, :3], acc[a]) + _dot(jac_a[:, 3:], alpha[a])
                     + _dot(jac_b[:, :3], acc[b]) + _dot(jac_b[:, 3:], alpha[b]))
        rhs = -gamma - 2.0 * self.eta * rate - self.eta ** 2 * value - free_rate
        jac = self._dense(jac_a, jac_b)
        weighted = self._dense(self._weighted(jac_a, a, inv_inertia),
                               self._weighted(jac_b, b, inv_inertia))
        schur = weighted @ jac.T
        try:
            if rows.redundant:
                lam = np.linalg.lstsq(schur, rhs, rcond=1e-10)[0]
            else:
                lam = np.linalg.solve(schur, rhs)
        except np.linalg.LinAlgError as err:
            raise _NumericalFailure('the constraint system is singular') from err
        generalized = (weighted.T @ lam).reshape(self.n, 6)
        acc += generalized[:, :3]
        alpha += generalized[:, 3:]
        return acc, alpha, lam, directions, value

    def _external(self, load, rot):
        """External force or torque in world axes, rotating body-axis loads."""
        if not self.wrench_body_axes.any():
            return load
        return np.where(self.wrench_body_axes[:, None], _apply(rot, load), load)

    def derivative(self, y: np.ndarray) -> np.ndarray:
        """Return dy/dt at state y (external wrenches held constant)."""
        acc, alpha, _, _, value = self._solve(y)
        _, vel, quat, rates = self._split(y)
        rot = rotations.matrices(quat)
        if value.size:
            self._stage_violation = max(self._stage_violation, float(np.abs(value).max()))
        return np.concatenate([
            vel.ravel(), acc.ravel(),
            rotations.rate_of_change(quat, rates).ravel(),
            np.einsum('nji,nj->ni', rot, alpha).ravel(),
        ])

    def _rk4(self, y, h):
        """One classical RK4 step of length h from y, quaternions normalized."""
        k1 = self.derivative(y)
        k2 = self.derivative(y + 0.5 * h * k1)
        k3 = self.derivative(y + 0.5 * h * k2)
        k4 = self.derivative(y + h * k3)
        out = y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        quat = self._split(out)[2]
        quat /= np.linalg.norm(quat, axis=1)[:, None]
        return out

    # ------------------------------------------------------- starting checks

    def _jacobian(self, y):
        """Dense Jacobian (m, 6 n) of the active rows and M^-1 blocks."""
        pos, vel, rot, omega, inv_inertia = self._kinematics(y)
        jac_a, jac_b = self._constraint_terms(pos, vel, rot, omega)[:2]
        rows = self._rows
        jac = self._dense(jac_a, jac_b)
        weighted = self._dense(self._weighted(jac_a, rows.a, inv_inertia),
                               self._weighted(jac_b, rows.b, inv_inertia))
        return jac, weighted, rot

    def _check_redundancy(self) -> int:
        """Detect redundant rows; warn once; return the remaining DOF."""
        free_dof = 6 * int(self.free.sum())
        rows = self._rows
        if rows.m == 0:
            return free_dof
        jac, weighted, _ = self._jacobian(self.y)
        schur = weighted @ jac.T
        scale = 1.0 / np.sqrt(np.maximum(np.diag(schur), 1e-300))
        rank = np.linalg.matrix_rank(schur * scale[:, None] * scale[None, :], tol=1e-9)
        if rank < rows.m:
            if not rows.redundant and not getattr(self, '_warned_redundant', False):
                names = sorted({self.model.joints[k].name
                                for k in np.concatenate([rows.t_joint, rows.r_joint])})
                self.log.warning(
                    'the joints %s constrain %d direction(s) more than once (redundant '
                    'joints or a closed loop): the motion is exact, the loads of the '
                    'redundant directions are shared in the least-norm sense',
                    ', '.join(names), rows.m - rank)
                self._warned_redundant = True
            rows.redundant = True
        return free_dof - rank

    def _project_velocities(self):
        """Make the initial velocities consistent with the joints (mass weighted)."""
        rows = self._rows
        if rows.m == 0:
            return
        _, vel, _, rates = self._split(self.y)
        jac, weighted, rot = self._jacobian(self.y)
        omega = _apply(rot, rates)
        v = np.concatenate([vel, omega], axis=1).ravel()
        schur = weighted @ jac.T
        lam = np.linalg.lstsq(schur, jac @ v, rcond=1e-10)[0]
        delta = -(weighted.T @ lam).reshape(self.n, 6)
        if not np.abs(delta).max() > PROJECTION_REPORT:
            return
        vel += delta[:, :3]
        rates += np.einsum('nji,nj->ni', rot, delta[:, 3:])
        for i in np.flatnonzero(np.abs(delta).max(axis=1) > PROJECTION_REPORT):
            self.log.warning(
                'initial velocities of body %r are inconsistent with its joints; '
                'corrected (mass weighted) by %.3g m/s and %.3g deg/s',
                self.model.bodies[i].name, np.linalg.norm(delta[i, :3]),
                math.degrees(np.linalg.norm(delta[i, 3:])))

    # -------------------------------------------------------------- outputs

    def joint_wrenches(self):
        """Loads of the joints on their children at the current state.

        Returns
        -------
        force : ndarray, shape (n_joints, 3)
            Force on the child, world axes, N.
        moment : ndarray, shape (n_joints, 3)
            Moment on the child about the joint point, world axes, N m.
            Released joints have zero force and moment.

        """
        _, _, lam, directions, _ = self._solve(self.y)
        return self._wrenches(lam, directions)

    def _wrenches(self, lam, directions):
        n_j = len(self.model.joints)
        force = np.zeros((n_j, 3))
        moment = np.zeros((n_j, 3))
        rows = self._rows
        nt = rows.n_t
        np.add.at(force, rows.t_joint, lam[:nt, None] * directions[:nt])
        np.add.at(moment, rows.r_joint, lam[nt:, None] * directions[nt:])
        return force, moment

    def joint_points(self, y: Optional[np.ndarray] = None):
        """Each joint's point as carried by its parent and by its child.

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
        if self._rows.m == 0:
            return 0.0
        return float(np.abs(self._solve(self.y)[4]).max())

    # --------------------------------------------------------------- inputs

    def set_wrench(self, body, force, torque, body_axes: bool = False):
        """Hold an external force and moment at a body's CG until replaced.

        Parameters
        ----------
        body : str or int
        force : array_like, shape (3,)
            N, world axes, or body axes if body_axes.
        torque : array_like, shape (3,)
            N m, same axes as force.
        body_axes : bool

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
        self.force_ext[i] = force
        self.torque_ext[i] = torque
        self.wrench_body_axes[i] = bool(body_axes)

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
        self._rows = _Rows(self._tables, self.active, self.n)
        self.dof = self._check_redundancy()
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

    def advance_to(self, t_target: float) -> bool:
        """Integrate to t_target in RK4 steps of dt, the last one cut to land on it.

        Steps are also cut at release times, and a step in which a release
        condition is crossed is cut at the crossing, located on the step's own
        RK4 map. Returns False (and sets ``status`` and ``message``) if the
        run failed; the state is then the last good one.
        """
        if self.status != 'running':
            return False
        try:
            while self.t < t_target:
                remaining = t_target - self.t
                if remaining <= self.dt * (1.0 + 1e-9):
                    h, t_end = remaining, t_target
                else:
                    h, t_end = self.dt, self.t + self.dt
                due = self._next_time_trigger()
                if due is not None and due < t_end:
                    h, t_end = due - self.t, due
                self._step(h, t_end)
        except _NumericalFailure as err:
            self.status = 'failed'
            self.message = f'at t = {self.t:.9g} s: {err}'
            return False
        return True

    def _next_time_trigger(self) -> Optional[float]:
        times = self.triggers[self.active, 0]
        times = times[np.isfinite(times)]
        return float(times.min()) if times.size else None

    def _fire_time_triggers(self):
        due = self.active & (self.triggers[:, 0] <= self.t)
        if due.any():
            self._release(np.flatnonzero(due), 'time')

    def _condition_values(self, y, joints):
        """Angle (rad), distance (m) and force (N) of some joints at y, (k, 3)."""
        out = np.empty((len(joints), 3))
        out[:, 0] = self.joint_angles(y)[joints]
        on_a, on_b = self.joint_points(y)
        out[:, 1] = np.linalg.norm(on_b - on_a, axis=1)[joints]
        if np.isfinite(self.triggers[joints, 3]).any():
            _, _, lam, directions, _ = self._solve(y)
            out[:, 2] = np.linalg.norm(self._wrenches(lam, directions)[0], axis=1)[joints]
        else:
            out[:, 2] = 0.0
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
