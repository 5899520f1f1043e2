# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Independent reference solutions for the physics tests.

Nothing here imports the engine: rotations are Rodrigues matrices, and the
equations are written in generalized coordinates (angles about the free
axes) or as Euler's equations about a fixed point, integrated by scipy's
DOP853 at tolerances far below the engine's error.
"""

import numpy as np
from scipy.integrate import solve_ivp

RTOL = 1e-12
ATOL = 1e-13


def normalized_error(actual, expected, scale=1.0):
    """Return the largest |actual - expected| / scale."""
    return float(np.max(np.abs(np.asarray(actual) - np.asarray(expected))) / scale)


def skew(v):
    """Return the cross-product matrix of v."""
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def axis_rotation(axis, angle):
    """Return the rotation matrix of angle (rad) about a unit axis (Rodrigues)."""
    k = skew(np.asarray(axis, dtype=float))
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def quat_matrix(q):
    """Return the rotation matrix of a quaternion (x, y, z, w)."""
    x, y, z, w = np.asarray(q) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def parallel_axis(inertia_cg, mass, offset):
    """Return the inertia about a point at offset from the CG (same axes)."""
    offset = np.asarray(offset, dtype=float)
    return inertia_cg + mass * (offset @ offset * np.eye(3) - np.outer(offset, offset))


class PivotChain:
    """
    One body turning about a fixed point through successive free axes.

    The attitude is R(q) = Rot(a_1, q_1) Rot(a_2, q_2) ... R0, with the a_i
    fixed in world at t = 0 (a hinge: one axis; a universal joint: the
    parent's axis, then the child's). Euler's equation about the pivot,
    projected on the free axes (the joint's moment has no component there),
    gives the generalized accelerations.

    Parameters
    ----------
    mass : float
    inertia_cg : ndarray, shape (3, 3)
        Body axes.
    rot0 : ndarray, shape (3, 3)
        Attitude at t = 0.
    cg0 : ndarray, shape (3,)
        CG at t = 0, world.
    pivot : ndarray, shape (3,)
        The fixed point, world.
    axes : list of ndarray, shape (3,)
        The free axes, world at t = 0, outermost first.
    gravity : ndarray, shape (3,)

    """

    def __init__(self, mass, inertia_cg, rot0, cg0, pivot, axes, gravity):
        self.mass = mass
        self.inertia_cg_body = np.asarray(inertia_cg, dtype=float)
        self.rot0 = np.asarray(rot0, dtype=float)
        self.pivot = np.asarray(pivot, dtype=float)
        self.rho0 = np.asarray(cg0, dtype=float) - self.pivot
        rho_body = self.rot0.T @ self.rho0
        self.inertia_pivot_body = parallel_axis(self.inertia_cg_body, mass, rho_body)
        self.axes = [np.asarray(a, dtype=float) / np.linalg.norm(a) for a in axes]
        self.gravity = np.asarray(gravity, dtype=float)

    def kinematics(self, q, qd):
        """Return R, the world columns of w = C qd, and the qd-product part of dw/dt."""
        rot = np.eye(3)
        columns = []
        for axis, angle in zip(self.axes, q):
            columns.append(rot @ axis)
            rot = rot @ axis_rotation(axis, angle)
        omega_partial = np.zeros(3)
        bias = np.zeros(3)
        for column, rate in zip(columns, qd):
            # d/dt of a column = (w of the rotations outside it) x column
            bias += rate * np.cross(omega_partial, column)
            omega_partial += rate * column
        return rot @ self.rot0, np.array(columns).T, bias

    def accelerations(self, q, qd):
        """Return generalized accelerations, world w and alpha, attitude."""
        rot, columns, bias = self.kinematics(q, qd)
        omega = columns @ qd
        inertia = rot @ self.inertia_pivot_body @ rot.T
        rho = rot @ self.rot0.T @ self.rho0
        torque = np.cross(rho, self.mass * self.gravity) - np.cross(omega, inertia @ omega)
        lhs = columns.T @ inertia @ columns
        rhs = columns.T @ (torque - inertia @ bias)
        qdd = np.linalg.solve(lhs, rhs)
        return qdd, omega, columns @ qdd + bias, rot

    def solve(self, qd0, times, events=None):
        """Integrate from q = 0 with rates qd0; return the scipy solution."""
        k = len(self.axes)

        def rhs(_, state):
            qdd = self.accelerations(state[:k], state[k:])[0]
            return np.concatenate([state[k:], qdd])

        return solve_ivp(rhs, (0.0, times[-1]), np.concatenate([np.zeros(k), qd0]),
                         method='DOP853', t_eval=times, rtol=RTOL, atol=ATOL,
                         events=events, dense_output=True)

    def state(self, q, qd):
        """
        Return CG, R, rates (body axes), and the joint wrench on the body.

        The wrench is the force and the moment about the pivot that the
        joint must apply for this motion (inverse dynamics about the CG).
        """
        _, omega, alpha, rot = self.accelerations(q, qd)
        rho = rot @ self.rot0.T @ self.rho0
        acc = np.cross(alpha, rho) + np.cross(omega, np.cross(omega, rho))
        force = self.mass * (acc - self.gravity)
        inertia_cg = rot @ self.inertia_cg_body @ rot.T
        moment = inertia_cg @ alpha + np.cross(omega, inertia_cg @ omega) + np.cross(rho, force)
        return self.pivot + rho, rot, rot.T @ omega, force, moment


def torque_free(inertia_body, rot0, rates0_body, times):
    """Integrate a torque-free rigid body; return (R(t), rates_body(t)) lists."""
    inertia = np.asarray(inertia_body, dtype=float)
    inverse = np.linalg.inv(inertia)

    def rhs(_, s):
        rot = s[:9].reshape(3, 3)
        w = s[9:]
        return np.concatenate([(rot @ skew(w)).ravel(), inverse @ -np.cross(w, inertia @ w)])

    sol = solve_ivp(rhs, (times[0], times[-1]), np.concatenate([np.ravel(rot0), rates0_body]),
                    method='DOP853', t_eval=times, rtol=RTOL, atol=ATOL)
    return [s[:9].reshape(3, 3) for s in sol.y.T], [s[9:] for s in sol.y.T]


def heavy_top(mass, inertia_cg, rot0, rho0_world, rates0_body, gravity, times):
    """Integrate a body on a fixed pivot (Euler's equations about the pivot)."""
    rho_body = np.asarray(rot0).T @ rho0_world
    inertia = parallel_axis(np.asarray(inertia_cg, dtype=float), mass, rho_body)
    inverse = np.linalg.inv(inertia)

    def rhs(_, s):
        rot = s[:9].reshape(3, 3)
        w = s[9:]
        torque = np.cross(rho_body, rot.T @ (mass * np.asarray(gravity)))
        return np.concatenate([(rot @ skew(w)).ravel(),
                               inverse @ (torque - np.cross(w, inertia @ w))])

    sol = solve_ivp(rhs, (times[0], times[-1]), np.concatenate([np.ravel(rot0), rates0_body]),
                    method='DOP853', t_eval=times, rtol=RTOL, atol=ATOL)
    return [s[:9].reshape(3, 3) for s in sol.y.T], [s[9:] for s in sol.y.T], rho_body
