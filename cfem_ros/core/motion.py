# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Kinematic bodies: prescribed trajectories evaluated in the compiled step.

A body with ``motion`` (``model.Motion``) follows its trajectory whatever
the loads; the joints to it use its position, velocity and acceleration.
Its trajectory lives in extra columns of the kernel's ``bodies`` array,
which has them only when the model has a kinematic body (so that the other
models' arrays, and results, are those without this module):

- ``M_KIND``: 0 a body that is not kinematic, 1 constant velocity and body
  rates, 2 a table;
- ``M_T0``: the time of the step's start, s (the kernel's RK4 adds the
  stage's offset);
- ``M_ACC`` (6): the acceleration of the CG and the angular acceleration
  (world axes) at the last time evaluated, which the constraint rows'
  right-hand side uses;
- ``M_REF``: 1 + the index of the body whose frame this body's relative
  pose and twist are sampled in (``sample_relative``), 0 for none;
- from ``M_DATA``: constant motion, p0 (3), v (3, world), q0 (4, x y z w),
  body rates (3): p = p0 + v t, q = q0 exp(w t / 2); a table, the number of
  segments k, the k + 1 breakpoints, then per segment the cubic
  coefficients of the CG position (3 axes x 4, highest power first: scipy
  ``CubicSpline``), the key attitude (4) and the cubic coefficients of the
  rotation vector from it (3 x 4: scipy ``RotationSpline``, C2, whose rates
  are body rates). Beyond the table the end segments' polynomials continue.

``place`` writes the state and accelerations at a time into y and the
columns; the kernel calls it at every RK4 stage and at the step's end.
"""

from __future__ import annotations

import math

from cfem_ros.core import rotations
import numba
import numpy as np

#: No reference counting (``kernel._JIT`` says why).
_JIT = {'cache': True, 'nogil': True, 'fastmath': {'contract'}, 'error_model': 'numpy',
        '_nrt': False}

#: Columns of ``bodies`` the kernel has without kinematic bodies.
BODY_COLUMNS = 20
M_KIND, M_T0, M_ACC, M_REF, M_DATA = 20, 21, 22, 28, 29
KIND_NONE, KIND_CONSTANT, KIND_TABLE = 0, 1, 2
#: Numbers per table segment: position coefficients, key quaternion, rotation vector ones.
SEGMENT = 28


# ------------------------------------------------------------- compiled part

@numba.njit(**_JIT)
def _qmul(ax, ay, az, aw, bx, by, bz, bw):
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


@numba.njit(**_JIT)
def _exp(rx, ry, rz):
    """Return the unit quaternion of the rotation vector (rx, ry, rz), x y z w."""
    angle = np.sqrt(rx * rx + ry * ry + rz * rz)
    if angle < 1e-4:
        s = 0.5 - angle * angle / 48.0
    else:
        s = np.sin(0.5 * angle) / angle
    return rx * s, ry * s, rz * s, np.cos(0.5 * angle)


@numba.njit(**_JIT)
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@numba.njit(**_JIT)
def _constant(bodies, i, t, y, n):
    c = M_DATA
    for k in range(3):
        y[3 * i + k] = bodies[i, c + k] + bodies[i, c + 3 + k] * t
        y[3 * n + 3 * i + k] = bodies[i, c + 3 + k]
        y[10 * n + 3 * i + k] = bodies[i, c + 10 + k]
        bodies[i, M_ACC + k] = 0.0
        bodies[i, M_ACC + 3 + k] = 0.0   # constant body rates: d(R w)/dt = R (w x w) = 0
    e = _exp(bodies[i, c + 10] * t, bodies[i, c + 11] * t, bodies[i, c + 12] * t)
    q = _qmul(bodies[i, c + 6], bodies[i, c + 7], bodies[i, c + 8], bodies[i, c + 9],
              e[0], e[1], e[2], e[3])
    for k in range(4):
        y[6 * n + 4 * i + k] = q[k]


@numba.njit(**_JIT)
def _table(bodies, i, t, y, n):
    count = int(bodies[i, M_DATA])
    first = M_DATA + 1
    seg = 0
    while seg < count - 1 and bodies[i, first + seg + 1] <= t:
        seg += 1
    s = t - bodies[i, first + seg]
    o = first + count + 1 + SEGMENT * seg
    for k in range(3):
        c0, c1, c2, c3 = (bodies[i, o + 4 * k], bodies[i, o + 4 * k + 1],
                          bodies[i, o + 4 * k + 2], bodies[i, o + 4 * k + 3])
        y[3 * i + k] = ((c0 * s + c1) * s + c2) * s + c3
        y[3 * n + 3 * i + k] = (3.0 * c0 * s + 2.0 * c1) * s + c2
        bodies[i, M_ACC + k] = 6.0 * c0 * s + 2.0 * c1
    key = o + 12
    r = _cubic(bodies, i, o + 16, s, 0)
    rd = _cubic(bodies, i, o + 16, s, 1)
    rdd = _cubic(bodies, i, o + 16, s, 2)
    e = _exp(r[0], r[1], r[2])
    q = _qmul(bodies[i, key], bodies[i, key + 1], bodies[i, key + 2], bodies[i, key + 3],
              e[0], e[1], e[2], e[3])
    norm = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for k in range(4):
        y[6 * n + 4 * i + k] = q[k] / norm
    # body rates and their derivative from the rotation vector's (scipy RotationSpline)
    theta = np.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
    if theta > 1e-4:
        k1 = (1.0 - np.cos(theta)) / theta ** 2
        k2 = (theta - np.sin(theta)) / theta ** 3
        n1 = (-theta * np.sin(theta) - 2.0 * (np.cos(theta) - 1.0)) / theta ** 4
        n2 = (-2.0 * theta + 3.0 * np.sin(theta) - theta * np.cos(theta)) / theta ** 5
    else:
        k1 = 0.5 - theta ** 2 / 24.0
        k2 = 1.0 / 6.0 - theta ** 2 / 120.0
        n1 = 1.0 / 12.0 - theta ** 2 / 180.0
        n2 = -1.0 / 60.0 + theta ** 2 / 12604.0
    w = _rate(r, rd, k1, k2)
    linear = _rate(r, rdd, k1, k2)
    dp = r[0] * rd[0] + r[1] * rd[1] + r[2] * rd[2]
    cp = _cross(r[0], r[1], r[2], rd[0], rd[1], rd[2])
    ccp = _cross(r[0], r[1], r[2], cp[0], cp[1], cp[2])
    dccp = _cross(rd[0], rd[1], rd[2], cp[0], cp[1], cp[2])
    for k in range(3):
        y[10 * n + 3 * i + k] = w[k]
    alpha = (linear[0] + dp * (n1 * cp[0] + n2 * ccp[0]) + k2 * dccp[0],
             linear[1] + dp * (n1 * cp[1] + n2 * ccp[1]) + k2 * dccp[1],
             linear[2] + dp * (n1 * cp[2] + n2 * ccp[2]) + k2 * dccp[2])
    # world angular acceleration: R alpha_body (the w x w term is zero)
    x, yy, z, ww = (y[6 * n + 4 * i], y[6 * n + 4 * i + 1], y[6 * n + 4 * i + 2],
                    y[6 * n + 4 * i + 3])
    a0, a1, a2 = alpha[0], alpha[1], alpha[2]
    bodies[i, M_ACC + 3] = ((1 - 2 * (yy * yy + z * z)) * a0 + 2 * (x * yy - ww * z) * a1
                            + 2 * (x * z + ww * yy) * a2)
    bodies[i, M_ACC + 4] = (2 * (x * yy + ww * z) * a0 + (1 - 2 * (x * x + z * z)) * a1
                            + 2 * (yy * z - ww * x) * a2)
    bodies[i, M_ACC + 5] = (2 * (x * z - ww * yy) * a0 + 2 * (yy * z + ww * x) * a1
                            + (1 - 2 * (x * x + yy * yy)) * a2)


@numba.njit(**_JIT)
def _rate(r, rd, k1, k2):
    """Return (I - k1 [r]x + k2 [r]x^2) rd, scipy's rotation-vector rate to angular rate."""
    c = _cross(r[0], r[1], r[2], rd[0], rd[1], rd[2])
    cc = _cross(r[0], r[1], r[2], c[0], c[1], c[2])
    return (rd[0] - k1 * c[0] + k2 * cc[0], rd[1] - k1 * c[1] + k2 * cc[1],
            rd[2] - k1 * c[2] + k2 * cc[2])


@numba.njit(**_JIT)
def _cubic(bodies, i, o, s, order):
    """Return the order-th derivative at s of the three cubics from column o (4 each)."""
    return (_poly(bodies, i, o, s, order), _poly(bodies, i, o + 4, s, order),
            _poly(bodies, i, o + 8, s, order))


@numba.njit(**_JIT)
def _poly(bodies, i, o, s, order):
    c0, c1, c2, c3 = bodies[i, o], bodies[i, o + 1], bodies[i, o + 2], bodies[i, o + 3]
    if order == 0:
        return ((c0 * s + c1) * s + c2) * s + c3
    if order == 1:
        return (3.0 * c0 * s + 2.0 * c1) * s + c2
    return 6.0 * c0 * s + 2.0 * c1


@numba.njit(**_JIT)
def known(jac, r, bodies, a, b):
    """Return row r's J times the known accelerations of its ends (zero for other bodies)."""
    total = 0.0
    for k in range(6):
        total += jac[r, k] * bodies[a, M_ACC + k] + jac[r, 6 + k] * bodies[b, M_ACC + k]
    return total


@numba.njit(**_JIT)
def derivative(bodies, i, rot, dy, n):
    """Put kinematic body i's acceleration (world) and body-axis angular one into dy."""
    for k in range(3):
        dy[3 * n + 3 * i + k] = bodies[i, M_ACC + k]
        dy[10 * n + 3 * i + k] = (rot[i, 0, k] * bodies[i, M_ACC + 3]
                                  + rot[i, 1, k] * bodies[i, M_ACC + 4]
                                  + rot[i, 2, k] * bodies[i, M_ACC + 5])


@numba.njit(**_JIT)
def place(y, bodies, offset):
    """Write each kinematic body's state and accelerations at its step start + offset."""
    n = bodies.shape[0]
    for i in range(n):
        kind = bodies[i, M_KIND]
        if kind == KIND_CONSTANT:
            _constant(bodies, i, bodies[i, M_T0] + offset, y, n)
        elif kind == KIND_TABLE:
            _table(bodies, i, bodies[i, M_T0] + offset, y, n)


@numba.njit(**_JIT)
def sample_relative(y, bodies, out):
    """
    Write each body's pose and twist relative to its reference at the end of out.

    13 numbers a body with a reference (``M_REF``), in body order: the CG
    relative to the reference's CG (3) and the relative attitude (x y z w,
    body to reference) in the reference's axes, then the velocity of the CG
    as seen from the reference and the angular velocity relative to it (3
    + 3, the reference's axes).
    """
    n = bodies.shape[0]
    count = 0
    for i in range(n):
        if bodies[i, M_REF] > 0.0:
            count += 1
    o = out.shape[0] - 13 * count
    for i in range(n):
        c = int(bodies[i, M_REF]) - 1
        if c < 0:
            continue
        qc, qi = 6 * n + 4 * c, 6 * n + 4 * i
        nc = np.sqrt(y[qc] ** 2 + y[qc + 1] ** 2 + y[qc + 2] ** 2 + y[qc + 3] ** 2)
        ni = np.sqrt(y[qi] ** 2 + y[qi + 1] ** 2 + y[qi + 2] ** 2 + y[qi + 3] ** 2)
        x, yy, z, w = y[qc] / nc, y[qc + 1] / nc, y[qc + 2] / nc, y[qc + 3] / nc
        rel = _qmul(-x, -yy, -z, w, y[qi] / ni, y[qi + 1] / ni, y[qi + 2] / ni, y[qi + 3] / ni)
        d = (y[3 * i] - y[3 * c], y[3 * i + 1] - y[3 * c + 1], y[3 * i + 2] - y[3 * c + 2])
        wc = _turn(x, yy, z, w, y[10 * n + 3 * c], y[10 * n + 3 * c + 1],
                   y[10 * n + 3 * c + 2], False)
        xi, yi, zi, wi = y[qi] / ni, y[qi + 1] / ni, y[qi + 2] / ni, y[qi + 3] / ni
        wi_world = _turn(xi, yi, zi, wi, y[10 * n + 3 * i], y[10 * n + 3 * i + 1],
                         y[10 * n + 3 * i + 2], False)
        carried = _cross(wc[0], wc[1], wc[2], d[0], d[1], d[2])
        v = (y[3 * n + 3 * i] - y[3 * n + 3 * c] - carried[0],
             y[3 * n + 3 * i + 1] - y[3 * n + 3 * c + 1] - carried[1],
             y[3 * n + 3 * i + 2] - y[3 * n + 3 * c + 2] - carried[2])
        p = _turn(x, yy, z, w, d[0], d[1], d[2], True)
        v = _turn(x, yy, z, w, v[0], v[1], v[2], True)
        wr = _turn(x, yy, z, w, wi_world[0] - wc[0], wi_world[1] - wc[1],
                   wi_world[2] - wc[2], True)
        for k in range(3):
            out[o + k] = p[k]
            out[o + 7 + k] = v[k]
            out[o + 10 + k] = wr[k]
        for k in range(4):
            out[o + 3 + k] = rel[k]
        o += 13


@numba.njit(**_JIT)
def _turn(x, y, z, w, a0, a1, a2, inverse):
    """Return R a (R^T a if inverse), R the matrix of the unit quaternion (x, y, z, w)."""
    r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
    r10, r11, r12 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
    r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    if inverse:
        return (r00 * a0 + r10 * a1 + r20 * a2, r01 * a0 + r11 * a1 + r21 * a2,
                r02 * a0 + r12 * a1 + r22 * a2)
    return (r00 * a0 + r01 * a1 + r02 * a2, r10 * a0 + r11 * a1 + r12 * a2,
            r20 * a0 + r21 * a1 + r22 * a2)


@numba.njit(**_JIT)
def set_time(bodies, t):
    """Write the time of the step's start into the kinematic bodies' columns."""
    for i in range(bodies.shape[0]):
        bodies[i, M_T0] = t


# ------------------------------------------------------------- Python part

def columns(model) -> np.ndarray:
    """
    Return the extra ``bodies`` columns of a model's kinematic bodies, (n, width).

    Width 0 when the model has none (the kernel then has its own 20 columns).
    """
    motions = [getattr(b, 'motion', None) for b in model.bodies]
    references = dict(getattr(model, 'references', ()))
    if not references and not any(m is not None for m in motions):
        return np.zeros((len(motions), 0))
    packed = [np.zeros(ODOMETRY_WIDTH)]   # room for odometry (``odometry``)
    for i, (body, motion) in enumerate(zip(model.bodies, motions)):
        head = np.zeros(M_DATA - BODY_COLUMNS)
        head[M_REF - BODY_COLUMNS] = references.get(i, -1) + 1
        if motion is None:
            packed.append(head)
            continue
        if len(motion.times):
            head[M_KIND - BODY_COLUMNS] = KIND_TABLE
            data = _table_data(motion)
        else:
            head[M_KIND - BODY_COLUMNS] = KIND_CONSTANT
            data = np.concatenate([body.position, motion.velocity, body.orientation_xyzw,
                                   motion.rates])
        packed.append(np.concatenate([head, data]))
    width = max(len(p) for p in packed)
    packed = packed[1:]
    out = np.zeros((len(packed), width))
    for i, p in enumerate(packed):
        out[i, :len(p)] = p
    return out


def _table_data(motion) -> np.ndarray:
    """Pack a table's C2 splines (scipy, imported here: only tables need it)."""
    from scipy.interpolate import CubicSpline
    from scipy.spatial.transform import Rotation, RotationSpline

    times = np.asarray(motion.times, dtype=float)
    position = CubicSpline(times, motion.positions, axis=0)
    rotations = Rotation.from_quat(motion.quaternions)
    attitude = RotationSpline(times, rotations)
    count = len(times) - 1
    keys = rotations.as_quat()
    segments = np.empty((count, SEGMENT))
    for k in range(count):
        segments[k, :12] = position.c[:, k, :].T.reshape(12)
        segments[k, 12:16] = keys[k]
        segments[k, 16:] = attitude.interpolator.c[:, k, :].T.reshape(12)
    return np.concatenate([[count], times, segments.reshape(-1)])


#: Width of the columns of a body driven by odometry (two segments: see ``odometry``).
ODOMETRY_WIDTH = M_DATA + 1 + 3 + 2 * SEGMENT - BODY_COLUMNS


def odometry(t, position, quaternion, velocity, rates, acceleration, angular_acceleration,
             horizon: float, jerk=(0.0, 0.0, 0.0)) -> np.ndarray:
    """
    Pack a trajectory from one odometry message: the data columns (``M_DATA`` on).

    From time t, the pose (world), the CG velocity (world) and body rates,
    with the acceleration (world), its rate of change ``jerk`` and the body
    angular acceleration (estimated by the caller): a cubic in position for
    ``horizon`` s, then constant velocity and body rates from where that
    leaves the body. The rotation vector from the key attitude is
    w s + alpha s^2 / 2, whose rates at s = 0 are w.
    """
    def segment(p, v, a, q, w, alpha, j=(0.0, 0.0, 0.0)):
        out = np.zeros(SEGMENT)
        for k in range(3):
            out[4 * k:4 * k + 4] = (j[k] / 6.0, 0.5 * a[k], v[k], p[k])
            out[16 + 4 * k:16 + 4 * k + 4] = (0.0, 0.5 * alpha[k], w[k], 0.0)
        out[12:16] = q
        return out

    first = segment(position, velocity, acceleration, quaternion, rates, angular_acceleration,
                    jerk)
    probe = np.zeros((1, M_DATA + 1 + 2 + SEGMENT))
    probe[0, M_KIND] = KIND_TABLE
    probe[0, M_DATA:] = np.concatenate([[1, t, t + horizon], first])
    y = np.zeros(13)
    _table(probe, 0, t + horizon, y, 1)
    second = segment(y[0:3], y[3:6], np.zeros(3), y[6:10], y[10:13], np.zeros(3))
    return np.concatenate([[2, t, t + horizon, t + horizon + 1.0], first, second])


def hermite(t0: float, start, t1: float, end) -> np.ndarray:
    """
    Pack the segment between two odometry messages: the data columns (``M_DATA`` on).

    ``start`` and ``end`` are (position, quaternion x y z w, CG velocity
    (world), body rates). The position is the cubic Hermite polynomial
    through both positions and velocities, per axis (as scipy's
    ``CubicHermiteSpline``); the attitude, the key attitude ``start``'s
    turned by a rotation vector that is the cubic through 0 with rate
    ``start``'s body rates and the rotation to ``end``'s attitude with the
    rate that gives ``end``'s body rates (``_rate`` inverted). So pose and
    twist are those of the messages at both ends, and continuous across
    them. Beyond t1 the polynomials continue (the caller cuts its steps at
    t1).
    """
    h = t1 - t0
    p0, q0, v0, w0 = (np.asarray(v, dtype=float) for v in start)
    p1, q1, v1, w1 = (np.asarray(v, dtype=float) for v in end)
    rel = rotations.multiply(rotations.conjugate(q0[None]), q1[None])[0]
    if rel[3] < 0.0:
        rel = -rel   # the shorter way round
    sine = np.linalg.norm(rel[:3])
    angle = 2.0 * math.atan2(sine, rel[3])
    r1 = rel[:3] * (angle / sine if sine > 0.0 else 2.0)
    r1_rate = np.linalg.solve(_rate_matrix(r1), w1)
    out = np.zeros(SEGMENT)
    for k in range(3):
        out[4 * k:4 * k + 4] = _hermite_cubic(p0[k], v0[k], p1[k], v1[k], h)
        out[16 + 4 * k:16 + 4 * k + 4] = _hermite_cubic(0.0, w0[k], r1[k], r1_rate[k], h)
    out[12:16] = q0
    return np.concatenate([[1, t0, t1], out])


def _hermite_cubic(f0, d0, f1, d1, h):
    """Return the cubic's coefficients, highest power first, with these ends on [0, h]."""
    return ((2.0 * (f0 - f1) + h * (d0 + d1)) / h ** 3,
            (3.0 * (f1 - f0) - h * (2.0 * d0 + d1)) / h ** 2, d0, f0)


def _rate_matrix(r) -> np.ndarray:
    """Return the matrix of ``_rate``: body rates = it @ the rotation vector's rate."""
    theta = float(np.linalg.norm(r))
    if theta > 1e-4:
        k1 = (1.0 - math.cos(theta)) / theta ** 2
        k2 = (theta - math.sin(theta)) / theta ** 3
    else:
        k1 = 0.5 - theta ** 2 / 24.0
        k2 = 1.0 / 6.0 - theta ** 2 / 120.0
    skew = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    return np.eye(3) - k1 * skew + k2 * skew @ skew


def state_at(model, t: float):
    """
    Return the kinematic bodies' states at time t (for checks and tests).

    Returns
    -------
    dict
        Body index -> (position, velocity, quaternion xyzw, body rates,
        acceleration, angular acceleration (world)).

    """
    from cfem_ros.core import kernel
    n = len(model.bodies)
    extra = columns(model)
    if extra.shape[1] == 0:
        return {}
    bodies = np.zeros((n, BODY_COLUMNS + extra.shape[1]))
    bodies[:, BODY_COLUMNS:] = extra
    y = np.zeros(13 * n)
    kernel.motion_place(y, bodies, float(t))
    out = {}
    for i, body in enumerate(model.bodies):
        if getattr(body, 'motion', None) is not None:
            out[i] = (y[3 * i:3 * i + 3].copy(), y[3 * n + 3 * i:3 * n + 3 * i + 3].copy(),
                      y[6 * n + 4 * i:6 * n + 4 * i + 4].copy(),
                      y[10 * n + 3 * i:10 * n + 3 * i + 3].copy(),
                      bodies[i, M_ACC:M_ACC + 3].copy(), bodies[i, M_ACC + 3:M_ACC + 6].copy())
    return out
