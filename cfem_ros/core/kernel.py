# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The compiled hot path: state derivative, RK4 and the step loop (numba, cached).

The arrays are laid out by ``engine.Simulator``; this module only computes,
and never allocates inside the step loop: every scratch array is carved out
of one workspace (``workspace_size``) made once per set of active joints.

State ``y`` (13 n): positions (3 n, world, m), velocities (3 n, world, m/s),
quaternions (4 n, x y z w, body to world), rates (3 n, body axes, rad/s).

``bodies`` (n, 20): mass, 1/mass (0 for ground), inertia (9, body axes, about
the CG), inverse inertia (9; 0 for ground); with kinematic bodies, more
columns: their trajectories (``motion.py``; the hooks are marked "motion.py").
``loads``: the packed applied loads of ``loads.py`` (per body: force (3),
torque (3), 1.0 if in body axes, application point (3); then the scheduled
wrenches and their tables).
``rows_i`` (m, 3): parent body, child body, 1 for a translation row, 2 for a
translation row at the same joint point as the row before (its terms are
computed once), 0 for a rotation row. Rows come grouped by joint.
``rows_f`` (m, 9): translation rows: axis on the parent, anchor on the
parent, anchor on the child (body axes); rotation rows: vector on the parent,
vector on the child, unused.
``plan`` (J, 7), one line per active joint, leaves of the joint tree first:
first row, translation rows, rotation rows, tree child body, tree parent body,
+1 if the tree child is the joint's child (-1 if it is its parent), model
joint index. ``roots`` (n,): -1 for a fixed body, 0 for a free body held to
its tree parent, 1 for the free root of a tree, 2 for a free body without
joints.

The joint loads are solved in one of two ways (``engine`` says which):

- tree (``dense`` = 0), when the joints form a tree or a forest: the
  articulated recursion of the Lagrange-multiplier system. A joint's rows
  J_c on its tree child c and J_p on its tree parent p satisfy
  J_p = -J_c Phi(r_pc) exactly (Phi shifts a rigid motion from p's CG to
  c's), so eliminating the child's free motions G (null space of J_c) passes
  the child's articulated inertia M^ and force f^ on to the parent:
  M^_p += Phi^T (M^ - M^ G D^-1 G^T M^) Phi and f^_p += Phi^T (I - M^ G D^-1
  G^T) (f^ - M^ s), with D = G^T M^ G and s any acceleration with J_c s =
  the rows' right-hand side. Cost and memory linear in the number of bodies,
  the same accelerations and loads as the dense form to rounding.
- dense (1, or 2 with redundant rows): the Schur complement J M^-1 J^T
  solved as one matrix (least squares when redundant); for closed loops.
"""

from __future__ import annotations

import glob
import hashlib
import os

from cfem_ros.core.aot import COMPILED_SOURCES
import numba
import numpy as np


def _guard_cache():
    """
    Drop the compiled cache of the kernel when any compiled source of the core changed.

    numba keys each cached function on its own file only: the kernel's
    cache would not notice a change in ``loads.py``, whose functions it
    inlines. The sources' digest is kept beside the cache; a different one
    removes the core's cached functions, which are then compiled again.
    """
    here = os.path.dirname(os.path.abspath(__file__))
    cache = os.environ.get('NUMBA_CACHE_DIR') or os.path.join(here, '__pycache__')
    digest = hashlib.sha256()
    for name in COMPILED_SOURCES:
        with open(os.path.join(here, name), 'rb') as source:
            digest.update(source.read())
    stamp = os.path.join(cache, 'cfem_ros_core_sources.sha256')
    try:
        with open(stamp) as kept:
            if kept.read() == digest.hexdigest():
                return
    except OSError:
        pass
    for pattern in ('kernel.*.nb[ic]', 'loads.*.nb[ic]', 'motion.*.nb[ic]'):
        for path in glob.glob(os.path.join(cache, '**', pattern), recursive=True):
            try:
                os.remove(path)
            except OSError:
                pass
    try:
        os.makedirs(cache, exist_ok=True)
        with open(stamp + f'.{os.getpid()}', 'w') as fresh:
            fresh.write(digest.hexdigest())
        os.replace(stamp + f'.{os.getpid()}', stamp)
    except OSError:
        pass   # a read-only install: numba then compiles in memory as it can


_guard_cache()

from cfem_ros.core import loads as applied_loads  # noqa: E402, I100 - after the cache guard
from cfem_ros.core import motion  # noqa: E402, I100 - after the cache guard

#: fastmath only to contract a * b + c into fused multiply-adds (one rounding, not two):
#: about 12 % off a long chain's step, whose elimination is a chain of dependent
#: multiply-adds. No other fast-math flag: non-finite states must still be caught.
#: No reference counting (numba's ``_nrt``) in the step's functions: they only take
#: views of arrays their caller holds, and each view of a counted array costs two atomic
#: operations, which made up about 70 % of a step of a small model (a store on its
#: pylon: 7.6 us a step with them, 1.1 without, the same numbers to the bit). A
#: function that allocates, returns an array or is called from Python counts (``_NRT``).
_JIT = {'cache': True, 'nogil': True, 'fastmath': {'contract'}, 'error_model': 'numpy',
        '_nrt': False}
_NRT = dict(_JIT, _nrt=True)

#: Inlined (numba IR): the two wrappers around the solve, which would otherwise pass
#: the whole workspace (22 arrays) by value on every derivative, and the helpers
#: of the tree elimination's per-joint loop; each has one or two call sites.
_INLINE = dict(_JIT, inline='always')

#: ``advance`` results in ``info[3]`` (LOADS_NOT_FINITE: a sample's outputs or a
#: force-release check's joint loads are not finite while the state is).
REACHED, CONDITION, NOT_FINITE, VIOLATION, SINGULAR, ROWS_FULL = 0, 1, 2, 3, 4, 5
LOADS_NOT_FINITE = 6

#: A pivot of the solve (a Cholesky pivot, a 2x2 or 3x3 determinant over the
#: product of its diagonal, a hinge's D over its diagonal terms) at
#: or below this fraction of its scale has lost all but about three of its 16
#: digits to cancellation: the solve is ill-conditioned and reported as singular.
#: (A hinge's D = g^T M^ g is measured against sum M^_ii g_i^2.)
PIVOT_RTOL = 1e-12

#: Columns of ``plan``.
P_ROW, P_NT, P_NR, P_CHILD, P_PARENT, P_SIGN, P_JOINT = range(7)


# ------------------------------------------------------------ small algebra

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


@numba.njit(**_INLINE)
def _quat_matrix(x, y, z, w, out):
    """Rotation matrix of the quaternion (x, y, z, w) of any non-zero norm, into out."""
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    s = 2.0 / (xx + yy + zz + w * w)   # 2 / |q|^2: no square root, one division
    out[0, 0] = 1 - s * (yy + zz)
    out[0, 1] = s * (xy - wz)
    out[0, 2] = s * (xz + wy)
    out[1, 0] = s * (xy + wz)
    out[1, 1] = 1 - s * (xx + zz)
    out[1, 2] = s * (yz - wx)
    out[2, 0] = s * (xz - wy)
    out[2, 1] = s * (yz + wx)
    out[2, 2] = 1 - s * (xx + yy)


@numba.njit(**_JIT)
def _normalize(v):
    norm = np.sqrt(_dot(v, v))
    scale = 1.0 / norm
    for k in range(3):
        v[k] *= scale
    return norm


@numba.njit(**_INLINE)
def _complement(vectors, first, count, stride_sign, base, out):
    """
    Fill out[0:3 - count] with unit vectors spanning what is orthogonal to some rows.

    The rows are ``stride_sign * vectors[first + i, base:base + 3]`` for i < count.
    """
    if count == 0:
        for i in range(3):
            for k in range(3):
                out[i, k] = 1.0 if i == k else 0.0
    elif count == 1:
        v0 = vectors[first, base] * stride_sign
        v1 = vectors[first, base + 1] * stride_sign
        v2 = vectors[first, base + 2] * stride_sign
        # the world axis least aligned with v, crossed with v
        a0, a1, a2 = abs(v0), abs(v1), abs(v2)
        if a0 <= a1 and a0 <= a2:
            out[0, 0], out[0, 1], out[0, 2] = 0.0, v2, -v1
        elif a1 <= a2:
            out[0, 0], out[0, 1], out[0, 2] = -v2, 0.0, v0
        else:
            out[0, 0], out[0, 1], out[0, 2] = v1, -v0, 0.0
        _normalize(out[0])
        out[1, 0] = v1 * out[0, 2] - v2 * out[0, 1]
        out[1, 1] = v2 * out[0, 0] - v0 * out[0, 2]
        out[1, 2] = v0 * out[0, 1] - v1 * out[0, 0]
        _normalize(out[1])
    elif count == 2:
        _cross(vectors[first, base:base + 3], vectors[first + 1, base:base + 3], out[0])
        _normalize(out[0])


@numba.njit(**_JIT)
def _cholesky(a, k, out):
    """Lower Cholesky factor of a[:k, :k] into out; False if not positive definite."""
    for i in range(k):
        for j in range(i + 1):
            total = a[i, j]
            for s in range(j):
                total -= out[i, s] * out[j, s]
            if i == j:
                if not total > PIVOT_RTOL * a[i, i]:
                    return False
                out[i, i] = np.sqrt(total)
            else:
                out[i, j] = total / out[j, j]
    return True


@numba.njit(**_JIT)
def _cholesky_solve(chol, k, x):
    """Solve (L L^T) x = b in place for the first k entries of x."""
    for i in range(k):
        total = x[i]
        for s in range(i):
            total -= chol[i, s] * x[s]
        x[i] = total / chol[i, i]
    for i in range(k - 1, -1, -1):
        total = x[i]
        for s in range(i + 1, k):
            total -= chol[s, i] * x[s]
        x[i] = total / chol[i, i]


@numba.njit(**_INLINE)
def _inverse(a, k, out):
    """Inverse of the symmetric a[:k, :k] (k <= 3, lower part used) into out; False if singular."""
    if k == 0:
        return True
    if k == 1:
        if not a[0, 0] > 0.0:
            return False
        out[0, 0] = 1.0 / a[0, 0]
        return True
    if k == 2:
        det = a[0, 0] * a[1, 1] - a[1, 0] * a[1, 0]
        if not det > (PIVOT_RTOL * a[0, 0]) * a[1, 1]:
            return False
        scale = 1.0 / det
        out[0, 0] = a[1, 1] * scale
        out[1, 1] = a[0, 0] * scale
        out[0, 1] = out[1, 0] = -a[1, 0] * scale
        return True
    c00 = a[1, 1] * a[2, 2] - a[2, 1] * a[2, 1]
    c01 = a[2, 1] * a[2, 0] - a[1, 0] * a[2, 2]
    c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    det = a[0, 0] * c00 + a[1, 0] * c01 + a[2, 0] * c02
    if not det > ((PIVOT_RTOL * a[0, 0]) * a[1, 1]) * a[2, 2]:
        return False
    scale = 1.0 / det
    out[0, 0] = c00 * scale
    out[0, 1] = out[1, 0] = c01 * scale
    out[0, 2] = out[2, 0] = c02 * scale
    out[1, 1] = (a[0, 0] * a[2, 2] - a[2, 0] * a[2, 0]) * scale
    out[1, 2] = out[2, 1] = (a[1, 0] * a[2, 0] - a[0, 0] * a[2, 1]) * scale
    out[2, 2] = (a[0, 0] * a[1, 1] - a[1, 0] * a[1, 0]) * scale
    return True


# ---------------------------------------------------------------- workspace

@numba.njit(**_NRT)
def workspace_size(n, m, nj):
    """Length of the float workspace for n bodies, m rows and nj joints."""
    return (n * (9 + 3 + 9 + 36 + 6 + 6) + m * (12 + 12 + 4) + nj * (18 + 18 + 9 + 3 + 6 + 6)
            + 6 * 13 * n + 4 * 36 + 4 * 9 + 8 * 3)


@numba.njit(**_NRT)
def carve(work, n, m, nj):
    """
    Cut the workspace into views (see ``workspace_size``), once per call from Python.

    0 rot, 1 omega, 2 inv_inertia, 3 mhat, 4 fhat, 5 acc, 6 jac, 7 weighted,
    8 rate, 9 gamma, 10 value, 11 rhs, 12 basis, 13 weighted_basis, 14 chol,
    15 projected, 16 particular, 17 wrench, 18 stages, 19 six (4, 6, 6),
    20 three (4, 3, 3), 21 vec (8, 3), 22 the first two rows of vec as one (6,).
    """
    o = 0
    rot = work[o:o + 9 * n].reshape((n, 3, 3))
    o += 9 * n
    omega = work[o:o + 3 * n].reshape((n, 3))
    o += 3 * n
    inv_inertia = work[o:o + 9 * n].reshape((n, 3, 3))
    o += 9 * n
    mhat = work[o:o + 36 * n].reshape((n, 6, 6))
    o += 36 * n
    fhat = work[o:o + 6 * n].reshape((n, 6))
    o += 6 * n
    acc = work[o:o + 6 * n].reshape((n, 6))
    o += 6 * n
    jac = work[o:o + 12 * m].reshape((m, 12))
    o += 12 * m
    weighted = work[o:o + 12 * m].reshape((m, 12))
    o += 12 * m
    rate = work[o:o + m]
    o += m
    gamma = work[o:o + m]
    o += m
    value = work[o:o + m]
    o += m
    rhs = work[o:o + m]
    o += m
    basis = work[o:o + 18 * nj].reshape((nj, 6, 3))
    o += 18 * nj
    weighted_basis = work[o:o + 18 * nj].reshape((nj, 6, 3))
    o += 18 * nj
    chol = work[o:o + 9 * nj].reshape((nj, 3, 3))
    o += 9 * nj
    projected = work[o:o + 3 * nj].reshape((nj, 3))
    o += 3 * nj
    particular = work[o:o + 6 * nj].reshape((nj, 6))
    o += 6 * nj
    wrench = work[o:o + 6 * nj].reshape((nj, 6))
    o += 6 * nj
    stages = work[o:o + 6 * 13 * n].reshape((6, 13 * n))
    o += 6 * 13 * n
    six = work[o:o + 4 * 36].reshape((4, 6, 6))
    o += 4 * 36
    three = work[o:o + 4 * 9].reshape((4, 3, 3))
    o += 4 * 9
    vec = work[o:o + 8 * 3].reshape((8, 3))
    return (rot, omega, inv_inertia, mhat, fhat, acc, jac, weighted, rate, gamma, value, rhs,
            basis, weighted_basis, chol, projected, particular, wrench, stages, six, three, vec,
            work[o:o + 6])


# --------------------------------------------------------------- the system

@numba.njit(**_JIT)
def _rotate(rot, i, x, y, z):
    """rot[i] @ (x, y, z) as a tuple."""
    return (rot[i, 0, 0] * x + rot[i, 0, 1] * y + rot[i, 0, 2] * z,
            rot[i, 1, 0] * x + rot[i, 1, 1] * y + rot[i, 1, 2] * z,
            rot[i, 2, 0] * x + rot[i, 2, 1] * y + rot[i, 2, 2] * z)


@numba.njit(**_JIT)
def _x(a, b):
    """Cross product of two 3-tuples."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@numba.njit(**_JIT)
def _d(a, b):
    """Dot product of two 3-tuples."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@numba.njit(**_INLINE)
def _body_congruence(rot, i, src, col, out, row0):
    """Set out[row0:row0+3, row0:row0+3] to rot[i] @ B @ rot[i].T, B = src[i, col:col+9]."""
    for r in range(3):
        t0 = rot[i, r, 0] * src[i, col] + rot[i, r, 1] * src[i, col + 3] \
            + rot[i, r, 2] * src[i, col + 6]
        t1 = rot[i, r, 0] * src[i, col + 1] + rot[i, r, 1] * src[i, col + 4] \
            + rot[i, r, 2] * src[i, col + 7]
        t2 = rot[i, r, 0] * src[i, col + 2] + rot[i, r, 1] * src[i, col + 5] \
            + rot[i, r, 2] * src[i, col + 8]
        for c in range(3):
            out[row0 + r, row0 + c] = t0 * rot[i, c, 0] + t1 * rot[i, c, 1] + t2 * rot[i, c, 2]


@numba.njit(**_JIT)
def _body_terms(y, bodies, gravity, loads, v, need_inverse):
    """Per body: rotation, world rates, mass matrix, free load and inverse inertia (world)."""
    rot, omega, inv_inertia, mhat, fhat = v[0], v[1], v[2], v[3], v[4]
    n = bodies.shape[0]
    for i in range(n):
        o = 6 * n + 4 * i
        _quat_matrix(y[o], y[o + 1], y[o + 2], y[o + 3], rot[i])
        o = 10 * n + 3 * i
        w = _rotate(rot, i, y[o], y[o + 1], y[o + 2])
        omega[i, 0], omega[i, 1], omega[i, 2] = w
        if bodies[i, 1] == 0.0:
            # fixed or kinematic: its rows need its rotation and rates only (its mass
            # terms, never written, stay the workspace's zeros; its load is reset for
            # the scheduled wrenches, which may act on it)
            for k in range(6):
                fhat[i, k] = 0.0
            continue
        if need_inverse:
            _body_congruence(rot, i, bodies, 11, inv_inertia[i], 0)
        mh = mhat[i]
        mh[:, :] = 0.0
        mass = bodies[i, 0]
        mh[0, 0] = mh[1, 1] = mh[2, 2] = mass
        _body_congruence(rot, i, bodies, 2, mh, 3)
        force = (loads[i, 0], loads[i, 1], loads[i, 2])
        torque = (loads[i, 3], loads[i, 4], loads[i, 5])
        if loads[i, 6] > 0.0:
            force = _rotate(rot, i, force[0], force[1], force[2])
            torque = _rotate(rot, i, torque[0], torque[1], torque[2])
        torque = applied_loads.held_moment(rot, i, loads, force, torque)   # loads at points
        spin = (mh[3, 3] * w[0] + mh[3, 4] * w[1] + mh[3, 5] * w[2],
                mh[4, 3] * w[0] + mh[4, 4] * w[1] + mh[4, 5] * w[2],
                mh[5, 3] * w[0] + mh[5, 4] * w[1] + mh[5, 5] * w[2])
        gyro = _x(w, spin)
        for k in range(3):
            fhat[i, k] = mass * gravity[k] + force[k]
            fhat[i, 3 + k] = torque[k] - gyro[k]
    if loads.shape[0] > n:   # scheduled wrenches (loads.py)
        applied_loads.add_scheduled(y, rot, bodies, loads, fhat)


@numba.njit(**_JIT)
def _row_terms(y, bodies, rows_i, rows_f, eta, v, dense):
    """Per row: Jacobian blocks J (and J M^-1 if dense), value g, right-hand side."""
    rot, omega, inv_inertia = v[0], v[1], v[2]
    jac, weighted, rate, gamma, value, rhs = v[6], v[7], v[8], v[9], v[10], v[11]
    n = bodies.shape[0]
    m = rows_i.shape[0]
    zero = (0.0, 0.0, 0.0)
    rho_b, t1, d, d_dot, centripetal = zero, zero, zero, zero, zero
    for r in range(m):
        a, b = rows_i[r, 0], rows_i[r, 1]
        wa = (omega[a, 0], omega[a, 1], omega[a, 2])
        wb = (omega[b, 0], omega[b, 1], omega[b, 2])
        e = _rotate(rot, a, rows_f[r, 0], rows_f[r, 1], rows_f[r, 2])
        if rows_i[r, 2]:
            if rows_i[r, 2] == 1:
                # the joint point's terms, shared by a joint's translation rows
                rho_a = _rotate(rot, a, rows_f[r, 3], rows_f[r, 4], rows_f[r, 5])
                rho_b = _rotate(rot, b, rows_f[r, 6], rows_f[r, 7], rows_f[r, 8])
                pa = (y[3 * a], y[3 * a + 1], y[3 * a + 2])
                t1 = (y[3 * b] + rho_b[0] - pa[0], y[3 * b + 1] + rho_b[1] - pa[1],
                      y[3 * b + 2] + rho_b[2] - pa[2])
                d = (t1[0] - rho_a[0], t1[1] - rho_a[1], t1[2] - rho_a[2])
                vb = _x(wb, rho_b)
                va = _x(wa, rho_a)
                o = 3 * n
                d_dot = (y[o + 3 * b] + vb[0] - y[o + 3 * a] - va[0],
                         y[o + 3 * b + 1] + vb[1] - y[o + 3 * a + 1] - va[1],
                         y[o + 3 * b + 2] + vb[2] - y[o + 3 * a + 2] - va[2])
                cb, ca = _x(wb, vb), _x(wa, va)
                centripetal = (cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2])
            wa_e = _x(wa, e)
            t1e = _x(t1, e)
            rbe = _x(rho_b, e)
            for k in range(3):
                jac[r, k] = -e[k]
                jac[r, 3 + k] = -t1e[k]
                jac[r, 6 + k] = e[k]
                jac[r, 9 + k] = rbe[k]
            value[r] = _d(d, e)
            rate[r] = _d(e, d_dot) + _d(d, wa_e)
            # centripetal terms: wb x (wb x rho_b) - wa x (wa x rho_a)
            gamma[r] = 2.0 * _d(wa_e, d_dot) + _d(e, centripetal) + _d(d, _x(wa, wa_e))
        else:
            f = _rotate(rot, b, rows_f[r, 3], rows_f[r, 4], rows_f[r, 5])
            c = _x(f, e)
            rel = (wb[0] - wa[0], wb[1] - wa[1], wb[2] - wa[2])
            for k in range(3):
                jac[r, k] = 0.0
                jac[r, 3 + k] = -c[k]
                jac[r, 6 + k] = 0.0
                jac[r, 9 + k] = c[k]
            value[r] = _d(e, f)
            rate[r] = _d(rel, c)
            gamma[r] = _d(rel, _x(_x(wb, f), e)) + _d(rel, _x(f, _x(wa, e)))
        rhs[r] = -gamma[r] - 2.0 * eta * rate[r] - eta * eta * value[r]
        if bodies.shape[1] > motion.BODY_COLUMNS:   # kinematic ends' known acceleration
            rhs[r] -= motion.known(jac, r, bodies, a, b)   # (motion.py)
        if dense:
            for side in range(2):
                body = a if side == 0 else b
                base = 6 * side
                for k in range(3):
                    weighted[r, base + k] = bodies[body, 1] * jac[r, base + k]
                for k in range(3):
                    weighted[r, base + 3 + k] = (
                        inv_inertia[body, k, 0] * jac[r, base + 3]
                        + inv_inertia[body, k, 1] * jac[r, base + 4]
                        + inv_inertia[body, k, 2] * jac[r, base + 5])


@numba.njit(**_JIT)
def _tree_solve(y, plan, roots, rows_f, v):
    """
    Accelerations of a joint forest (the module docstring); False if singular.

    mhat and fhat hold each body's own mass matrix and load on entry and
    are overwritten by the articulated ones. acc (n, 6) gets (linear,
    angular) accelerations in world axes.
    """
    rot, mhat, fhat, acc, jac, rhs = v[0], v[3], v[4], v[5], v[6], v[11]
    basis, weighted_basis, chol, projected, particular = v[12], v[13], v[14], v[15], v[16]
    scratch, x, full = v[19][0], v[19][1], v[19][2]
    free_t, free_r, gram = v[20][0], v[20][1], v[20][2]
    vec, t1 = v[22], v[21][2]
    n_j = plan.shape[0]
    n = roots.shape[0]
    # leaves first: pass each child's articulated inertia on to its parent
    for j in range(n_j):
        r0, nt, nr = plan[j, P_ROW], plan[j, P_NT], plan[j, P_NR]
        c, p, sign = plan[j, P_CHILD], plan[j, P_PARENT], float(plan[j, P_SIGN])
        off = 6 if sign > 0 else 0
        # the joint point on the joint's child, relative to the tree child's CG
        b = c if sign > 0 else p
        rho = _rotate(rot, b, rows_f[r0, 6], rows_f[r0, 7], rows_f[r0, 8])
        rho = (rho[0] + y[3 * b] - y[3 * c], rho[1] + y[3 * b + 1] - y[3 * c + 1],
               rho[2] + y[3 * b + 2] - y[3 * c + 2])
        mh = mhat[c]
        u = weighted_basis[j]
        g = basis[j]
        s = particular[j]
        if nt == 3 and nr == 2:
            # a hinge: its free motion and particular acceleration in straight-line code
            _hinge_motion(jac, rhs, r0, off, rho, g, s)
            if not _eliminate_one(mh, fhat[c], g, s, u, vec, x, chol[j], projected[j]):
                return False
            if roots[p] >= 0:
                _shift_add(x, vec, y, c, p, mhat[p], fhat[p])
            continue
        # free motions G of the tree child: translations off the rows, rotations
        # off the rows with the joint point carried along
        _complement(jac, r0, nt, sign, off, free_t)
        _complement(jac, r0 + nt, nr, sign, off + 3, free_r)
        k_t, k_r = 3 - nt, 3 - nr
        for col in range(k_t):
            for k in range(3):
                g[k, col] = free_t[col, k]
                g[3 + k, col] = 0.0
        for col in range(k_r):
            w = (free_r[col, 0], free_r[col, 1], free_r[col, 2])
            rw = _x(rho, w)
            for k in range(3):
                g[k, k_t + col] = rw[k]
                g[3 + k, k_t + col] = w[k]
        k_free = k_t + k_r
        # a particular acceleration s with J_c s = rhs: rotation by least norm,
        # translation along the (orthonormal) row axes
        for k in range(6):
            s[k] = 0.0
        if nr > 0:
            for i in range(nr):
                vec[i] = rhs[r0 + nt + i]
                for i2 in range(i + 1):
                    total = 0.0
                    for k in range(3):
                        total += jac[r0 + nt + i, off + 3 + k] * jac[r0 + nt + i2, off + 3 + k]
                    scratch[i, i2] = total
            if not _inverse(scratch, nr, gram):
                return False
            for i in range(nr):
                total = 0.0
                for i2 in range(nr):
                    total += gram[i, i2] * vec[i2]
                for k in range(3):
                    s[3 + k] += total * jac[r0 + nt + i, off + 3 + k]
        ws = _x((s[3], s[4], s[5]), rho)
        for i in range(nt):
            for k in range(3):
                s[k] += rhs[r0 + i] * jac[r0 + i, off + k]
        for k in range(3):
            s[k] -= ws[k]
        if k_free == 1:
            # one free motion (hinge, slider): the same algebra, straight-line
            if not _eliminate_one(mh, fhat[c], g, s, u, vec, x, chol[j], projected[j]):
                return False
            if roots[p] >= 0:
                _shift_add(x, vec, y, c, p, mhat[p], fhat[p])
            continue
        # U = M^ G, D = G^T M^ G, q = G^T (f^ - M^ s)
        for col in range(k_free):
            for row in range(6):
                total = 0.0
                for k in range(6):
                    total += mh[row, k] * g[k, col]
                u[row, col] = total
        for row in range(6):
            total = fhat[c, row]
            for k in range(6):
                total -= mh[row, k] * s[k]
            vec[row] = total
        for col in range(k_free):
            total = 0.0
            for k in range(6):
                total += g[k, col] * vec[k]
            projected[j, col] = total
            for col2 in range(col + 1):
                total = 0.0
                for k in range(6):
                    total += g[k, col] * u[k, col2]
                scratch[col, col2] = total
        d_inv = chol[j]
        if not _inverse(scratch, k_free, d_inv):
            return False
        if roots[p] < 0:
            continue
        # what the parent feels: M^' = M^ - V U^T and z' = z - V q, V = U D^-1
        for row in range(6):
            for i in range(k_free):
                total = 0.0
                for k in range(k_free):
                    total += u[row, k] * d_inv[k, i]
                scratch[i, row] = total
        for row in range(6):
            total = 0.0
            for i in range(k_free):
                total += scratch[i, row] * projected[j, i]
            vec[row] -= total
        for i in range(6):
            for k in range(i, 6):
                total = mh[i, k]
                for q in range(k_free):
                    total -= scratch[q, i] * u[k, q]
                x[i, k] = total
                x[k, i] = total
        _shift_add(x, vec, y, c, p, mhat[p], fhat[p])
    # roots: a = M^-1 f
    for i in range(n):
        if roots[i] != 1:
            continue
        for k in range(6):
            acc[i, k] = fhat[i, k]
        if not _cholesky(mhat[i], 6, full):
            return False
        _cholesky_solve(full, 6, acc[i])
    # root first: each child's acceleration from its parent's
    for j in range(n_j - 1, -1, -1):
        c, p = plan[j, P_CHILD], plan[j, P_PARENT]
        k_free = 6 - plan[j, P_NT] - plan[j, P_NR]
        g, u, s = basis[j], weighted_basis[j], particular[j]
        if roots[p] >= 0:
            # Phi a_p: the parent's acceleration carried to the child's CG
            r = (y[3 * c] - y[3 * p], y[3 * c + 1] - y[3 * p + 1], y[3 * c + 2] - y[3 * p + 2])
            ar = _x((acc[p, 3], acc[p, 4], acc[p, 5]), r)
            for k in range(3):
                acc[c, k] = acc[p, k] + ar[k]
                acc[c, 3 + k] = acc[p, 3 + k]
        else:
            for k in range(6):
                acc[c, k] = 0.0
        for col in range(k_free):
            total = projected[j, col]
            for k in range(6):
                total -= u[k, col] * acc[c, k]
            t1[col] = total
        d_inv = chol[j]
        for col in range(k_free):
            total = 0.0
            for k in range(k_free):
                total += d_inv[col, k] * t1[k]
            vec[col] = total
        for k in range(6):
            total = acc[c, k] + s[k]
            for col in range(k_free):
                total += g[k, col] * vec[col]
            acc[c, k] = total
    return True


@numba.njit(**_INLINE)
def _hinge_motion(jac, rhs, r0, off, rho, g, s):
    """
    Set a hinge's free motion g (6, column 0) and least-norm particular acceleration s.

    Rows r0..r0+2 fix the joint point, r0+3 and r0+4 two directions; their
    blocks on the tree child start at column off. The free rotation is
    w = c1 x c2 / |c1 x c2| (c1, c2 the rotation rows' angular blocks), and
    the rotation part of s, orthogonal to w with c_i . s = rhs_i, is
    (rhs_1 c2 x n + rhs_2 n x c1) / |n|^2 with n = c1 x c2.
    """
    c1 = (jac[r0 + 3, off + 3], jac[r0 + 3, off + 4], jac[r0 + 3, off + 5])
    c2 = (jac[r0 + 4, off + 3], jac[r0 + 4, off + 4], jac[r0 + 4, off + 5])
    n = _x(c1, c2)
    nn = _d(n, n)
    scale = 1.0 / np.sqrt(nn)
    w = (n[0] * scale, n[1] * scale, n[2] * scale)
    rw = _x(rho, w)
    a, b = _x(c2, n), _x(n, c1)
    h1, h2 = rhs[r0 + 3] / nn, rhs[r0 + 4] / nn
    rot = (h1 * a[0] + h2 * b[0], h1 * a[1] + h2 * b[1], h1 * a[2] + h2 * b[2])
    ws = _x(rot, rho)
    for k in range(3):
        g[k, 0] = rw[k]
        g[3 + k, 0] = w[k]
        s[k] = (rhs[r0] * jac[r0, off + k] + rhs[r0 + 1] * jac[r0 + 1, off + k]
                + rhs[r0 + 2] * jac[r0 + 2, off + k]) - ws[k]
        s[3 + k] = rot[k]


@numba.njit(**_INLINE)
def _eliminate_one(mh, f, g, s, u, z, x, d_inv, projected):
    """
    Eliminate one free motion g (6, column 0) of a body with articulated M^ = mh, f^ = f.

    u = M^ g, D = g^T u, q = g^T z with z = f - M^ s; then what the parent
    feels before the shift: x = M^ - u u^T / D and z - u q / D. False if D is not
    above ``PIVOT_RTOL`` times sum M^_ii g_i^2 (singular or ill-conditioned).
    """
    g0, g1, g2, g3, g4, g5 = g[0, 0], g[1, 0], g[2, 0], g[3, 0], g[4, 0], g[5, 0]
    s0, s1, s2, s3, s4, s5 = s[0], s[1], s[2], s[3], s[4], s[5]
    total_d = 0.0
    total_q = 0.0
    for i in range(6):
        ui = (mh[i, 0] * g0 + mh[i, 1] * g1 + mh[i, 2] * g2 + mh[i, 3] * g3 + mh[i, 4] * g4
              + mh[i, 5] * g5)
        zi = f[i] - (mh[i, 0] * s0 + mh[i, 1] * s1 + mh[i, 2] * s2 + mh[i, 3] * s3
                     + mh[i, 4] * s4 + mh[i, 5] * s5)
        u[i, 0] = ui
        z[i] = zi
        total_d += g[i, 0] * ui
        total_q += g[i, 0] * zi
    # the scale: D without the off-diagonal terms of M^ (products of their own, so
    # that the sums above are compiled as before, to the bit)
    scale_d = (mh[0, 0] * (g0 * g0) + mh[1, 1] * (g1 * g1) + mh[2, 2] * (g2 * g2)
               + mh[3, 3] * (g3 * g3) + mh[4, 4] * (g4 * g4) + mh[5, 5] * (g5 * g5))
    if not total_d > PIVOT_RTOL * scale_d:
        return False
    inv = 1.0 / total_d
    d_inv[0, 0] = inv
    projected[0] = total_q
    a = total_q * inv
    for i in range(6):
        vi = u[i, 0] * inv
        z[i] -= u[i, 0] * a
        for k in range(i, 6):
            x[i, k] = x[k, i] = mh[i, k] - vi * u[k, 0]
    return True


@numba.njit(**_INLINE)
def _shift_add(x, z, y, c, p, mhat_p, fhat_p):
    """Add Phi^T x Phi to mhat_p and Phi^T z to fhat_p (x symmetric, Phi from c to p)."""
    r0, r1, r2 = y[3 * c] - y[3 * p], y[3 * c + 1] - y[3 * p + 1], y[3 * c + 2] - y[3 * p + 2]
    # x = [[A, B], [B^T, C]], S = [r]x: Phi^T x Phi = [[A, B'], [B'^T, C']] with
    # B' = B - A S and C' = C + S B' + (S B)^T; read once into registers
    a00, a01, a02, a11, a12, a22 = x[0, 0], x[0, 1], x[0, 2], x[1, 1], x[1, 2], x[2, 2]
    b00, b01, b02 = x[0, 3], x[0, 4], x[0, 5]
    b10, b11, b12 = x[1, 3], x[1, 4], x[1, 5]
    b20, b21, b22 = x[2, 3], x[2, 4], x[2, 5]
    c00, c01, c02, c11, c12, c22 = x[3, 3], x[3, 4], x[3, 5], x[4, 4], x[4, 5], x[5, 5]
    # B' = B - A S with S = [[0, -r2, r1], [r2, 0, -r0], [-r1, r0, 0]]
    p00 = b00 - (a01 * r2 - a02 * r1)
    p01 = b01 - (a02 * r0 - a00 * r2)
    p02 = b02 - (a00 * r1 - a01 * r0)
    p10 = b10 - (a11 * r2 - a12 * r1)
    p11 = b11 - (a12 * r0 - a01 * r2)
    p12 = b12 - (a01 * r1 - a11 * r0)
    p20 = b20 - (a12 * r2 - a22 * r1)
    p21 = b21 - (a22 * r0 - a02 * r2)
    p22 = b22 - (a02 * r1 - a12 * r0)
    # (S M)_ij = (r x M[:, j])_i for a 3x3 M; C' = C + S B' + (S B)^T
    # S B': column j is r x (p0j, p1j, p2j); S B: column j is r x (b0j, b1j, b2j)
    q00, q10, q20 = r1 * p20 - r2 * p10, r2 * p00 - r0 * p20, r0 * p10 - r1 * p00
    q01, q11, q21 = r1 * p21 - r2 * p11, r2 * p01 - r0 * p21, r0 * p11 - r1 * p01
    q02, q12, q22 = r1 * p22 - r2 * p12, r2 * p02 - r0 * p22, r0 * p12 - r1 * p02
    t00, t10, t20 = r1 * b20 - r2 * b10, r2 * b00 - r0 * b20, r0 * b10 - r1 * b00
    t01, t11, t21 = r1 * b21 - r2 * b11, r2 * b01 - r0 * b21, r0 * b11 - r1 * b01
    t02, t12, t22 = r1 * b22 - r2 * b12, r2 * b02 - r0 * b22, r0 * b12 - r1 * b02
    # C'_ij = C_ij + q_ij + t_ji
    mhat_p[3, 3] += c00 + q00 + t00
    mhat_p[3, 4] += c01 + q01 + t10
    mhat_p[3, 5] += c02 + q02 + t20
    mhat_p[4, 3] += c01 + q10 + t01
    mhat_p[4, 4] += c11 + q11 + t11
    mhat_p[4, 5] += c12 + q12 + t21
    mhat_p[5, 3] += c02 + q20 + t02
    mhat_p[5, 4] += c12 + q21 + t12
    mhat_p[5, 5] += c22 + q22 + t22
    mhat_p[0, 0] += a00
    mhat_p[0, 1] += a01
    mhat_p[0, 2] += a02
    mhat_p[1, 0] += a01
    mhat_p[1, 1] += a11
    mhat_p[1, 2] += a12
    mhat_p[2, 0] += a02
    mhat_p[2, 1] += a12
    mhat_p[2, 2] += a22
    mhat_p[0, 3] += p00
    mhat_p[0, 4] += p01
    mhat_p[0, 5] += p02
    mhat_p[1, 3] += p10
    mhat_p[1, 4] += p11
    mhat_p[1, 5] += p12
    mhat_p[2, 3] += p20
    mhat_p[2, 4] += p21
    mhat_p[2, 5] += p22
    mhat_p[3, 0] += p00
    mhat_p[4, 0] += p01
    mhat_p[5, 0] += p02
    mhat_p[3, 1] += p10
    mhat_p[4, 1] += p11
    mhat_p[5, 1] += p12
    mhat_p[3, 2] += p20
    mhat_p[4, 2] += p21
    mhat_p[5, 2] += p22
    z0, z1, z2, z3, z4, z5 = z[0], z[1], z[2], z[3], z[4], z[5]
    fhat_p[0] += z0
    fhat_p[1] += z1
    fhat_p[2] += z2
    fhat_p[3] += z3 + r1 * z2 - r2 * z1
    fhat_p[4] += z4 + r2 * z0 - r0 * z2
    fhat_p[5] += z5 + r0 * z1 - r1 * z0


@numba.njit(**_NRT)
def _dense_solve(bodies, rows_i, plan, v, redundant):
    """Accelerations and joint loads from the whole Schur complement (closed loops)."""
    inv_inertia, fhat, acc, jac, weighted, rhs, wrench = v[2], v[4], v[5], v[6], v[7], v[11], \
        v[17]
    n = bodies.shape[0]
    m = rows_i.shape[0]
    for i in range(n):
        for k in range(3):
            acc[i, k] = bodies[i, 1] * fhat[i, k]
            acc[i, 3 + k] = (inv_inertia[i, k, 0] * fhat[i, 3] + inv_inertia[i, k, 1] * fhat[i, 4]
                             + inv_inertia[i, k, 2] * fhat[i, 5])
    if m == 0:
        return
    right = np.empty(m)
    for r in range(m):
        a, b = rows_i[r, 0], rows_i[r, 1]
        free = 0.0
        for k in range(6):
            free += jac[r, k] * acc[a, k] + jac[r, 6 + k] * acc[b, k]
        right[r] = rhs[r] - free
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
        lam = np.linalg.lstsq(schur, right, 1e-10)[0]
    else:
        lam = np.linalg.solve(schur, right)
    for r in range(m):
        a, b = rows_i[r, 0], rows_i[r, 1]
        for k in range(6):
            acc[a, k] += lam[r] * weighted[r, k]
            acc[b, k] += lam[r] * weighted[r, 6 + k]
    # each joint's load on its tree child, as the tree solve reports it
    for j in range(plan.shape[0]):
        off = 6 if plan[j, P_SIGN] > 0 else 0
        for k in range(6):
            wrench[j, k] = 0.0
        for r in range(plan[j, P_ROW], plan[j, P_ROW] + plan[j, P_NT] + plan[j, P_NR]):
            for k in range(6):
                wrench[j, k] += lam[r] * jac[r, off + k]


@numba.njit(**_INLINE)
def _solve(y, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, v):
    """Accelerations (``acc`` of the views) and joint loads at y; False if singular."""
    _body_terms(y, bodies, gravity, loads, v, dense > 0)
    _row_terms(y, bodies, rows_i, rows_f, eta, v, dense > 0)
    if dense > 0:
        _dense_solve(bodies, rows_i, plan, v, dense > 1)
        return True
    acc, fhat, inv_inertia = v[5], v[4], v[2]
    for i in range(bodies.shape[0]):
        if roots[i] == 2:   # a free body on its own: a = M^-1 f directly
            _body_congruence(v[0], i, bodies, 11, inv_inertia[i], 0)
            for k in range(3):
                acc[i, k] = bodies[i, 1] * fhat[i, k]
                acc[i, 3 + k] = (inv_inertia[i, k, 0] * fhat[i, 3]
                                 + inv_inertia[i, k, 1] * fhat[i, 4]
                                 + inv_inertia[i, k, 2] * fhat[i, 5])
    return _tree_solve(y, plan, roots, rows_f, v)


@numba.njit(**_JIT)
def _joint_loads(y, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, v,
                 force, moment):
    if not _solve(y, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, v):
        return False
    rot, mhat, fhat, acc, wrench = v[0], v[3], v[4], v[5], v[17]
    for j in range(plan.shape[0]):
        c, sign = plan[j, P_CHILD], float(plan[j, P_SIGN])
        b = c if sign > 0 else plan[j, P_PARENT]
        if dense == 0:
            # the tree child's balance: load = M^ a - f^ (articulated)
            for k in range(6):
                total = -fhat[c, k]
                for i in range(6):
                    total += mhat[c, k, i] * acc[c, i]
                wrench[j, k] = total
        r0 = plan[j, P_ROW]
        rho = _rotate(rot, b, rows_f[r0, 6], rows_f[r0, 7], rows_f[r0, 8])
        rho = (rho[0] + y[3 * b] - y[3 * c], rho[1] + y[3 * b + 1] - y[3 * c + 1],
               rho[2] + y[3 * b + 2] - y[3 * c + 2])
        f = (sign * wrench[j, 0], sign * wrench[j, 1], sign * wrench[j, 2])
        arm = _x(rho, f)
        for k in range(3):
            force[j, k] = f[k]
            moment[j, k] = sign * wrench[j, 3 + k] - arm[k]
    return True


@numba.njit(**_NRT)
def joint_loads(y, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, work,
                force, moment):
    """
    Each active joint's load on its child at y; False if the system is singular.

    force, moment (J, 3): world axes, N and N m about the joint point, in
    ``plan`` order. Also leaves the constraint values in the workspace.
    """
    v = carve(work, bodies.shape[0], rows_i.shape[0], plan.shape[0])
    return _joint_loads(y, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, v,
                        force, moment)


@numba.njit(**_NRT)
def sample_outputs(y, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, work,
                   order, out):
    """
    Write what a sample publishes at y into out; return 0, SINGULAR or LOADS_NOT_FINITE.

    Per body 13 numbers: CG position, quaternion (x y z w, as in y), CG
    velocity in body axes, angular velocity (body axes); then per plan line
    in ``order`` 6: the joint's force and moment on its child (world axes,
    N and N m about the joint point); then 6 per applied load source
    (``loads.sample_applied``); then 13 per body with a reference frame
    (``motion.sample_relative``).
    """
    v = carve(work, bodies.shape[0], rows_i.shape[0], plan.shape[0])
    force = np.empty((plan.shape[0], 3))
    moment = np.empty((plan.shape[0], 3))
    return _sample_outputs(y, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense,
                           v, order, out, force, moment)


@numba.njit(**_JIT)
def _sample_outputs(y, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, v,
                    order, out, force, moment):
    n = bodies.shape[0]
    for i in range(n):
        o, q = 13 * i, 6 * n + 4 * i
        norm = np.sqrt(y[q] ** 2 + y[q + 1] ** 2 + y[q + 2] ** 2 + y[q + 3] ** 2)
        x, yy, z, w = y[q] / norm, y[q + 1] / norm, y[q + 2] / norm, y[q + 3] / norm
        # R^T v with R the body-to-world matrix of the unit quaternion
        v0, v1, v2 = y[3 * n + 3 * i], y[3 * n + 3 * i + 1], y[3 * n + 3 * i + 2]
        for k in range(3):
            out[o + k] = y[3 * i + k]
            out[o + 10 + k] = y[10 * n + 3 * i + k]
        for k in range(4):
            out[o + 3 + k] = y[q + k]
        out[o + 7] = ((1 - 2 * (yy * yy + z * z)) * v0 + 2 * (x * yy + w * z) * v1
                      + 2 * (x * z - w * yy) * v2)
        out[o + 8] = (2 * (x * yy - w * z) * v0 + (1 - 2 * (x * x + z * z)) * v1
                      + 2 * (yy * z + w * x) * v2)
        out[o + 9] = (2 * (x * z + w * yy) * v0 + 2 * (yy * z - w * x) * v1
                      + (1 - 2 * (x * x + yy * yy)) * v2)
    if loads.shape[0] > n:   # the scheduled wrenches' applied loads, after the joints' (loads.py)
        applied_loads.sample_applied(y, bodies, loads, out[13 * n + 6 * order.shape[0]:])
    if bodies.shape[1] > motion.BODY_COLUMNS:   # poses relative to a carrier, last (motion.py)
        motion.sample_relative(y, bodies, out)
    if order.shape[0] == 0:
        return REACHED
    if not _joint_loads(y, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, v,
                        force, moment):
        return SINGULAR
    for j in range(order.shape[0]):
        o = 13 * n + 6 * j
        for k in range(3):
            out[o + k] = force[order[j], k]
            out[o + 3 + k] = moment[order[j], k]
    # the state is finite (every step checks it); its loads may still not be
    for j in range(13 * n, 13 * n + 6 * order.shape[0]):
        if not np.isfinite(out[j]):
            return LOADS_NOT_FINITE
    return REACHED


@numba.njit(**_NRT)
def row_jacobian(y, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, work):
    """Fill the workspace's J and J M^-1 blocks at y (``carve`` items 6 and 7)."""
    v = carve(work, bodies.shape[0], rows_i.shape[0], plan.shape[0])
    _body_terms(y, bodies, gravity, loads, v, True)
    _row_terms(y, bodies, rows_i, rows_f, eta, v, True)


@numba.njit(**_NRT)
def project(y, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, work, delta):
    """
    Find the mass-weighted velocity correction that satisfies the joints at y.

    delta (n, 6): (linear, angular) world axes, the least M-norm change
    with J (v + delta) = 0; solved like the accelerations, with no loads.
    """
    n, m = bodies.shape[0], rows_i.shape[0]
    v = carve(work, n, m, plan.shape[0])
    omega, fhat, acc, jac, rhs = v[1], v[4], v[5], v[6], v[11]
    _body_terms(y, bodies, gravity, loads, v, True)
    _row_terms(y, bodies, rows_i, rows_f, eta, v, dense > 0)
    fhat[:, :] = 0.0
    for r in range(m):
        a, b = rows_i[r, 0], rows_i[r, 1]
        total = 0.0
        for k in range(3):
            total += (jac[r, k] * y[3 * n + 3 * a + k] + jac[r, 3 + k] * omega[a, k]
                      + jac[r, 6 + k] * y[3 * n + 3 * b + k] + jac[r, 9 + k] * omega[b, k])
        rhs[r] = -total
    if dense > 0:
        _dense_solve(bodies, rows_i, plan, v, True)
    else:
        acc[:, :] = 0.0
        if not _tree_solve(y, plan, roots, rows_f, v):
            return False
    delta[:, :] = acc
    return True


@numba.njit(**_NRT)
def constraint_values(work, n, m, n_j):
    """Return the constraint values of the last solve (a view of the workspace)."""
    return carve(work, n, m, n_j)[10]


@numba.njit(**_INLINE)
def _derivative(y, dy, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, v,
                solved):
    # solved: the workspace already holds the solve at y (with these loads)
    n = bodies.shape[0]
    if not solved and not _solve(y, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta,
                                 dense, v):
        return -1.0
    rot, acc, value = v[0], v[5], v[10]
    for i in range(n):
        o = 6 * n + 4 * i
        w = (y[10 * n + 3 * i], y[10 * n + 3 * i + 1], y[10 * n + 3 * i + 2])
        for k in range(3):
            dy[3 * i + k] = y[3 * n + 3 * i + k]
            dy[3 * n + 3 * i + k] = acc[i, k]
            # body-axis angular acceleration: R^T alpha_world
            dy[10 * n + 3 * i + k] = (rot[i, 0, k] * acc[i, 3] + rot[i, 1, k] * acc[i, 4]
                                      + rot[i, 2, k] * acc[i, 5])
        if bodies.shape[1] > motion.BODY_COLUMNS and bodies[i, motion.M_KIND] > 0.0:
            motion.derivative(bodies, i, rot, dy, n)   # a kinematic body's own (motion.py)
        # dq/dt = q * (w, 0) / 2, scalar last
        dy[o + 0] = 0.5 * (y[o + 3] * w[0] + y[o + 1] * w[2] - y[o + 2] * w[1])
        dy[o + 1] = 0.5 * (y[o + 3] * w[1] + y[o + 2] * w[0] - y[o + 0] * w[2])
        dy[o + 2] = 0.5 * (y[o + 3] * w[2] + y[o + 0] * w[1] - y[o + 1] * w[0])
        dy[o + 3] = -0.5 * (y[o + 0] * w[0] + y[o + 1] * w[1] + y[o + 2] * w[2])
    worst = 0.0
    for r in range(rows_i.shape[0]):
        worst = max(worst, abs(value[r]))
    return worst


@numba.njit(**_NRT)
def derivative(y, dy, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, work):
    """Fill dy with dy/dt at y; return the largest |constraint value| (-1 if singular)."""
    v = carve(work, bodies.shape[0], rows_i.shape[0], plan.shape[0])
    return _derivative(y, dy, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense,
                       v, False)


@numba.njit(**_JIT)
def _rk4(y, h, out, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, v,
         solved):
    size = y.shape[0]
    stages = v[18]
    stage = stages[4]
    worst = 0.0
    for s in range(4):
        if loads.shape[0] > bodies.shape[0]:   # stage time of scheduled wrenches (loads.py)
            applied_loads.stage_time(loads, bodies.shape[0], 0.0 if s == 0 else (
                0.5 * h if s < 3 else h))
        if bodies.shape[1] > motion.BODY_COLUMNS:   # kinematic bodies at the stage time
            motion.place(y if s == 0 else stage, bodies, 0.0 if s == 0 else (
                0.5 * h if s < 3 else h))   # (motion.py)
        # one call site: the derivative is inlined once
        w = _derivative(y if s == 0 else stage, stages[s], bodies, gravity, loads, rows_i,
                        rows_f, plan, roots, eta, dense, v, solved and s == 0)
        if w < 0.0:
            return -1.0
        if s == 0:
            worst = w
        if s < 3:
            c = 0.5 * h if s < 2 else h
            ks = stages[s]
            for j in range(size):
                stage[j] = y[j] + c * ks[j]
    k1, k2, k3, k4 = stages[0], stages[1], stages[2], stages[3]
    for j in range(size):
        out[j] = y[j] + (h / 6.0) * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
    n = bodies.shape[0]
    for i in range(n):
        o = 6 * n + 4 * i
        scale = 1.0 / np.sqrt(out[o] ** 2 + out[o + 1] ** 2 + out[o + 2] ** 2 + out[o + 3] ** 2)
        for k in range(4):
            out[o + k] *= scale
    if bodies.shape[1] > motion.BODY_COLUMNS:   # kinematic bodies at the step's end
        motion.place(out, bodies, h)   # (motion.py)
    return worst


@numba.njit(**_NRT)
def rk4_step(y, h, out, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense,
             work):
    """
    One classical RK4 step of length h from y into out, quaternions normalized.

    Returns the largest |constraint value| at y (the stages are not states of
    the solution, so their values say nothing about drift), -1 if singular.
    """
    v = carve(work, bodies.shape[0], rows_i.shape[0], plan.shape[0])
    return _rk4(y, h, out, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, v,
                False)


# ------------------------------------------------------------ release tests

@numba.njit(**_NRT)
def conditions(y, joints_i, joints_f, watch, out):
    """
    Angle (rad) and distance (m) of the watched joints at y, into out[:, 0:2].

    joints_i (n_joints, 2): parent, child; joints_f (n_joints, 10): anchor on
    the parent, anchor on the child (body axes), relative attitude at t = 0
    (x y z w). watch: model joint indices.
    """
    _conditions(y, joints_i, joints_f, watch, out, np.empty((3, 3)), np.empty(3), np.empty(3))


@numba.njit(**_JIT)
def _conditions(y, joints_i, joints_f, watch, out, rot, pa, pb):
    """``conditions`` with its scratch (rot (3, 3), pa, pb (3,)) given."""
    n = y.shape[0] // 13
    for w in range(watch.shape[0]):
        k = watch[w]
        a, b = joints_i[k, 0], joints_i[k, 1]
        qa = y[6 * n + 4 * a:6 * n + 4 * a + 4]
        qb = y[6 * n + 4 * b:6 * n + 4 * b + 4]
        na = np.sqrt(_dot4(qa, qa))
        nb = np.sqrt(_dot4(qb, qb))
        # relative = conj(q0) * conj(qa) * qb, angle = 2 atan2(|v|, |w|)
        rx, ry, rz, rw = _qmul(-qa[0] / na, -qa[1] / na, -qa[2] / na, qa[3] / na,
                               qb[0] / nb, qb[1] / nb, qb[2] / nb, qb[3] / nb)
        q0 = joints_f[k, 6:10]
        rx, ry, rz, rw = _qmul(-q0[0], -q0[1], -q0[2], q0[3], rx, ry, rz, rw)
        out[w, 0] = 2.0 * np.arctan2(np.sqrt(rx * rx + ry * ry + rz * rz), abs(rw))
        _quat_matrix(qa[0], qa[1], qa[2], qa[3], rot)
        _matvec(rot, joints_f[k, 0:3], pa)
        _quat_matrix(qb[0], qb[1], qb[2], qb[3], rot)
        _matvec(rot, joints_f[k, 3:6], pb)
        total = 0.0
        for i in range(3):
            gap = y[3 * b + i] + pb[i] - y[3 * a + i] - pa[i]
            total += gap * gap
        out[w, 1] = np.sqrt(total)


@numba.njit(**_JIT)
def _dot4(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]


@numba.njit(**_JIT)
def _qmul(ax, ay, az, aw, bx, by, bz, bw):
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


# --------------------------------------------------------------- step loop

@numba.njit(**_NRT)
def advance(y, info, t_target, due, limit, dt, bodies, gravity, loads, rows_i, rows_f, plan,
            roots, eta, dense, work, joints_i, joints_f, watch, limits, watch_plan, grid, order,
            samples):
    """
    Take RK4 steps of dt toward t_target, as ``Simulator.advance_to`` defines them.

    info = [t, steps, largest violation, result, violation limit]: t, y and
    the violation are updated after every step, so they hold the last good
    step whatever happens. Stops on
    reaching t_target or the release time ``due``, before a step that would
    end after ``limit``, before a step in which a watched condition (angle,
    distance, force at ``limits``; inf for none) is reached (CONDITION: the
    caller locates the crossing), or on a failure (NOT_FINITE, VIOLATION,
    SINGULAR, LOADS_NOT_FINITE: a sample's joint loads, or those a force
    condition is checked on, are not finite).

    grid = [rate (Hz; 0 for none), index k of the next sample, samples
    taken]: steps are also cut at the sample times k / rate, and at each
    the sample's outputs (``sample_outputs``, joints in ``order``) go to
    the next row of ``samples`` (none if it has 0 columns: the samples are
    only counted); a sample due at the current time is taken first. Stops
    with ROWS_FULL when a sample is due and every row is taken. A sample
    at ``due`` is taken before the call returns for the release (a release
    at t takes effect after the samples at t).
    """
    size = y.shape[0]
    v = carve(work, bodies.shape[0], rows_i.shape[0], plan.shape[0])
    out = v[18][5]
    values = np.empty((watch.shape[0], 2))
    rot, pa, pb = np.empty((3, 3)), np.empty(3), np.empty(3)
    force = np.empty((plan.shape[0], 3))
    moment = np.empty((plan.shape[0], 3))
    need_force = False
    for w in range(watch.shape[0]):
        if limits[w, 2] < np.inf:
            need_force = True
    t = info[0]
    info[3] = REACHED
    rate = grid[0]
    # the workspace holds the solve at y (a sample's or a force check's joint
    # loads): the next step's first stage uses it instead of solving again
    fresh = False
    while True:
        goal = t_target
        if rate > 0.0:
            at = grid[1] / rate
            if t >= at:
                taken = int(grid[2])
                if taken == samples.shape[0]:
                    info[3] = ROWS_FULL
                    return
                if samples.shape[1] > 0:
                    code = _sample_outputs(y, bodies, gravity, loads, rows_i, rows_f, plan,
                                           roots, eta, dense, v, order, samples[taken], force,
                                           moment)
                    if code != REACHED:
                        info[3] = code
                        return
                    if order.shape[0] > 0:
                        # a sample never shows a state beyond the tolerance (the steps
                        # check the state they start from, so a sample's would come late)
                        value = v[10]
                        worst = 0.0
                        for r in range(value.shape[0]):
                            worst = max(worst, abs(value[r]))
                        if worst > info[4]:
                            info[3] = VIOLATION
                            info[5] = worst
                            return
                fresh = samples.shape[1] > 0 and order.shape[0] > 0
                grid[1] += 1.0
                grid[2] += 1.0
                continue
            goal = min(goal, at)
        if t >= due:
            return   # a release is due now, after the samples at t: the caller releases
        if t >= t_target:
            return
        while t < goal:
            remaining = goal - t
            if remaining <= dt * (1.0 + 1e-9):
                h, t_end = remaining, goal
            else:
                h, t_end = dt, t + dt
            if due < t_end:
                h, t_end = due - t, due
            if t_end > limit:
                return
            worst = _rk4(y, h, out, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta,
                         dense, v, fresh)
            fresh = False
            if worst < 0.0:
                info[3] = SINGULAR
                return
            if watch.shape[0] > 0:
                _conditions(out, joints_i, joints_f, watch, values, rot, pa, pb)
                if need_force and not _joint_loads(out, bodies, gravity, loads, rows_i, rows_f,
                                                   plan, roots, eta, dense, v, force, moment):
                    info[3] = SINGULAR
                    return
                for w in range(watch.shape[0]):
                    magnitude = 0.0
                    if need_force:
                        magnitude = np.sqrt(_dot(force[watch_plan[w]], force[watch_plan[w]]))
                        if not np.isfinite(magnitude):
                            info[3] = LOADS_NOT_FINITE
                            return
                    if (values[w, 0] >= limits[w, 0] or values[w, 1] >= limits[w, 1]
                            or magnitude >= limits[w, 2]):
                        info[3] = CONDITION
                        return
            if loads.shape[0] > bodies.shape[0] and applied_loads.stroke_reached(
                    out, loads, bodies.shape[0]):   # an ejector's stroke ends (loads.py)
                info[3] = CONDITION
                return
            for j in range(size):
                if not np.isfinite(out[j]):
                    info[3] = NOT_FINITE
                    return
            if worst > info[4]:
                info[3] = VIOLATION
                info[5] = worst
                return
            info[2] = max(info[2], worst)
            for j in range(size):
                y[j] = out[j]
            fresh = need_force
            t = t_end
            info[0] = t
            if loads.shape[0] > bodies.shape[0]:
                applied_loads.set_time(loads, bodies.shape[0], t)   # loads.py
            if bodies.shape[1] > motion.BODY_COLUMNS:
                motion.set_time(bodies, t)   # motion.py
            info[1] += 1
            if t_end >= due:
                break   # the samples at t first (loop top), then back for the release


# ------------------------------------------------ crossings located in a step
# engine.Simulator._step: where in a step a release condition or an ejector's stroke
# end is first reached, on the step's RK4 map s -> rk4(y0, s), found by Brent's method
# as roots.brentq computes it (scipy's), operation for operation. Compiled without
# contraction into fused multiply-adds, so that the root finder, the excesses and the
# force magnitudes round as the Python (releases.py, loads.py) does: the same bits.
# The RK4, conditions and joint loads it calls are the step's own (contracted) code.

#: ``locate`` codes in ``info[1]`` besides REACHED, SINGULAR and LOADS_NOT_FINITE:
#: a condition's value is NaN, the step's ends do not bracket it, no convergence
#: (the errors of ``roots.brentq``).
NAN_VALUE, SAME_SIGNS, NO_CONVERGENCE = 7, 8, 9

#: Brent's tolerances for a crossing (as releases.py and loads.py use roots.brentq).
CROSSING_XTOL, CROSSING_RTOL, CROSSING_MAXITER = 1e-15, 4 * np.finfo(np.float64).eps, 200

_EXACT = dict(_JIT, fastmath=False)
_EXACT_NRT = dict(_NRT, fastmath=False)


@numba.njit(**_EXACT)
def _release_values(y, first, count, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta,
                    dense, v, joints_i, joints_f, watch, triggers, watch_plan, values, rot, pa,
                    pb, force, moment):
    """
    Angle, distance and force of the watched joints first .. first + count at y, into values.

    As ``Releases.values``: the force (its magnitude, summed left to right as numpy's
    norm does) only if one of them has a force condition, else 0. Returns REACHED,
    SINGULAR or LOADS_NOT_FINITE (any joint's load not finite).
    """
    _conditions(y, joints_i, joints_f, watch[first:first + count],
                values[first:first + count], rot, pa, pb)
    need = False
    for w in range(first, first + count):
        values[w, 2] = 0.0
        if np.isfinite(triggers[w, 2]):
            need = True
    if not need:
        return REACHED
    if not _joint_loads(y, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, v,
                        force, moment):
        return SINGULAR
    for j in range(plan.shape[0]):
        for k in range(3):
            if not (np.isfinite(force[j, k]) and np.isfinite(moment[j, k])):
                return LOADS_NOT_FINITE
    for w in range(first, first + count):
        f = force[watch_plan[w]]
        values[w, 2] = np.sqrt((f[0] * f[0] + f[1] * f[1]) + f[2] * f[2])
    return REACHED


@numba.njit(**_EXACT)
def _excess(s, y0, ys, which, col, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta,
            dense, v, joints_i, joints_f, watch, triggers, watch_plan, values, rot, pa, pb,
            force, moment, info):
    """
    Return (excess, code) of a condition at rk4(y0, s) (y0 at s = 0) over its limit.

    col 0-2: watched joint ``which``'s angle, distance or force; col 3: scheduled
    row ``which``'s stroke. Each RK4 raises the largest stage violation info[0].
    """
    state = y0
    if s != 0.0:
        worst = _rk4(y0, s, ys, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta,
                     dense, v, False)
        if worst < 0.0:
            return np.nan, SINGULAR
        if worst > info[0]:
            info[0] = worst
        state = ys
    if col == 3:
        n = bodies.shape[0]
        return (applied_loads._point_and_stroke(state, loads, which, n)[3]
                - loads[which, applied_loads.S_STROKE]), REACHED
    code = _release_values(state, which, 1, bodies, gravity, loads, rows_i, rows_f, plan, roots,
                           eta, dense, v, joints_i, joints_f, watch, triggers, watch_plan,
                           values, rot, pa, pb, force, moment)
    if code != REACHED:
        return np.nan, code
    return values[which, col] - triggers[which, col], REACHED


@numba.njit(**_EXACT)
def _brentq(h, y0, ys, which, col, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta,
            dense, v, joints_i, joints_f, watch, triggers, watch_plan, values, rot, pa, pb,
            force, moment, info):
    """
    Return (s, code): the root in [0, h] of ``_excess``, as ``roots.brentq`` finds it.

    Its iteration operation for operation (scipy's brentq.c), with the crossing's
    tolerances; code NAN_VALUE, SAME_SIGNS or NO_CONVERGENCE for its errors (s the
    abscissa it names), or a failure of the excess.
    """
    xtol, rtol = CROSSING_XTOL, CROSSING_RTOL
    xpre, xcur = 0.0, h
    xblk = fblk = spre = scur = 0.0
    fpre, code = _excess(xpre, y0, ys, which, col, bodies, gravity, loads, rows_i, rows_f, plan,
                         roots, eta, dense, v, joints_i, joints_f, watch, triggers, watch_plan,
                         values, rot, pa, pb, force, moment, info)
    if code != REACHED:
        return xpre, code
    if np.isnan(fpre):
        return xpre, NAN_VALUE
    fcur, code = _excess(xcur, y0, ys, which, col, bodies, gravity, loads, rows_i, rows_f, plan,
                         roots, eta, dense, v, joints_i, joints_f, watch, triggers, watch_plan,
                         values, rot, pa, pb, force, moment, info)
    if code != REACHED:
        return xcur, code
    if np.isnan(fcur):
        return xcur, NAN_VALUE
    if fpre * fcur > 0:
        return xcur, SAME_SIGNS
    if fpre == 0:
        return xpre, REACHED
    if fcur == 0:
        return xcur, REACHED
    for _ in range(CROSSING_MAXITER):
        if fpre * fcur < 0:
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0 or abs(sbis) < delta:
            return xcur, REACHED
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:
                stry = -fcur * (xcur - xpre) / (fcur - fpre)          # interpolate
            else:
                dpre = (fpre - fcur) / (xpre - xcur)                  # extrapolate
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            bound = abs(spre)   # Python's min(abs(spre), 3 |sbis| - delta)
            if 3 * abs(sbis) - delta < bound:
                bound = 3 * abs(sbis) - delta
            if 2 * abs(stry) < bound:
                spre, scur = scur, stry                               # good short step
            else:
                spre = scur = sbis                                    # bisect
        else:
            spre = scur = sbis                                        # bisect
        xpre, fpre = xcur, fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0 else -delta
        fcur, code = _excess(xcur, y0, ys, which, col, bodies, gravity, loads, rows_i, rows_f,
                             plan, roots, eta, dense, v, joints_i, joints_f, watch, triggers,
                             watch_plan, values, rot, pa, pb, force, moment, info)
        if code != REACHED:
            return xcur, code
        if np.isnan(fcur):
            return xcur, NAN_VALUE
    return xcur, NO_CONVERGENCE


@numba.njit(**_EXACT_NRT)
def locate(y0, h, y1, ys, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, work,
           joints_i, joints_f, watch, triggers, watch_plan, joints_found, wrenches_found, info):
    """
    Take an RK4 step of h from y0 into y1 and find where in it a condition is first reached.

    As ``Releases.crossing`` then ``ScheduledLoads.crossing`` (their Python is the
    reference): the watched joints (``watch``, model indices; ``triggers`` their
    angle, distance and force limits, NaN for none; ``watch_plan`` their plan
    lines) and the scheduled wrenches that are on with a stroke, reached at y1,
    are located on s -> rk4(y0, s): the earliest s in (0, h] (0 if reached at
    y0), and all reached within 1e-15 s of it. Then ys = rk4(y0, s) at the s the
    step is cut at (the stroke end's unless a release comes first) if s < h.

    info: [largest stage violation (in and out), code (REACHED or a failure:
    SINGULAR, LOADS_NOT_FINITE, NAN_VALUE, SAME_SIGNS, NO_CONVERGENCE), the s of
    a failure, release s (NaN: none), number of joints released, stroke end s
    (NaN: none), number of wrenches ended]. joints_found (len(watch), 2): joint,
    cause (0 angle, 1 distance, 2 force); wrenches_found: wrench indices.
    """
    n = bodies.shape[0]
    v = carve(work, n, rows_i.shape[0], plan.shape[0])
    values = np.zeros((watch.shape[0], 3))
    rot, pa, pb = np.empty((3, 3)), np.empty(3), np.empty(3)
    force = np.empty((plan.shape[0], 3))
    moment = np.empty((plan.shape[0], 3))
    info[1] = REACHED
    info[3] = np.nan
    info[4] = 0.0
    info[5] = np.nan
    info[6] = 0.0
    worst = _rk4(y0, h, y1, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, v,
                 False)
    if worst < 0.0:
        info[1] = SINGULAR
        return
    if worst > info[0]:
        info[0] = worst
    # the release conditions (Releases.crossing, Releases._locate)
    if watch.shape[0] > 0:
        code = _release_values(y1, 0, watch.shape[0], bodies, gravity, loads, rows_i, rows_f,
                               plan, roots, eta, dense, v, joints_i, joints_f, watch, triggers,
                               watch_plan, values, rot, pa, pb, force, moment)
        if code != REACHED:
            info[1] = code
            return
        reached = np.empty((watch.shape[0], 3), dtype=np.bool_)
        anything = False
        for w in range(watch.shape[0]):
            for col in range(3):
                reached[w, col] = values[w, col] >= triggers[w, col]
                anything = anything or reached[w, col]
        if anything:
            best, count = h, 0
            for w in range(watch.shape[0]):
                for col in range(3):
                    if not reached[w, col]:
                        continue
                    at0, code = _excess(0.0, y0, ys, w, col, bodies, gravity, loads, rows_i,
                                        rows_f, plan, roots, eta, dense, v, joints_i, joints_f,
                                        watch, triggers, watch_plan, values, rot, pa, pb, force,
                                        moment, info)
                    if code != REACHED:
                        info[1] = code
                        info[2] = 0.0
                        return
                    s = 0.0
                    if not at0 >= 0.0:
                        s, code = _brentq(h, y0, ys, w, col, bodies, gravity, loads, rows_i,
                                          rows_f, plan, roots, eta, dense, v, joints_i,
                                          joints_f, watch, triggers, watch_plan, values, rot,
                                          pa, pb, force, moment, info)
                        if code != REACHED:
                            info[1] = code
                            info[2] = s
                            return
                    if s < best - 1e-15:
                        best, count = s, 1
                        joints_found[0, 0], joints_found[0, 1] = watch[w], col
                    elif abs(s - best) <= 1e-15:
                        known = False
                        for i in range(count):
                            known = known or joints_found[i, 0] == watch[w]
                        if not known:
                            joints_found[count, 0], joints_found[count, 1] = watch[w], col
                            count += 1
            info[3], info[4] = best, count
    # the ejectors' stroke ends (ScheduledLoads.crossing)
    best, count = h, -1
    for row in range(n, loads.shape[0]):
        if loads[row, applied_loads.S_KIND] != 1.0:
            break   # the scheduled rows come first
        limit = loads[row, applied_loads.S_STROKE]
        if not (loads[row, applied_loads.S_ON] > 0.0 and np.isfinite(limit)
                and applied_loads._point_and_stroke(y1, loads, row, n)[3] >= limit):
            continue
        count = max(count, 0)
        at0, code = _excess(0.0, y0, ys, row, 3, bodies, gravity, loads, rows_i, rows_f, plan,
                            roots, eta, dense, v, joints_i, joints_f, watch, triggers,
                            watch_plan, values, rot, pa, pb, force, moment, info)
        s = 0.0
        if not at0 >= 0.0:
            s, code = _brentq(h, y0, ys, row, 3, bodies, gravity, loads, rows_i, rows_f, plan,
                              roots, eta, dense, v, joints_i, joints_f, watch, triggers,
                              watch_plan, values, rot, pa, pb, force, moment, info)
            if code != REACHED:
                info[1] = code
                info[2] = s
                return
        if s < best - 1e-15:
            best, count = s, 1
            wrenches_found[0] = row - n
        elif abs(s - best) <= 1e-15:
            wrenches_found[count] = row - n
            count += 1
    if count >= 0:
        info[5], info[6] = best, count
    # the state where the step is cut: the stroke end, unless a release comes first
    release, stroke = info[3], info[5]
    cut = stroke if not np.isnan(stroke) and not release < stroke else release
    if cut < h:
        worst = _rk4(y0, cut, ys, bodies, gravity, loads, rows_i, rows_f, plan, roots, eta,
                     dense, v, False)
        if worst < 0.0:
            info[1] = SINGULAR
            info[2] = cut
            return
        if worst > info[0]:
            info[0] = worst


# ---------------------------------------------- applied loads called from Python
# loads.ScheduledLoads calls these through the kernel, so that a kernel compiled
# ahead of time (aot.py) has them compiled too

@numba.njit(**_NRT)
def loads_set_time(loads, n, t):
    """Write the time t into the scheduled rows (``loads.set_time``)."""
    applied_loads.set_time(loads, n, t)


@numba.njit(**_NRT)
def loads_strokes(y, loads, n, out):
    """Write each scheduled wrench's stroke so far at y into out (``loads.strokes``)."""
    applied_loads.strokes(y, loads, n, out)


@numba.njit(**_NRT)
def loads_rotations(y, n, rot):
    """Write the bodies' rotation matrices at y into rot (``loads._rotations``)."""
    applied_loads._rotations(y, n, rot)


# ------------------------------------------- kinematic bodies called from Python
# engine.Simulator calls these through the kernel (aot.py compiles them too)

@numba.njit(**_NRT)
def motion_place(y, bodies, offset):
    """Write the kinematic bodies' state at their step start + offset into y (``motion.place``)."""
    motion.place(y, bodies, offset)


@numba.njit(**_NRT)
def motion_set_time(bodies, t):
    """Write the time of the step's start into the kinematic bodies' columns."""
    motion.set_time(bodies, t)


# ------------------------------------------------------- run metrics (study.metrics)

@numba.njit(**_NRT)
def clearance(pos_a, quat_a, points_a, pos_b, quat_b, points_b, out):
    """
    Write the least distance between points on two bodies over samples into out.

    pos_* (k, 3), quat_* (k, 4): the bodies' CG positions and attitudes
    (x y z w, body to world, normalized here) at the same k samples;
    points_* (p, 3): points in body axes. out[:4]: the distance, m, and the
    sample, point on a and point on b where it is least (the first in that
    order if several tie); inf and -1 with no sample or no point.
    """
    out[0], out[1], out[2], out[3] = np.inf, -1.0, -1.0, -1.0
    world_a = np.empty((points_a.shape[0], 3))
    world_b = np.empty((points_b.shape[0], 3))
    for k in range(pos_a.shape[0]):
        _world_points(pos_a[k], quat_a[k], points_a, world_a)
        _world_points(pos_b[k], quat_b[k], points_b, world_b)
        for i in range(world_a.shape[0]):
            for j in range(world_b.shape[0]):
                dx = world_a[i, 0] - world_b[j, 0]
                dy = world_a[i, 1] - world_b[j, 1]
                dz = world_a[i, 2] - world_b[j, 2]
                distance = np.sqrt(dx * dx + dy * dy + dz * dz)
                if distance < out[0]:
                    out[0], out[1], out[2], out[3] = distance, k, i, j


@numba.njit(**_JIT)
def _world_points(position, quat, points, out):
    """Write body-axis points at a CG position and attitude (normalized here) in world."""
    norm = np.sqrt(quat[0] * quat[0] + quat[1] * quat[1] + quat[2] * quat[2]
                   + quat[3] * quat[3])
    x, y, z, w = quat[0] / norm, quat[1] / norm, quat[2] / norm, quat[3] / norm
    r00, r01, r02 = 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)
    r10, r11, r12 = 2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)
    r20, r21, r22 = 2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)
    for i in range(points.shape[0]):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        out[i, 0] = position[0] + (r00 * px + r01 * py + r02 * pz)
        out[i, 1] = position[1] + (r10 * px + r11 * py + r12 * pz)
        out[i, 2] = position[2] + (r20 * px + r21 * py + r22 * pz)
