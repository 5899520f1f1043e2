# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Applied loads: held wrenches at points, scheduled wrenches, ejector strokes.

Every load the kernel applies lives in one packed array, the kernel's
``loads`` (rows of ``WIDTH`` numbers), so that the compiled step needs no
Python call and no new argument:

- rows 0 .. n-1, one per body, the wrench held from topics or inputs:
  force (3), torque (3), 1.0 if in body axes, application point (3, body
  axes, from the CG; the moment about the CG gains r x F);
- then one row per scheduled wrench (``S_*`` columns; ``S_KIND`` = 1);
- then one row per body with aerodynamic tables (``A_*`` columns, ``S_KIND`` = 3);
- then the rows of their tables (``S_KIND`` = 2): abscissa (time, s, or
  stroke, m) then force (3) and moment (3), or the aerodynamic grids;
- then, if there is any row after the bodies', one scratch row (``S_KIND`` = 4).

A scheduled wrench acts on its body at its point while it is on: its time
window cuts the steps like a release time (the engine switches it), and the
end of its stroke is watched after each step and located inside the step on
the step's own RK4 map, like a release condition. Its opposite acts on
``reacts_on`` at the same world point. Stage times (for tables against
time) are written by the kernel's RK4 into the scheduled rows.

numba caches each function with its own file only: after editing this
module, delete the ``__pycache__`` ``*.nbi``/``*.nbc`` of ``kernel.py`` too.
"""

from __future__ import annotations

import math

from cfem_ros.core.roots import brentq   # scipy's brentq, without importing scipy
import numba
import numpy as np

#: No reference counting but where a function allocates (``kernel._JIT`` says why).
_JIT = {'cache': True, 'nogil': True, 'fastmath': {'contract'}, 'error_model': 'numpy',
        '_nrt': False}
_NRT = dict(_JIT, _nrt=True)

#: Columns of a packed row.
WIDTH = 24
#: Held rows: the application point's columns.
H_POINT = 7
#: Scheduled rows: body, reacts_on (-1 none), frame (-1 world, else a body), on (1.0).
S_BODY, S_REACT, S_FRAME, S_ON = 0, 1, 2, 3
#: point (3), force (3), moment (3), stroke (inf: none), anchor (3).
S_POINT, S_FORCE, S_MOMENT, S_STROKE, S_ANCHOR = 4, 7, 10, 13, 14
#: table: 0 none, 1 against time, 2 against stroke; its first row, its length.
S_TABLE, S_FIRST, S_COUNT = 17, 18, 19
#: time of the step's start, time of the stage being evaluated, the wrench's start (s).
S_T0, S_T, S_START = 20, 21, 22
#: row kind: 0 held, 1 scheduled, 2 table, 3 aerodynamic, 4 scratch (the last row).
S_KIND = 23
TABLE_NONE, TABLE_TIME, TABLE_STROKE = 0, 1, 2
#: Aerodynamic rows: body, area, length, density, air velocity (3, world),
#: Clp, Cmq, Cnr, grid sizes (alpha, beta), first table row: the alpha
#: values (rad, column 0), then the beta values, then per grid node
#: (alpha-major) CX, CY, CZ, Cl, Cm, Cn in columns 1-6.
A_BODY, A_AREA, A_LENGTH, A_DENSITY, A_WIND, A_DAMPING = 0, 1, 2, 3, 4, 7
A_NA, A_NB, A_FIRST = 10, 11, 12


# ------------------------------------------------------------- compiled part

@numba.njit(**_JIT)
def held_moment(rot, i, loads, force, torque):
    """Return the held torque of body i plus r x F (world axes), r its point turned by rot[i]."""
    px, py, pz = loads[i, H_POINT], loads[i, H_POINT + 1], loads[i, H_POINT + 2]
    if px == 0.0 and py == 0.0 and pz == 0.0:
        return torque
    r = (rot[i, 0, 0] * px + rot[i, 0, 1] * py + rot[i, 0, 2] * pz,
         rot[i, 1, 0] * px + rot[i, 1, 1] * py + rot[i, 1, 2] * pz,
         rot[i, 2, 0] * px + rot[i, 2, 1] * py + rot[i, 2, 2] * pz)
    return (torque[0] + r[1] * force[2] - r[2] * force[1],
            torque[1] + r[2] * force[0] - r[0] * force[2],
            torque[2] + r[0] * force[1] - r[1] * force[0])


@numba.njit(**_JIT)
def _turn(rot, i, v, out):
    for k in range(3):
        out[k] = rot[i, k, 0] * v[0] + rot[i, k, 1] * v[1] + rot[i, k, 2] * v[2]


@numba.njit(**_JIT)
def _carried(y, n, i, px, py, pz):
    """Return body i's CG plus its rotation (from its quaternion in y) applied to p."""
    o = 6 * n + 4 * i
    x, yy, z, w = y[o], y[o + 1], y[o + 2], y[o + 3]
    s = 2.0 / (x * x + yy * yy + z * z + w * w)
    return (y[3 * i] + (1 - s * (yy * yy + z * z)) * px + s * (x * yy - w * z) * py
            + s * (x * z + w * yy) * pz,
            y[3 * i + 1] + s * (x * yy + w * z) * px + (1 - s * (x * x + z * z)) * py
            + s * (yy * z - w * x) * pz,
            y[3 * i + 2] + s * (x * z - w * yy) * px + s * (yy * z + w * x) * py
            + (1 - s * (x * x + yy * yy)) * pz)


@numba.njit(**_JIT)
def _point_and_stroke(y, loads, row, n):
    """Return the scheduled row's point (world, 3 numbers) and its stroke so far, m."""
    b = int(loads[row, S_BODY])
    p = _carried(y, n, b, loads[row, S_POINT], loads[row, S_POINT + 1],
                 loads[row, S_POINT + 2])
    j = int(loads[row, S_REACT])
    ref = (loads[row, S_ANCHOR], loads[row, S_ANCHOR + 1], loads[row, S_ANCHOR + 2])
    if j >= 0:
        ref = _carried(y, n, j, ref[0], ref[1], ref[2])
    gap = (p[0] - ref[0], p[1] - ref[1], p[2] - ref[2])
    return p[0], p[1], p[2], math.sqrt(gap[0] * gap[0] + gap[1] * gap[1] + gap[2] * gap[2])


@numba.njit(**_JIT)
def _table_value(loads, row, x, out):
    """Force and moment of the row's table at x into out (6), linear, held beyond its ends."""
    first, count = int(loads[row, S_FIRST]), int(loads[row, S_COUNT])
    last = first + count - 1
    if x <= loads[first, 0]:
        for k in range(6):
            out[k] = loads[first, 1 + k]
        return
    if x >= loads[last, 0]:
        for k in range(6):
            out[k] = loads[last, 1 + k]
        return
    lo = first
    while loads[lo + 1, 0] < x:
        lo += 1
    x0, x1 = loads[lo, 0], loads[lo + 1, 0]
    u = (x - x0) / (x1 - x0)
    for k in range(6):
        out[k] = loads[lo, 1 + k] + u * (loads[lo + 1, 1 + k] - loads[lo, 1 + k])


@numba.njit(**_JIT)
def scheduled_wrench(y, rot, loads, row, n, out):
    """
    Put the scheduled row's wrench on its body at y into out, world axes.

    out (18): force (3), moment about the body's CG (3), then the world
    point (3) and the moment given with the force (3), then scratch.
    Returns False if it is off.
    """
    if loads[row, S_ON] <= 0.0:
        return False
    point = out[6:9]
    point[0], point[1], point[2], stroke = _point_and_stroke(y, loads, row, n)
    local = out[12:18]
    kind = int(loads[row, S_TABLE])
    if kind == TABLE_NONE:
        for k in range(6):
            local[k] = loads[row, S_FORCE + k]
    else:
        x = loads[row, S_T] - loads[row, S_START] if kind == TABLE_TIME else stroke
        _table_value(loads, row, x, local)
    f = int(loads[row, S_FRAME])
    if f >= 0:
        _turn(rot, f, local[0:3], out[0:3])
        _turn(rot, f, local[3:6], out[9:12])
    else:
        for k in range(3):
            out[k] = local[k]
            out[9 + k] = local[3 + k]
    b = int(loads[row, S_BODY])
    r = (point[0] - y[3 * b], point[1] - y[3 * b + 1], point[2] - y[3 * b + 2])
    out[3] = out[9] + r[1] * out[2] - r[2] * out[1]
    out[4] = out[10] + r[2] * out[0] - r[0] * out[2]
    out[5] = out[11] + r[0] * out[1] - r[1] * out[0]
    return True


@numba.njit(**_JIT)
def _bracket(loads, first, count, x):
    """Return (i, u): x between grid values i and i + 1 at fraction u, held at the ends."""
    if count == 1 or x <= loads[first, 0]:
        return 0, 0.0
    if x >= loads[first + count - 1, 0]:
        return count - 2, 1.0
    i = 0
    while loads[first + i + 1, 0] < x:
        i += 1
    return i, (x - loads[first + i, 0]) / (loads[first + i + 1, 0] - loads[first + i, 0])


@numba.njit(**_JIT)
def aero_wrench(y, rot, loads, row, n, out):
    """
    Put the aerodynamic force and moment about the CG of the row's body at y into out.

    out[0:6], world axes (out[6:12] is scratch); zero at zero airspeed.
    """
    b = int(loads[row, A_BODY])
    rel = (y[3 * n + 3 * b] - loads[row, A_WIND], y[3 * n + 3 * b + 1] - loads[row, A_WIND + 1],
           y[3 * n + 3 * b + 2] - loads[row, A_WIND + 2])
    u = rot[b, 0, 0] * rel[0] + rot[b, 1, 0] * rel[1] + rot[b, 2, 0] * rel[2]
    v = rot[b, 0, 1] * rel[0] + rot[b, 1, 1] * rel[1] + rot[b, 2, 1] * rel[2]
    w = rot[b, 0, 2] * rel[0] + rot[b, 1, 2] * rel[1] + rot[b, 2, 2] * rel[2]
    speed = math.sqrt(u * u + v * v + w * w)
    for k in range(6):
        out[k] = 0.0
    if speed == 0.0:
        return
    alpha = math.atan2(w, u)
    beta = math.asin(min(1.0, max(-1.0, v / speed)))
    na, nb, first = int(loads[row, A_NA]), int(loads[row, A_NB]), int(loads[row, A_FIRST])
    i, fa = _bracket(loads, first, na, alpha)
    j, fb = _bracket(loads, first + na, nb, beta)
    nodes = first + na + nb
    i1 = min(i + 1, na - 1)
    j1 = min(j + 1, nb - 1)
    c = out[6:12]   # scratch
    for k in range(6):
        c00 = loads[nodes + i * nb + j, 1 + k]
        c01 = loads[nodes + i * nb + j1, 1 + k]
        c10 = loads[nodes + i1 * nb + j, 1 + k]
        c11 = loads[nodes + i1 * nb + j1, 1 + k]
        low = c00 + fb * (c01 - c00)
        high = c10 + fb * (c11 - c10)
        c[k] = low + fa * (high - low)
    qs = 0.5 * loads[row, A_DENSITY] * speed * speed * loads[row, A_AREA]
    length = loads[row, A_LENGTH]
    scale = length / (2.0 * speed)
    o = 10 * n + 3 * b
    f = (qs * c[0], qs * c[1], qs * c[2])
    m = (qs * length * (c[3] + loads[row, A_DAMPING] * y[o] * scale),
         qs * length * (c[4] + loads[row, A_DAMPING + 1] * y[o + 1] * scale),
         qs * length * (c[5] + loads[row, A_DAMPING + 2] * y[o + 2] * scale))
    _turn(rot, b, f, out[0:3])
    _turn(rot, b, m, out[3:6])


@numba.njit(**_JIT)
def add_scheduled(y, rot, bodies, loads, fhat):
    """Add the scheduled wrenches that are on, their reactions and aero loads to fhat (world)."""
    n = bodies.shape[0]
    w = loads[loads.shape[0] - 1]   # the scratch row
    for row in range(n, loads.shape[0]):
        if loads[row, S_KIND] == 2.0 or loads[row, S_KIND] == 4.0:
            break   # the tables: no more loads
        if loads[row, S_KIND] == 3.0:
            aero_wrench(y, rot, loads, row, n, w)
            b = int(loads[row, A_BODY])
            for k in range(6):
                fhat[b, k] += w[k]
            continue
        if loads[row, S_KIND] != 1.0 or not scheduled_wrench(y, rot, loads, row, n, w):
            continue
        b = int(loads[row, S_BODY])
        for k in range(6):
            fhat[b, k] += w[k]
        j = int(loads[row, S_REACT])
        if j >= 0 and bodies[j, 1] > 0.0:
            r = (w[6] - y[3 * j], w[7] - y[3 * j + 1], w[8] - y[3 * j + 2])
            fhat[j, 0] -= w[0]
            fhat[j, 1] -= w[1]
            fhat[j, 2] -= w[2]
            fhat[j, 3] -= w[9] + r[1] * w[2] - r[2] * w[1]
            fhat[j, 4] -= w[10] + r[2] * w[0] - r[0] * w[2]
            fhat[j, 5] -= w[11] + r[0] * w[1] - r[1] * w[0]


@numba.njit(**_JIT)
def set_time(loads, n, t):
    """Write the time of the step's start (and of its evaluation) into the scheduled rows."""
    for row in range(n, loads.shape[0]):
        if loads[row, S_KIND] != 1.0:
            break
        loads[row, S_T0] = t
        loads[row, S_T] = t


@numba.njit(**_JIT)
def stage_time(loads, n, offset):
    """Write the RK4 stage's time, the step's start plus offset, into the scheduled rows."""
    for row in range(n, loads.shape[0]):
        if loads[row, S_KIND] != 1.0:
            break
        loads[row, S_T] = loads[row, S_T0] + offset


@numba.njit(**_JIT)
def _rotations(y, n, rot):
    for i in range(n):
        o = 6 * n + 4 * i
        x, yy, z, w = y[o], y[o + 1], y[o + 2], y[o + 3]
        s = 2.0 / (x * x + yy * yy + z * z + w * w)
        rot[i, 0, 0] = 1 - s * (yy * yy + z * z)
        rot[i, 0, 1] = s * (x * yy - w * z)
        rot[i, 0, 2] = s * (x * z + w * yy)
        rot[i, 1, 0] = s * (x * yy + w * z)
        rot[i, 1, 1] = 1 - s * (x * x + z * z)
        rot[i, 1, 2] = s * (yy * z - w * x)
        rot[i, 2, 0] = s * (x * z - w * yy)
        rot[i, 2, 1] = s * (yy * z + w * x)
        rot[i, 2, 2] = 1 - s * (x * x + yy * yy)


@numba.njit(**_JIT)
def strokes(y, loads, n, out):
    """Each scheduled row's stroke so far at y into out (rows n.., -1 for the others)."""
    for row in range(n, loads.shape[0]):
        out[row - n] = -1.0
        if loads[row, S_KIND] == 1.0:
            out[row - n] = _point_and_stroke(y, loads, row, n)[3]


@numba.njit(**_JIT)
def stroke_reached(y, loads, n):
    """Return True if a scheduled wrench that is on has reached its stroke at y."""
    for row in range(n, loads.shape[0]):
        kind = loads[row, S_KIND]
        if kind != 1.0 and kind != 3.0:
            break   # the tables: no more wrenches
        if kind == 1.0 and loads[row, S_ON] > 0.0 and loads[row, S_STROKE] < np.inf:
            if _point_and_stroke(y, loads, row, n)[3] >= loads[row, S_STROKE]:
                return True
    return False


@numba.njit(**_NRT)
def sample_applied(y, bodies, loads, out):
    """
    Write each scheduled wrench's load at y into out, 6 numbers a source (world axes).

    Per scheduled wrench: its force and moment about its body's CG, then,
    if it reacts on a body that is not fixed, the reaction's force and
    moment about that body's CG (``ScheduledLoads.sources`` order); zero
    while it is off.
    """
    n = bodies.shape[0]
    rot = np.empty((n, 3, 3))
    _rotations(y, n, rot)
    w = np.empty(18)
    o = 0
    for row in range(n, loads.shape[0]):
        if loads[row, S_KIND] == 2.0 or loads[row, S_KIND] == 4.0:
            break   # the tables
        if loads[row, S_KIND] == 3.0:
            aero_wrench(y, rot, loads, row, n, w)
            for k in range(6):
                out[o + k] = w[k]
            o += 6
            continue
        if loads[row, S_KIND] != 1.0:
            continue
        on = scheduled_wrench(y, rot, loads, row, n, w)
        for k in range(6):
            out[o + k] = w[k] if on else 0.0
        o += 6
        j = int(loads[row, S_REACT])
        if j >= 0 and bodies[j, 1] > 0.0:
            r = (w[6] - y[3 * j], w[7] - y[3 * j + 1], w[8] - y[3 * j + 2])
            reaction = (-w[0], -w[1], -w[2], -(w[9] + r[1] * w[2] - r[2] * w[1]),
                        -(w[10] + r[2] * w[0] - r[0] * w[2]),
                        -(w[11] + r[0] * w[1] - r[1] * w[0]))
            for k in range(6):
                out[o + k] = reaction[k] if on else 0.0
            o += 6


# ------------------------------------------------------------- Python part

def _kernel():
    """Return the kernel (imported here: it imports this module)."""
    from cfem_ros.core import kernel
    return kernel


class ScheduledLoads:
    """
    The scheduled wrenches of a model in a simulator's packed ``loads``.

    Parameters
    ----------
    model : Model
        Its ``wrenches`` (``model.Wrench``).
    n : int
        Number of bodies.

    Attributes
    ----------
    array : ndarray, shape (n + rows, WIDTH)
        The packed loads (the held rows first, zero).
    started, done : ndarray of bool
        Per wrench: switched on once; switched off for good.

    """

    def __init__(self, model, n: int):
        self.model = model
        self.n = n
        wrenches = getattr(model, 'wrenches', ())
        aero = getattr(model, 'aero', ())
        self.count = len(wrenches)
        tables = sum(len(w.table) for w in wrenches) + sum(
            len(a.alpha) + len(a.beta) + len(a.alpha) * len(a.beta) for a in aero)
        scratch = 1 if self.count or aero else 0
        rows = np.zeros((n + self.count + len(aero) + tables + scratch, WIDTH))
        if scratch:
            rows[-1, S_KIND] = 4.0
        nxt = n + self.count + len(aero)
        for k, w in enumerate(wrenches):
            r = rows[n + k]
            r[S_KIND] = 1.0
            r[S_BODY], r[S_REACT], r[S_FRAME] = w.body, w.reacts_on, w.frame
            r[S_POINT:S_POINT + 3] = w.point
            r[S_FORCE:S_FORCE + 3] = w.force
            r[S_MOMENT:S_MOMENT + 3] = w.moment
            r[S_STROKE] = np.inf if w.stroke is None else w.stroke
            r[S_START] = w.start
            r[S_TABLE] = {None: TABLE_NONE, 'time': TABLE_TIME, 'stroke': TABLE_STROKE}[
                w.table_against]
            if len(w.table):
                r[S_FIRST], r[S_COUNT] = nxt, len(w.table)
                rows[nxt:nxt + len(w.table), :7] = w.table
                rows[nxt:nxt + len(w.table), S_KIND] = 2.0
                nxt += len(w.table)
        for k, a in enumerate(aero):
            r = rows[n + self.count + k]
            r[S_KIND] = 3.0
            r[A_BODY], r[A_AREA], r[A_LENGTH], r[A_DENSITY] = a.body, a.area, a.length, a.density
            r[A_WIND:A_WIND + 3] = a.freestream
            r[A_DAMPING:A_DAMPING + 3] = a.damping
            r[A_NA], r[A_NB], r[A_FIRST] = len(a.alpha), len(a.beta), nxt
            na, nb = len(a.alpha), len(a.beta)
            rows[nxt:nxt + na, 0] = a.alpha
            rows[nxt + na:nxt + na + nb, 0] = a.beta
            rows[nxt + na + nb:nxt + na + nb + na * nb, 1:7] = a.coefficients.reshape(-1, 6)
            rows[nxt:nxt + na + nb + na * nb, S_KIND] = 2.0
            nxt += na + nb + na * nb
        self.array = rows
        self.started = np.zeros(self.count, dtype=bool)
        self.done = np.zeros(self.count, dtype=bool)
        #: Numbers a sample's applied loads take (6 a source).
        self.outputs_size = 6 * len(self.sources())

    def set_time(self, t: float):
        """Write the current time into the scheduled rows."""
        if self.array.shape[0] > self.n:
            _kernel().loads_set_time(self.array, int(self.n), float(t))

    def due(self, t: float):
        """Return the next time after t at which a wrench switches, or None."""
        times = []
        for k, w in enumerate(self.model.wrenches):
            if self.done[k]:
                continue
            if not self.started[k] and w.start > t:
                times.append(w.start)
            elif self.started[k] and w.end is not None and w.end > t:
                times.append(w.end)
        return min(times) if times else None

    def switch(self, t: float, y: np.ndarray) -> bool:
        """Switch the wrenches whose start or end is t or earlier; True if any did."""
        changed = False
        for k, w in enumerate(self.model.wrenches):
            if self.done[k]:
                continue
            if not self.started[k] and w.start <= t:
                self.started[k] = True
                self._anchor(k, y)
                self.array[self.n + k, S_ON] = 1.0
                changed = True
            if self.started[k] and w.end is not None and w.end <= t:
                self._off(k)
                changed = True
        return changed

    def reanchor(self, y: np.ndarray):
        """Measure the strokes of the wrenches already on from state y (a new initial state)."""
        for k in np.flatnonzero(self.started & ~self.done):
            self._anchor(k, y)

    def _off(self, k):
        self.done[k] = True
        self.array[self.n + k, S_ON] = 0.0

    def _anchor(self, k, y):
        """Record where the point is at the start (in world, or in reacts_on's axes)."""
        n = self.n
        row = self.array[n + k]
        rot = np.empty((n, 3, 3))
        _kernel().loads_rotations(np.ascontiguousarray(y), int(n), rot)
        b = int(row[S_BODY])
        point = y[3 * b:3 * b + 3] + rot[b] @ row[S_POINT:S_POINT + 3]
        j = int(row[S_REACT])
        if j >= 0:
            point = rot[j].T @ (point - y[3 * j:3 * j + 3])
        row[S_ANCHOR:S_ANCHOR + 3] = point

    def strokes(self, y: np.ndarray) -> np.ndarray:
        """Return each wrench's stroke so far at y, m."""
        out = np.empty(self.array.shape[0] - self.n)
        _kernel().loads_strokes(np.ascontiguousarray(y), self.array, int(self.n), out)
        return out[:self.count]

    def watched(self) -> np.ndarray:
        """Return the wrenches that are on with a stroke."""
        rows = self.array[self.n:self.n + self.count]
        return np.flatnonzero((rows[:, S_ON] > 0.0) & np.isfinite(rows[:, S_STROKE]))

    def crossing(self, y0: np.ndarray, y1: np.ndarray, h: float, rk4):
        """
        Return the earliest stroke end in the step y0 -> y1 as (s, wrenches), or None.

        Located on the step's RK4 map ``rk4(y0, s)`` like a release condition.
        """
        watched = self.watched()
        if not watched.size:
            return None
        stroke = self.array[self.n + watched, S_STROKE]
        reached = self.strokes(y1)[watched] >= stroke
        if not reached.any():
            return None
        best, which = h, []
        for k, limit in zip(watched[reached], stroke[reached]):
            def excess(s, k=k, limit=limit):
                return self.strokes(y0 if s == 0.0 else rk4(y0, s))[k] - limit

            if excess(0.0) >= 0.0:
                s = 0.0
            else:
                s = brentq(excess, 0.0, h, xtol=1e-15, rtol=4 * np.finfo(float).eps,
                           maxiter=200)
            if s < best - 1e-15:
                best, which = s, [int(k)]
            elif abs(s - best) <= 1e-15:
                which.append(int(k))
        return best, which

    def end_strokes(self, wrenches):
        """Switch off the wrenches whose stroke has ended."""
        for k in wrenches:
            self._off(k)

    def sources(self):
        """Return (body name, source name) of each load ``sample_applied`` writes."""
        bodies = self.model.bodies
        out = []
        for w in self.model.wrenches:
            out.append((bodies[w.body].name, w.name))
            if w.reacts_on >= 0 and bodies[w.reacts_on].dynamic:
                out.append((bodies[w.reacts_on].name, w.name))
        out.extend((bodies[a.body].name, 'aero') for a in getattr(self.model, 'aero', ()))
        return out
