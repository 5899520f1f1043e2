# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The compiled hot path: state derivative and RK4 step (numba, cached).

The arrays are laid out by ``engine.Simulator``; this module only computes.

State ``y`` (13 n): positions (3 n, world, m), velocities (3 n, world, m/s),
quaternions (4 n, x y z w, body to world), rates (3 n, body axes, rad/s).

``bodies`` (n, 20): mass, 1/mass (0 for ground), inertia (9, body axes, about
the CG), inverse inertia (9; 0 for ground).
``loads`` (n, 7): external force (3), torque (3), 1.0 if in body axes.
``rows_i`` (m, 2): parent and child body of each row.
``rows_f`` (m, 9): translation rows (the first ``n_t``): axis on the parent,
anchor on the parent, anchor on the child (body axes); rotation rows: vector
on the parent, vector on the child, unused.
"""

from __future__ import annotations

import numba
import numpy as np

_JIT = {'cache': True, 'nogil': True, 'fastmath': False, 'error_model': 'numpy'}


@numba.njit(**_JIT)
def _cross(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@numba.njit(**_JIT)
def _matvec(m, v, out):
    for i in range(3):
        out[i] = m[i, 0] * v[0] + m[i, 1] * v[1] + m[i, 2] * v[2]


@numba.njit(**_JIT)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@numba.njit(**_JIT)
def _quat_matrix(x, y, z, w, out):
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    out[0, 0] = 1 - 2 * (yy + zz)
    out[0, 1] = 2 * (xy - wz)
    out[0, 2] = 2 * (xz + wy)
    out[1, 0] = 2 * (xy + wz)
    out[1, 1] = 1 - 2 * (xx + zz)
    out[1, 2] = 2 * (yz - wx)
    out[2, 0] = 2 * (xz - wy)
    out[2, 1] = 2 * (yz + wx)
    out[2, 2] = 1 - 2 * (xx + yy)


@numba.njit(**_JIT)
def _congruence(rot, body, out):
    """Set out to rot @ body @ rot.T (body given as 9 numbers, row major)."""
    tmp = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            tmp[i, j] = rot[i, 0] * body[j] + rot[i, 1] * body[3 + j] + rot[i, 2] * body[6 + j]
    for i in range(3):
        for j in range(3):
            out[i, j] = tmp[i, 0] * rot[j, 0] + tmp[i, 1] * rot[j, 1] + tmp[i, 2] * rot[j, 2]


@numba.njit(**_JIT)
def _body_terms(y, bodies, gravity, loads, acc, alpha, rot, omega, inv_inertia):
    """Per body: rotation, world rates and inverse inertia, unconstrained accelerations."""
    n = bodies.shape[0]
    inertia = np.empty((3, 3))
    tmp = np.empty(3)
    tmp2 = np.empty(3)
    torque = np.empty(3)
    for i in range(n):
        q = y[6 * n + 4 * i:6 * n + 4 * i + 4]
        norm = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        _quat_matrix(q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm, rot[i])
        _matvec(rot[i], y[10 * n + 3 * i:10 * n + 3 * i + 3], omega[i])
        _congruence(rot[i], bodies[i, 2:11], inertia)
        _congruence(rot[i], bodies[i, 11:20], inv_inertia[i])
        mass, inv_mass = bodies[i, 0], bodies[i, 1]
        if loads[i, 6] > 0.0:
            _matvec(rot[i], loads[i, 0:3], tmp)
        else:
            tmp[:] = loads[i, 0:3]
        for k in range(3):
            acc[i, k] = inv_mass * (mass * gravity[k] + tmp[k])
        if loads[i, 6] > 0.0:
            _matvec(rot[i], loads[i, 3:6], tmp)
        else:
            tmp[:] = loads[i, 3:6]
        _matvec(inertia, omega[i], tmp2)
        _cross(omega[i], tmp2, torque)
        for k in range(3):
            torque[k] = tmp[k] - torque[k]
        _matvec(inv_inertia[i], torque, alpha[i])


@numba.njit(**_JIT)
def _row_terms(y, bodies, rows_i, rows_f, n_t, rot, omega, inv_inertia,
               jac, weighted, rate, gamma, value, directions):
    """Per row: Jacobian blocks J and J M^-1, value g, rate J v, gamma, load direction."""
    n = bodies.shape[0]
    m = rows_i.shape[0]
    jac[:, :] = 0.0
    e = np.empty(3)
    f = np.empty(3)
    c = np.empty(3)
    rho_a = np.empty(3)
    rho_b = np.empty(3)
    d = np.empty(3)
    d_dot = np.empty(3)
    wa_e = np.empty(3)
    t1 = np.empty(3)
    t2 = np.empty(3)
    for r in range(m):
        a, b = rows_i[r, 0], rows_i[r, 1]
        wa, wb = omega[a], omega[b]
        _matvec(rot[a], rows_f[r, 0:3], e)
        if r < n_t:
            _matvec(rot[a], rows_f[r, 3:6], rho_a)
            _matvec(rot[b], rows_f[r, 6:9], rho_b)
            for k in range(3):
                point_b = y[3 * b + k] + rho_b[k]
                d[k] = point_b - y[3 * a + k] - rho_a[k]
                t1[k] = point_b - y[3 * a + k]
            _cross(wb, rho_b, t2)
            for k in range(3):
                d_dot[k] = y[3 * n + 3 * b + k] + t2[k] - y[3 * n + 3 * a + k]
            _cross(wa, rho_a, t2)
            for k in range(3):
                d_dot[k] -= t2[k]
            _cross(wa, e, wa_e)
            _cross(t1, e, t2)
            for k in range(3):
                jac[r, k] = -e[k]
                jac[r, 3 + k] = -t2[k]
                jac[r, 6 + k] = e[k]
            _cross(rho_b, e, t2)
            for k in range(3):
                jac[r, 9 + k] = t2[k]
            value[r] = _dot(d, e)
            rate[r] = _dot(e, d_dot) + _dot(d, wa_e)
            # centripetal terms: wb x (wb x rho_b) - wa x (wa x rho_a)
            _cross(wb, rho_b, t1)
            _cross(wb, t1, t2)
            g = _dot(e, t2)
            _cross(wa, rho_a, t1)
            _cross(wa, t1, t2)
            g -= _dot(e, t2)
            _cross(wa, wa_e, t1)
            gamma[r] = 2.0 * _dot(wa_e, d_dot) + g + _dot(d, t1)
            directions[r, :] = e
        else:
            _matvec(rot[b], rows_f[r, 3:6], f)
            _cross(f, e, c)
            for k in range(3):
                jac[r, 3 + k] = -c[k]
                jac[r, 9 + k] = c[k]
                t1[k] = wb[k] - wa[k]
            value[r] = _dot(e, f)
            rate[r] = _dot(t1, c)
            _cross(wb, f, t2)
            _cross(t2, e, d)
            _cross(wa, e, t2)
            _cross(f, t2, d_dot)
            gamma[r] = _dot(t1, d) + _dot(t1, d_dot)
            directions[r, :] = c
        for side in range(2):
            body = a if side == 0 else b
            base = 6 * side
            for k in range(3):
                weighted[r, base + k] = bodies[body, 1] * jac[r, base + k]
            _matvec(inv_inertia[body], jac[r, base + 3:base + 6], t1)
            for k in range(3):
                weighted[r, base + 3 + k] = t1[k]


@numba.njit(**_JIT)
def solve_state(y, bodies, gravity, loads, rows_i, rows_f, n_t, eta, redundant,
                acc, alpha, rot, lam, directions, value):
    """
    Accelerations (world) and row loads at state y.

    Fills acc (n, 3), alpha (n, 3, world axes), rot (n, 3, 3), and for the m
    rows lam (m,), directions (m, 3, world) and value (m,).
    """
    n = bodies.shape[0]
    m = rows_i.shape[0]
    omega = np.empty((n, 3))
    inv_inertia = np.empty((n, 3, 3))
    _body_terms(y, bodies, gravity, loads, acc, alpha, rot, omega, inv_inertia)
    if m == 0:
        return
    jac = np.empty((m, 12))       # [parent V, parent w, child V, child w]
    weighted = np.empty((m, 12))  # the same rows times M^-1
    rate = np.empty(m)
    gamma = np.empty(m)
    _row_terms(y, bodies, rows_i, rows_f, n_t, rot, omega, inv_inertia,
               jac, weighted, rate, gamma, value, directions)
    rhs = np.empty(m)
    for r in range(m):
        a, b = rows_i[r, 0], rows_i[r, 1]
        free = 0.0
        for k in range(3):
            free += (jac[r, k] * acc[a, k] + jac[r, 3 + k] * alpha[a, k]
                     + jac[r, 6 + k] * acc[b, k] + jac[r, 9 + k] * alpha[b, k])
        rhs[r] = -gamma[r] - 2.0 * eta * rate[r] - eta * eta * value[r] - free
    schur = np.zeros((m, m))
    for r in range(m):
        for s in range(r, m):
            total = 0.0
            for side_r in range(2):
                body_r = rows_i[r, side_r]
                for side_s in range(2):
                    if rows_i[s, side_s] == body_r:
                        for k in range(6):
                            total += weighted[r, 6 * side_r + k] * jac[s, 6 * side_s + k]
            schur[r, s] = total
            schur[s, r] = total
    if redundant:
        lam[:] = np.linalg.lstsq(schur, rhs, 1e-10)[0]
    else:
        lam[:] = np.linalg.solve(schur, rhs)
    for r in range(m):
        a, b = rows_i[r, 0], rows_i[r, 1]
        for k in range(3):
            acc[a, k] += lam[r] * weighted[r, k]
            alpha[a, k] += lam[r] * weighted[r, 3 + k]
            acc[b, k] += lam[r] * weighted[r, 6 + k]
            alpha[b, k] += lam[r] * weighted[r, 9 + k]


@numba.njit(**_JIT)
def derivative(y, dy, bodies, gravity, loads, rows_i, rows_f, n_t, eta, redundant):
    """Fill dy with dy/dt at y; return the largest |constraint value|."""
    n = bodies.shape[0]
    m = rows_i.shape[0]
    acc = np.empty((n, 3))
    alpha = np.empty((n, 3))
    rot = np.empty((n, 3, 3))
    lam = np.empty(m)
    directions = np.empty((m, 3))
    value = np.empty(m)
    solve_state(y, bodies, gravity, loads, rows_i, rows_f, n_t, eta, redundant,
                acc, alpha, rot, lam, directions, value)
    for i in range(n):
        q = y[6 * n + 4 * i:6 * n + 4 * i + 4]
        w = y[10 * n + 3 * i:10 * n + 3 * i + 3]
        for k in range(3):
            dy[3 * i + k] = y[3 * n + 3 * i + k]
            dy[3 * n + 3 * i + k] = acc[i, k]
            # body-axis angular acceleration: R^T alpha_world
            dy[10 * n + 3 * i + k] = (rot[i, 0, k] * alpha[i, 0] + rot[i, 1, k] * alpha[i, 1]
                                      + rot[i, 2, k] * alpha[i, 2])
        o = 6 * n + 4 * i
        # dq/dt = q * (w, 0) / 2, scalar last
        dy[o + 0] = 0.5 * (q[3] * w[0] + q[1] * w[2] - q[2] * w[1])
        dy[o + 1] = 0.5 * (q[3] * w[1] + q[2] * w[0] - q[0] * w[2])
        dy[o + 2] = 0.5 * (q[3] * w[2] + q[0] * w[1] - q[1] * w[0])
        dy[o + 3] = -0.5 * (q[0] * w[0] + q[1] * w[1] + q[2] * w[2])
    worst = 0.0
    for r in range(m):
        worst = max(worst, abs(value[r]))
    return worst


@numba.njit(**_JIT)
def rk4_step(y, h, out, bodies, gravity, loads, rows_i, rows_f, n_t, eta, redundant):
    """
    One classical RK4 step of length h from y into out, quaternions normalized.

    Returns the largest |constraint value| at y (the stages are not states of
    the solution, so their values say nothing about drift).
    """
    size = y.shape[0]
    k1 = np.empty(size)
    k2 = np.empty(size)
    k3 = np.empty(size)
    k4 = np.empty(size)
    stage = np.empty(size)
    worst = derivative(y, k1, bodies, gravity, loads, rows_i, rows_f, n_t, eta, redundant)
    for j in range(size):
        stage[j] = y[j] + 0.5 * h * k1[j]
    derivative(stage, k2, bodies, gravity, loads, rows_i, rows_f,
               n_t, eta, redundant)
    for j in range(size):
        stage[j] = y[j] + 0.5 * h * k2[j]
    derivative(stage, k3, bodies, gravity, loads, rows_i, rows_f,
               n_t, eta, redundant)
    for j in range(size):
        stage[j] = y[j] + h * k3[j]
    derivative(stage, k4, bodies, gravity, loads, rows_i, rows_f,
               n_t, eta, redundant)
    for j in range(size):
        out[j] = y[j] + (h / 6.0) * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
    n = bodies.shape[0]
    for i in range(n):
        o = 6 * n + 4 * i
        norm = np.sqrt(out[o] ** 2 + out[o + 1] ** 2 + out[o + 2] ** 2 + out[o + 3] ** 2)
        for k in range(4):
            out[o + k] /= norm
    return worst


@numba.njit(**_JIT)
def jacobian(y, bodies, rows_i, rows_f, n_t):
    """Row Jacobian blocks J and J M^-1 (m, 12) and values g (m,) at y."""
    n = bodies.shape[0]
    m = rows_i.shape[0]
    rot = np.empty((n, 3, 3))
    omega = np.empty((n, 3))
    inv_inertia = np.empty((n, 3, 3))
    acc = np.empty((n, 3))
    alpha = np.empty((n, 3))
    _body_terms(y, bodies, np.zeros(3), np.zeros((n, 7)), acc, alpha, rot, omega, inv_inertia)
    jac = np.empty((m, 12))
    weighted = np.empty((m, 12))
    rate = np.empty(m)
    gamma = np.empty(m)
    value = np.empty(m)
    directions = np.empty((m, 3))
    _row_terms(y, bodies, rows_i, rows_f, n_t, rot, omega, inv_inertia,
               jac, weighted, rate, gamma, value, directions)
    return jac, weighted, value
