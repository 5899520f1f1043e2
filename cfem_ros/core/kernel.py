# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The compiled hot path: state derivative, RK4 and the step loop (C++, ``_kernel``).

The functions are those of the extension module ``cfem_ros.core._kernel``
(``cfem_ros/core/cpp``, built by ``pip install`` or ``colcon build``); this
module is its Python face: the constants, the workspace's views and the
same names and arguments the engine calls.

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

import functools
import math

from cfem_ros.core import _kernel
import numpy as np

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

#: ``locate`` codes in ``info[1]`` besides REACHED, SINGULAR and LOADS_NOT_FINITE:
#: a condition's value is NaN, the step's ends do not bracket it, no convergence
#: (the errors of ``roots.brentq``).
NAN_VALUE, SAME_SIGNS, NO_CONVERGENCE = 7, 8, 9

#: Brent's tolerances for a crossing (as releases.py and loads.py use roots.brentq).
CROSSING_XTOL, CROSSING_RTOL, CROSSING_MAXITER = 1e-15, 4 * np.finfo(np.float64).eps, 200

#: The compiled functions (their docstrings: the C++ headers in ``cpp/``).
#: Arrays are float64 (plan, rows_i, roots, watch and the like int64) in C order,
#: taken without copies; a wrong one raises TypeError or ValueError naming it.
#: Every function that computes releases the GIL.
workspace_size = _kernel.workspace_size
derivative = _kernel.derivative
rk4_step = _kernel.rk4_step
joint_loads = _kernel.joint_loads
sample_outputs = _kernel.sample_outputs
row_jacobian = _kernel.row_jacobian
project = _kernel.project
conditions = _kernel.conditions
advance = _kernel.advance
locate = _kernel.locate
loads_set_time = _kernel.loads_set_time
loads_strokes = _kernel.loads_strokes
loads_rotations = _kernel.loads_rotations
motion_place = _kernel.motion_place
motion_set_time = _kernel.motion_set_time
clearance = _kernel.clearance
#: The solve's small factorizations (tests check their pivot thresholds).
_inverse = _kernel.inverse
_cholesky = _kernel.cholesky


def carve(work: np.ndarray, n: int, m: int, nj: int) -> tuple:
    """
    Cut the workspace into views (see ``workspace_size``).

    0 rot, 1 omega, 2 inv_inertia, 3 mhat, 4 fhat, 5 acc, 6 jac, 7 weighted,
    8 rate, 9 gamma, 10 value, 11 rhs, 12 basis, 13 weighted_basis, 14 chol,
    15 projected, 16 particular, 17 wrench, 18 stages, 19 six (4, 6, 6),
    20 three (4, 3, 3), 21 vec (8, 3), 22 the first two rows of vec as one (6,).
    The compiled code cuts the same parts (``cpp/workspace.cpp``), then its own
    scratch after them.
    """
    return tuple(work[start:stop].reshape(shape) for start, stop, shape in _parts(n, m, nj))


@functools.lru_cache(maxsize=256)
def _parts(n: int, m: int, nj: int) -> tuple:
    """Return the views of ``carve`` as (start, stop, shape), computed once per size."""
    shapes = [(n, 3, 3), (n, 3), (n, 3, 3), (n, 6, 6), (n, 6), (n, 6), (m, 12), (m, 12),
              (m,), (m,), (m,), (m,), (nj, 6, 3), (nj, 6, 3), (nj, 3, 3), (nj, 3), (nj, 6),
              (nj, 6), (6, 13 * n), (4, 6, 6), (4, 3, 3), (8, 3)]
    parts, o = [], 0
    for shape in shapes:
        size = math.prod(shape)
        parts.append((o, o + size, shape))
        o += size
    parts.append((o - 24, o - 18, (6,)))
    return tuple(parts)


def constraint_values(work: np.ndarray, n: int, m: int, n_j: int) -> np.ndarray:
    """Return the constraint values of the last solve (a view of the workspace)."""
    start, stop, _ = _parts(n, m, n_j)[10]
    return work[start:stop]
