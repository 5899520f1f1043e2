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
  rates, 2 a table, 3 a steady manoeuvre (``flight``: the velocity constant
  in body axes, turning with the body);
- ``M_T0``: the time of the step's start, s (the kernel's RK4 adds the
  stage's offset);
- ``M_ACC`` (6): the acceleration of the CG and the angular acceleration
  (world axes) at the last time evaluated, which the constraint rows'
  right-hand side uses;
- ``M_REF``: 1 + the index of the body whose frame this body's relative
  pose and twist are sampled in (``sample_relative``), 0 for none;
- from ``M_DATA``: constant motion, p0 (3), v (3, world), q0 (4, x y z w),
  body rates (3): p = p0 + v t, q = q0 exp(w t / 2); a steady manoeuvre, the
  same numbers with v in body axes: velocity R(t) v, p in closed form; a table, the number of
  segments k, the k + 1 breakpoints, then per segment the cubic
  coefficients of the CG position (3 axes x 4, highest power first: scipy
  ``CubicSpline``), the key attitude (4) and the cubic coefficients of the
  rotation vector from it (3 x 4: scipy ``RotationSpline``, C2, whose rates
  are body rates). Beyond the table the end segments' polynomials continue.

The compiled step evaluates them (``cpp/motion.cpp``; the columns are laid
out in ``cpp/layout.hpp`` and read from the extension, ``kernel.BODIES``):
``kernel.motion_place`` writes the state and accelerations at a time into y
and the columns, at every RK4 stage and at the step's end.
"""

from __future__ import annotations

import math

from cfem_ros.core import rotations
from cfem_ros.core.native import kernel
from cfem_ros.core.native.kernel import BODIES, STATE, TRAJECTORY
import numpy as np

#: The columns (``kernel.BODIES``, laid out in ``cpp/layout.hpp``): those the
#: kernel has without kinematic bodies, the trajectory's, the kinds; numbers
#: per table segment (position coefficients, key quaternion, rotation vector ones).
BODY_COLUMNS, M_KIND, M_T0, M_ACC, M_REF, M_DATA = (
    BODIES.BODY_COLUMNS, BODIES.M_KIND, BODIES.M_T0, BODIES.M_ACC, BODIES.M_REF, BODIES.M_DATA)
KIND_NONE, KIND_CONSTANT, KIND_TABLE, KIND_ARC, SEGMENT = (
    BODIES.KIND_NONE, BODIES.KIND_CONSTANT, BODIES.KIND_TABLE, BODIES.KIND_ARC,
    TRAJECTORY.SEGMENT)


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
        elif getattr(motion, 'velocity_body', None) is not None:
            head[M_KIND - BODY_COLUMNS] = KIND_ARC
            data = _constant(body.position, motion.velocity_body, body.orientation_xyzw,
                             motion.rates)
        else:
            head[M_KIND - BODY_COLUMNS] = KIND_CONSTANT
            data = _constant(body.position, motion.velocity, body.orientation_xyzw,
                             motion.rates)
        packed.append(np.concatenate([head, data]))
    width = max(len(p) for p in packed)
    packed = packed[1:]
    out = np.zeros((len(packed), width))
    for i, p in enumerate(packed):
        out[i, :len(p)] = p
    return out


#: A table's and a segment's columns (``TRAJECTORY``), read once.
_COUNT, _TIMES = TRAJECTORY.D_COUNT, TRAJECTORY.D_TIMES
_POSITION = TRAJECTORY.span('G_POSITION')
_KEY, _ROTATION = TRAJECTORY.span('G_KEY'), TRAJECTORY.span('G_ROTATION')


def _constant(position, velocity, quaternion, rates) -> np.ndarray:
    """Pack constant motion or a steady manoeuvre (``TRAJECTORY``'s constant columns)."""
    out = np.empty(TRAJECTORY.CONSTANT)
    out[TRAJECTORY.span('D_POSITION')] = position
    out[TRAJECTORY.span('D_VELOCITY')] = velocity
    out[TRAJECTORY.span('D_QUATERNION')] = quaternion
    out[TRAJECTORY.span('D_RATES')] = rates
    return out


def _table(times, segments) -> np.ndarray:
    """Pack a table: its segment count, breakpoints and segments (``TRAJECTORY``)."""
    first = _TIMES + len(times)
    out = np.empty(first + SEGMENT * len(segments))
    out[_COUNT] = len(segments)
    out[_TIMES:first] = times
    for k, segment in enumerate(segments):
        out[first + SEGMENT * k:first + SEGMENT * (k + 1)] = segment
    return out


def _segment(key) -> tuple:
    """Return a segment holding the key attitude, and its cubics' views (3 axes x 4 each)."""
    out = np.zeros(SEGMENT)
    out[_KEY] = key
    return out, out[_POSITION].reshape(3, 4), out[_ROTATION].reshape(3, 4)


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
    segments = []
    for k in range(count):
        out, cubic, turn = _segment(keys[k])
        cubic[:] = position.c[:, k, :].T
        turn[:] = attitude.interpolator.c[:, k, :].T
        segments.append(out)
    return _table(times, segments)


#: Width of the columns of a body driven by odometry (two segments: see ``odometry``).
ODOMETRY_WIDTH = M_DATA + TRAJECTORY.D_TIMES + 3 + 2 * SEGMENT - BODY_COLUMNS


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
        out, cubic, turn = _segment(q)
        for k in range(3):   # per axis, highest power first
            cubic[k] = (j[k] / 6.0, 0.5 * a[k], v[k], p[k])
            turn[k] = (0.0, 0.5 * alpha[k], w[k], 0.0)
        return out

    first = segment(position, velocity, acceleration, quaternion, rates, angular_acceleration,
                    jerk)
    table = _table([t, t + horizon], [first])
    probe = np.zeros((1, M_DATA + len(table)))
    probe[0, M_KIND] = KIND_TABLE
    probe[0, M_DATA:] = table
    y = np.zeros(STATE.BODY)   # one body's state
    kernel.motion_place(y, probe, t + horizon)   # M_T0 = 0: the table at t + horizon
    pos, vel, quat, rates = (kernel.state_block(y, 1, name)[0] for name in STATE.columns)
    second = segment(pos, vel, np.zeros(3), quat, rates, np.zeros(3))
    return _table([t, t + horizon, t + horizon + 1.0], [first, second])


def hermite(t0: float, start, t1: float, end) -> np.ndarray:
    """
    Pack the segment between two odometry messages: the data columns (``M_DATA`` on).

    ``start`` and ``end`` are (position, quaternion x y z w, CG velocity
    (world), body rates). The position is the cubic Hermite polynomial
    through both positions and velocities, per axis (as scipy's
    ``CubicHermiteSpline``); the attitude, the key attitude ``start``'s
    turned by a rotation vector that is the cubic through 0 with rate
    ``start``'s body rates and the rotation to ``end``'s attitude with the
    rate that gives ``end``'s body rates (``_rate_matrix`` inverted). So pose and
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
    out, cubic, turn = _segment(q0)
    for k in range(3):
        cubic[k] = _hermite_cubic(p0[k], v0[k], p1[k], v1[k], h)
        turn[k] = _hermite_cubic(0.0, w0[k], r1[k], r1_rate[k], h)
    return _table([t0, t1], [out])


def _hermite_cubic(f0, d0, f1, d1, h):
    """Return the cubic's coefficients, highest power first, with these ends on [0, h]."""
    return ((2.0 * (f0 - f1) + h * (d0 + d1)) / h ** 3,
            (3.0 * (f1 - f0) - h * (2.0 * d0 + d1)) / h ** 2, d0, f0)


def _rate_matrix(r) -> np.ndarray:
    """Return body rates over the rotation vector's rate (``cpp/motion.cpp``'s ``rate``)."""
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
    n = len(model.bodies)
    extra = columns(model)
    if extra.shape[1] == 0:
        return {}
    bodies = np.zeros((n, BODY_COLUMNS + extra.shape[1]))
    bodies[:, BODY_COLUMNS:] = extra
    y = np.zeros(STATE.BODY * n)
    kernel.motion_place(y, bodies, float(t))
    blocks = [kernel.state_block(y, n, name) for name in STATE.columns]
    out = {}
    for i, body in enumerate(model.bodies):
        if getattr(body, 'motion', None) is not None:
            out[i] = (*(block[i].copy() for block in blocks),
                      bodies[i, M_ACC:M_ACC + 3].copy(), bodies[i, M_ACC + 3:M_ACC + 6].copy())
    return out
