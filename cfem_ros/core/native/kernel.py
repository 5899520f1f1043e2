# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The compiled hot path: state derivative, RK4 and the step loop (C++, ``_kernel``).

The functions are those of the extension module ``cfem_ros.core._kernel``
(``cfem_ros/core/cpp``, built by ``pip install`` or ``colcon build``); this
module is its one Python face: nothing else imports the extension. The
layout of every array the two share (columns, widths, workspace parts) is
the extension's (``cpp/layout.hpp``, ``cpp/workspace.hpp``), read here:
Python writes no column index of its own.

A ``System`` holds a model's arrays and the rows, plan, watched joints and
workspace of one set of active joints, checked once when made (as MuJoCo's
``mjModel``/``mjData``): shapes, dtypes and every index the arrays hold (a
body, row, plan line, joint, table or packed shape out of range is a
ValueError naming the argument, row, column and value; ``cpp/systemcheck.cpp``).
The solves take it and the state: ``derivative(system, y, dy)``,
``advance(system, y, info, ...)``; ``system.outputs`` is the size of a
sample. It points into the caller's arrays (no copy): the engine writes held
loads, switches and trajectories into them between calls. The arrays are
laid out by ``engine.Simulator``; this module only computes, and never
allocates inside the step loop: every scratch array is a part of the
System's one workspace.

State ``y`` (13 n): positions (3 n, world, m), velocities (3 n, world, m/s),
quaternions (4 n, x y z w, body to world), rates (3 n, body axes, rad/s).

``bodies`` (n, ``BODIES.BODY_COLUMNS``): mass, 1/mass (0 for ground), inertia
(9, body axes, about the CG), inverse inertia (9; 0 for ground); with
kinematic bodies, more columns: their trajectories (``motion.py``).
``loads``: the packed applied loads of ``loads.py`` (``LOADS``; per body:
force (3), torque (3), 1.0 if in body axes, application point (3); then the
scheduled wrenches and their tables).
``rows_i`` (m, 3): parent body, child body, 1 for a translation row, 2 for a
translation row at the same joint point as the row before (its terms are
computed once), 0 for a rotation row. Rows come grouped by joint.
``rows_f`` (m, 9): translation rows: axis on the parent, anchor on the
parent, anchor on the child (body axes); rotation rows: vector on the parent,
vector on the child, unused.
``plan`` (J, ``PLAN.WIDTH``), one line per active joint, leaves of the joint
tree first: first row, translation rows, rotation rows, tree child body, tree
parent body, +1 if the tree child is the joint's child (-1 if it is its
parent), model joint index. ``roots`` (n,): -1 for a fixed body, 0 for a free body held to
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

from cfem_ros.core import _kernel
import numpy as np


class Layout:
    """
    The columns of one array the kernel shares with Python, as the extension lays them out.

    Each column is an attribute holding its first index (``LOADS.S_FORCE``),
    each number of the table an attribute holding its value (``LOADS.WIDTH``,
    ``LOADS.KIND_SCHEDULED``); ``span(name)`` is the slice of a column's width.
    """

    def __init__(self, array: str):
        #: {name: (group, first column, width)}; width 0: to the end of the row.
        self.columns = {}
        #: {name: value} of the table's sizes and stored values.
        self.numbers = {}
        for name, entry in _kernel.LAYOUT[array].items():
            if isinstance(entry, tuple):
                self.columns[name] = entry
            else:
                self.numbers[name] = entry
            setattr(self, name, entry[1] if isinstance(entry, tuple) else entry)
        self.array = array

    def width(self, name: str) -> int:
        """Return how many numbers a column holds (0: to the end of the row)."""
        return self.columns[name][2]

    def span(self, name: str) -> slice:
        """Return the slice of a column's numbers in a row."""
        _, first, width = self.columns[name]
        return slice(first, first + width if width else None)


#: The arrays' layouts (``cpp/layout.hpp``): ``bodies`` and the kinematic bodies'
#: columns, ``loads``, a packed aerodynamic table's header (``aero_table``), ``plan``,
#: the ``info`` of ``advance`` and of ``locate``, a sample's outputs (``sample``: per
#: body, joint, applied source and aero body), the air of ``aero_wrench``
#: (``aero_air``), a kinematic body's trajectory from ``BODIES.M_DATA`` on
#: (``trajectory``), a packed collision shape (``shape``) and the velocity
#: correction of ``project`` (``twist``), the closest points of ``distance``
#: (``closest``), a body's track between its samples (``track``) and the least
#: distance over a window found between samples (``least``).
BODIES = Layout('bodies')
LOADS = Layout('loads')
AERO_TABLE = Layout('aero_table')
PLAN = Layout('plan')
ROWS_I = Layout('rows_i')
ROWS_F = Layout('rows_f')
JOINTS_I = Layout('joints_i')
JOINTS_F = Layout('joints_f')
ADVANCE_INFO = Layout('advance_info')
LOCATE_INFO = Layout('locate_info')
SAMPLE = Layout('sample')
#: An odometry input's 13 numbers (``odometry``; ``run.inputs.Input.values``):
#: position, quaternion, velocity and rates, ``D_*``. The kernel reads no such
#: vector; its table is the extension's so that one file lays out every one.
ODOMETRY = Layout('odometry')
AERO_AIR = Layout('aero_air')
TRAJECTORY = Layout('trajectory')
SHAPE = Layout('shape')
TWIST = Layout('twist')
CLOSEST = Layout('closest')
TRACK = Layout('track')
LEAST = Layout('least')
#: The integrator's state y of n bodies (``state``): blocks of all bodies, block
#: ``Y_*`` from ``first * n`` on, ``width`` numbers per body (``state_block``).
STATE = Layout('state')


def state_block(y: np.ndarray, n: int, name: str) -> np.ndarray:
    """Return the view of block ``name`` of ``STATE`` in the state y of n bodies, (n, width)."""
    _, first, width = STATE.columns[name]
    return y[first * n:(first + width) * n].reshape(n, width)


#: ``advance`` results in ``info[ADVANCE_INFO.I_RESULT]`` (LOADS_NOT_FINITE: a
#: sample's outputs or a force-release check's joint loads are not finite while
#: the state is); ``locate`` codes in ``info[LOCATE_INFO.L_CODE]`` besides
#: REACHED, SINGULAR and LOADS_NOT_FINITE: a condition's value is NaN, the
#: step's ends do not bracket it, no convergence.
REACHED, CONDITION, NOT_FINITE = _kernel.REACHED, _kernel.CONDITION, _kernel.NOT_FINITE
VIOLATION, SINGULAR, ROWS_FULL = _kernel.VIOLATION, _kernel.SINGULAR, _kernel.ROWS_FULL
LOADS_NOT_FINITE = _kernel.LOADS_NOT_FINITE
NAN_VALUE, SAME_SIGNS, NO_CONVERGENCE = (_kernel.NAN_VALUE, _kernel.SAME_SIGNS,
                                         _kernel.NO_CONVERGENCE)

#: A pivot of the solve (a Cholesky pivot, a 2x2 or 3x3 determinant over the
#: product of its diagonal, a hinge's D over its diagonal terms) at
#: or below this fraction of its scale has lost all but about three of its 16
#: digits to cancellation: the solve is ill-conditioned and reported as singular.
#: (A hinge's D = g^T M^ g is measured against sum M^_ii g_i^2.)
PIVOT_RTOL = _kernel.PIVOT_RTOL

#: Brent's tolerances for a crossing (``cpp/events.hpp``: scipy's brentq's, as
#: ``test/crossings.py``'s reference search uses them).
CROSSING_XTOL, CROSSING_RTOL = _kernel.CROSSING_XTOL, _kernel.CROSSING_RTOL
CROSSING_MAXITER = _kernel.CROSSING_MAXITER

#: The search between samples (``cpp/between.hpp``): how close its least comes to the
#: interpolant's (m), by how much it must fall below the least sample to replace it (m),
#: and the points probed per sample interval.
BETWEEN_DISTANCE_TOLERANCE = _kernel.BETWEEN_DISTANCE_TOLERANCE
BETWEEN_GAIN = _kernel.BETWEEN_GAIN
BETWEEN_PROBES = _kernel.BETWEEN_PROBES

#: The compiled functions (their docstrings: the C++ headers in ``cpp/``).
#: Arrays are float64 (plan, rows_i, roots, watch and the like int64) in C order,
#: taken without copies; a wrong one raises TypeError or ValueError naming it.
#: Every function that computes releases the GIL (the small per-body ones, times,
#: rotations and trajectories, from 64 bodies or rows on: below, a release costs as
#: much as their work). What only the tests call (a reference search's pieces: one
#: RK4 step, the release conditions, the strokes; the small factorizations; the table
#: interpolation alone) is the extension's submodule ``_kernel.testing``, not this API.
System = _kernel.System
derivative = _kernel.derivative
joint_loads = _kernel.joint_loads
sample_outputs = _kernel.sample_outputs
row_jacobian = _kernel.row_jacobian
project = _kernel.project
advance = _kernel.advance
locate = _kernel.locate
workspace_size = _kernel.workspace_size
loads_set_time = _kernel.loads_set_time
loads_rotations = _kernel.loads_rotations
loads_aero_axes = _kernel.loads_aero_axes
motion_place = _kernel.motion_place
motion_set_time = _kernel.motion_set_time
clearance = _kernel.clearance
isa = _kernel.isa


def views(system) -> dict:
    """
    Return the parts of a System's workspace as views, by name (``cpp/workspace.hpp``).

    E.g. ``jac`` (m, 12), ``value`` (m,): the rows' Jacobian blocks and
    values of the last solve (``jac`` whole after ``row_jacobian``; a tree
    solve writes only the columns it reads: a translation row's rotation
    columns are left as they were).
    """
    work = system.work
    return {name: work[start:start + size].reshape(shape)
            for name, (start, size, shape) in _parts(system).items()}


def _parts(system) -> dict:
    """Return the parts of a System's workspace as {name: (start, size, shape)}."""
    return _sized_parts(system.n, system.m, system.joints, system.dense)


@functools.lru_cache(maxsize=256)
def _sized_parts(n: int, m: int, nj: int, dense: int) -> dict:
    """Return the workspace's parts as {name: (start, size, shape)}, read once per size."""
    return {name: (start, int(np.prod(shape, dtype=np.int64)), shape)
            for name, start, shape in _kernel.workspace_parts(n, m, nj, dense)}


def constraint_values(system) -> np.ndarray:
    """Return the constraint values of the system's last solve (a view of its workspace)."""
    start, size, _ = _parts(system)['value']
    return system.work[start:start + size]


# The vectorised aerodynamic-table and shape-distance functions (cpp/aeroshapes.cpp)
# take float64 arrays in C order as they are; these make that so, in the open.

def aero_wrench(packed, position, velocity, rot, rates, carrier_position, carrier_rot):
    """Return the aerodynamic wrench at k states, (k, 6), and the air data, (k, 22)."""
    return _kernel.aero_wrench(*(_floats(a) for a in (packed, position, velocity, rot, rates,
                                                      carrier_position, carrier_rot)))


def distance(shape_a, rot_a, position_a, shape_b, rot_b, position_b):
    """
    Return the shapes' distances at k pose pairs, (k,) m, closest points and parts.

    The closest points, (k, ``CLOSEST.WIDTH``): on a, then on b (world, m).

    The parts, (k, 2): the closest parts of compound shapes (0 for a convex one).
    """
    return _kernel.distance(*(_floats(a) for a in (shape_a, rot_a, position_a, shape_b, rot_b,
                                                   position_b)))


def track(position, quaternion, velocity, rates) -> np.ndarray:
    """
    Return a body's track between its samples, (n, ``TRACK.WIDTH``) (``cpp/between.cpp``).

    From its n samples' CG position (world, m), quaternion (x y z w, body to
    world), CG velocity (body axes, m/s) and body rates (rad/s): each quaternion
    on the side of the one before, the velocity in world axes and the
    quaternion's rate of change.
    """
    position, quaternion, velocity, rates = (_floats(a) for a in (position, quaternion,
                                                                  velocity, rates))
    out = np.empty((len(position), TRACK.WIDTH))
    _kernel.track(position, quaternion, velocity, rates, out)
    return out


def least_shape_distance(time, sampled, track_a, track_b, shape_a, shape_b, start: float,
                         end: float) -> np.ndarray:
    """
    Return the least distance of two packed shapes over [start, end], between samples included.

    ``cpp/between.hpp``'s search (``cfem_ros.study.between`` describes it):
    time, sampled (n,) the sample times (s) and the distance there (m);
    track_a, track_b (n, ``TRACK.WIDTH``) the bodies' tracks, or (0,
    ``TRACK.WIDTH``) each for the samples alone. Returns (``LEAST.WIDTH``,):
    the least (m), its time (s), the poses there (NaN at a sample).
    """
    out = np.empty(LEAST.WIDTH)
    _kernel.least_shape_distance(*(_floats(a) for a in (time, sampled, track_a, track_b,
                                                        shape_a, shape_b)),
                                 float(start), float(end), out)
    return out


def least_point_distance(time, track_a, track_b, points_a, points_b, start: float,
                         end: float) -> np.ndarray:
    """
    Return the least distance over pairs of body-axis points (m) in [start, end], between samples.

    As ``least_shape_distance``, the distance at the samples computed here (the
    ``clearance`` metric's); points_a (p, 3), points_b (q, 3) in body axes, m.
    ``LEAST.L_POINT_A``, ``L_POINT_B``: the closest pair between samples.
    """
    out = np.empty(LEAST.WIDTH)
    _kernel.least_point_distance(*(_floats(a) for a in (time, track_a, track_b, points_a,
                                                        points_b)),
                                 float(start), float(end), out)
    return out


def _floats(a) -> np.ndarray:
    """Return a as float64 in C order (the same array when it already is)."""
    return np.ascontiguousarray(a, dtype=np.float64)


# The kernel's formulas over many samples (cpp/recorded.cpp): the step's and the
# sample's own, so that Python keeps no copy of them.

def relative_states(position, velocity, quaternion, rates, ref_position, ref_velocity,
                    ref_quaternion, ref_rates) -> np.ndarray:
    """
    Return k bodies' poses and twists relative to k reference bodies, (k, ``SAMPLE.BODY``).

    Each body's CG position and velocity (world, m and m/s), quaternion (x y z
    w, body to world, any non-zero norm) and rates (body axes, rad/s), (k, 3)
    or (k, 4). The result has a sample's body columns (``SAMPLE``): the CG from
    the reference's CG, the attitude relative to it (unit, x y z w), the CG
    velocity seen from the reference and the relative angular velocity, all in
    the reference's axes: what a sample of a body with a ``reference`` holds.
    """
    return _kernel.relative_states(*(_floats(a) for a in (
        position, velocity, quaternion, rates, ref_position, ref_velocity, ref_quaternion,
        ref_rates)))


def dynamic_pressure(density, speed) -> np.ndarray:
    """Return the dynamic pressure rho v^2 / 2 of densities (kg/m^3) at speeds (m/s), Pa."""
    density, speed = np.broadcast_arrays(np.asarray(density, dtype=np.float64),
                                         np.asarray(speed, dtype=np.float64))
    out = _kernel.dynamic_pressure(_floats(density.ravel()), _floats(speed.ravel()))
    return out.reshape(density.shape)


def shape_reach(convex) -> float:
    """Return the radius about its centre of a sphere holding a packed convex shape, m."""
    return _kernel.shape_reach(_floats(convex))


def bounding_radius(shape) -> float:
    """Return the radius about the body's CG of a sphere holding a packed shape, m."""
    return _kernel.bounding_radius(_floats(shape))
