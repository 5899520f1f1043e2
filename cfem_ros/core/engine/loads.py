# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Applied loads: held wrenches at points, scheduled wrenches, ejector strokes.

Every load the kernel applies lives in one packed array, the kernel's
``loads`` (rows of ``LOADS.WIDTH`` numbers), so that the compiled step needs no
Python call and no new argument:

- rows 0 .. n-1, one per body, the wrench held from topics or inputs:
  force (3), torque (3), 1.0 if in body axes, application point (3, body
  axes, from the CG; the moment about the CG gains r x F);
- then one row per scheduled wrench (``S_*`` columns, ``KIND_SCHEDULED``);
- then one row per body with aerodynamic tables (``A_*``, ``KIND_AERO``);
- then one row per watched contact pair (``C_*``, ``KIND_CONTACT``;
  ``S_ON`` = 1.0 while armed: its shapes apart);
- then one row per sway brace (``KIND_BRACE``, ``BR_*`` columns; ``BR_ON``
  1.0 while its pad touches; ``braces.py``);
- then the rows of their tables (``KIND_TABLE``): abscissa (time, s, or
  stroke, m) then force (3) and moment (3) (``T_*``); or an aerodynamic
  table packed by ``aeropack.pack`` or a shape by ``contacts.pack_shape``,
  ``AERO_ROW`` numbers a row;
- then, if there is any row after the bodies', one scratch row (``KIND_SCRATCH``).
Each row keeps its kind in its last column, ``S_KIND``.

A scheduled wrench acts on its body at its point while it is on: its time
window cuts the steps like a release time (the engine switches it), and the
end of its stroke is watched after each step and located inside the step on
the step's own RK4 map by the kernel, like a release condition. Its opposite acts on
``reacts_on`` at the same world point. Stage times (for tables against
time) are written by the kernel's RK4 into the scheduled rows.

The columns are the extension's (``kernel.LOADS``, laid out in
``cpp/layout.hpp``); the compiled step reads these rows in ``cpp/loads.cpp``.
A new load kind: its columns in ``cpp/layout.hpp``, its rows here, its
branch there.
"""

from __future__ import annotations

from cfem_ros.core.engine import aeropack, braces
from cfem_ros.core.engine.bodies import state_views
from cfem_ros.core.engine.ties import Ties
from cfem_ros.core.native import contacts, kernel
from cfem_ros.core.native.kernel import LOADS, SAMPLE
import numpy as np

#: Numbers of a packed aerodynamic table or shape a row holds (the last column is S_KIND).
AERO_ROW = LOADS.AERO_ROW
#: Shapes this close touch, m.
CONTACT_GAP = LOADS.CONTACT_GAP
#: A scheduled row's table: none, against time, against stroke.
TABLES = {None: LOADS.TABLE_NONE, 'time': LOADS.TABLE_TIME, 'stroke': LOADS.TABLE_STROKE}


# ------------------------------------------------------------- Python part

def _put_packed(rows: np.ndarray, first: int, table: np.ndarray) -> int:
    """Write a packed table into rows from first on, AERO_ROW numbers a row; return the next."""
    count = -(-len(table) // AERO_ROW)
    block = np.zeros(count * AERO_ROW)
    block[:len(table)] = table
    rows[first:first + count, :AERO_ROW] = block.reshape(count, AERO_ROW)
    rows[first:first + count, LOADS.S_KIND] = LOADS.KIND_TABLE
    return first + count


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
    array : ndarray, shape (n + rows, LOADS.WIDTH)
        The packed loads (the held rows first, zero).
    started, done : ndarray of bool
        Per wrench: switched on once; switched off for good.
    start, end : ndarray, shape (count,)
        Per wrench: when it switches on and off, s; inf while it waits for
        the release it is tied to (``released``), or for no end.

    """

    def __init__(self, model, n: int):
        self.model = model
        self.n = n
        wrenches = getattr(model, 'wrenches', ())
        aero = getattr(model, 'aero', ())
        self.count = len(wrenches)
        pairs = getattr(model, 'contacts', ())
        packed = [aeropack.pack(a, model) for a in aero]
        shapes = {b: contacts.pack_shape(model.bodies[b].shape)
                  for pair in pairs for b in pair.bodies}
        packed_rows = [-(-len(p) // AERO_ROW) for p in packed + list(shapes.values())]
        tables = sum(len(w.table) for w in wrenches) + sum(packed_rows)
        self.braces = getattr(model, 'braces', ())
        scratch = 1 if self.count or aero or pairs or self.braces else 0
        #: Where the contact rows start, and the braces' rows, counted from row n.
        self.contact_first = self.count + len(aero)
        self.brace_first = self.contact_first + len(pairs)
        rows = np.zeros((n + self.brace_first + len(self.braces) + tables + scratch,
                         LOADS.WIDTH))
        if scratch:
            rows[-1, LOADS.S_KIND] = LOADS.KIND_SCRATCH
        braces.pack(rows, n + self.brace_first, self.braces)
        nxt = n + self.brace_first + len(self.braces)
        for k, w in enumerate(wrenches):
            r = rows[n + k]
            r[LOADS.S_KIND] = LOADS.KIND_SCHEDULED
            r[LOADS.S_BODY], r[LOADS.S_REACT], r[LOADS.S_FRAME] = w.body, w.reacts_on, w.frame
            r[LOADS.span('S_POINT')] = w.point
            r[LOADS.span('S_FORCE')] = w.force
            r[LOADS.span('S_MOMENT')] = w.moment
            r[LOADS.S_STROKE] = np.inf if w.stroke is None else w.stroke
            r[LOADS.S_START] = w.start
            r[LOADS.S_TABLE] = TABLES[w.table_against]
            if len(w.table):
                r[LOADS.S_FIRST], r[LOADS.S_COUNT] = nxt, len(w.table)
                data, table = np.asarray(w.table, dtype=float), rows[nxt:nxt + len(w.table)]
                table[:, LOADS.T_ABSCISSA] = data[:, 0]
                table[:, LOADS.span('T_FORCE')] = data[:, 1:4]
                table[:, LOADS.span('T_MOMENT')] = data[:, 4:7]
                table[:, LOADS.S_KIND] = LOADS.KIND_TABLE
                nxt += len(w.table)
        for k, (a, table) in enumerate(zip(aero, packed)):
            r = rows[n + self.count + k]
            r[LOADS.S_KIND] = LOADS.KIND_AERO
            r[LOADS.A_BODY], r[LOADS.A_FIRST] = a.body, nxt
            r[LOADS.A_CARRIER] = -1 if a.proximity is None else a.proximity.carrier
            nxt = _put_packed(rows, nxt, table)
        first_row = {}
        for b, shape in shapes.items():
            first_row[b] = nxt
            nxt = _put_packed(rows, nxt, shape)
        for k, pair in enumerate(pairs):
            r = rows[n + self.contact_first + k]
            r[LOADS.S_KIND] = LOADS.KIND_CONTACT
            r[LOADS.C_A], r[LOADS.C_B] = pair.bodies
            a, b = pair.bodies
            r[LOADS.C_SHAPE_A], r[LOADS.C_SHAPE_B] = first_row[a], first_row[b]
            r[LOADS.C_RADIUS_A], r[LOADS.C_RADIUS_B] = (contacts.bounding_radius(shapes[a]),
                                                        contacts.bounding_radius(shapes[b]))
        self.array = rows
        self.pairs = pairs
        self.started = np.zeros(self.count, dtype=bool)
        self.done = np.zeros(self.count, dtype=bool)
        #: Which starts and ends wait for a release (``ties.Ties``), and per wrench when it
        #: switches on and off, s: inf while it waits for that release, or for no end.
        self.ties = Ties(model)
        self.start, self.end = self.ties.times()
        #: Numbers a sample's applied loads take (6 a source), then the air of each body
        #: with aero tables (``SAMPLE.AIR`` each: ``cpp/loads.cpp`` sample_applied).
        self.outputs_size = SAMPLE.WRENCH * len(self.sources()) + SAMPLE.AIR * len(aero)

    def set_time(self, t: float):
        """Write the current time into the scheduled rows."""
        if self.array.shape[0] > self.n:
            kernel.loads_set_time(self.array, int(self.n), float(t))

    def due(self, t: float):
        """Return the next time after t at which a wrench switches, or None."""
        times = []
        for k in range(self.count):
            if self.done[k]:
                continue
            if not self.started[k] and t < self.start[k] < np.inf:
                times.append(self.start[k])
            elif self.started[k] and t < self.end[k] < np.inf:
                times.append(self.end[k])
        return float(min(times)) if times else None

    def switch(self, t: float, y: np.ndarray) -> bool:
        """Switch the wrenches whose start or end is t or earlier; True if any did."""
        changed = False
        for k in range(self.count):
            if self.done[k]:
                continue
            if not self.started[k] and self.end[k] <= t:
                self.done[k] = True   # its end came first (a release): it never starts
                continue
            if not self.started[k] and self.start[k] <= t:
                self.started[k] = True
                self._anchor(k, y)
                self.array[self.n + k, LOADS.S_START] = self.start[k]   # tables against time
                self.array[self.n + k, LOADS.S_ON] = 1.0
                changed = True
            if self.started[k] and self.end[k] <= t:
                self._off(k)
                changed = True
        return changed

    def released(self, joints, t: float) -> bool:
        """
        Time the wrenches tied to the release of ``joints`` at t (``ties.Ties``).

        Returns True if any is now due at t (the caller then calls ``switch``).
        """
        return self.ties.released(joints, t, self.start, self.end)

    def reanchor(self, y: np.ndarray):
        """Measure the strokes of the wrenches already on from state y (a new initial state)."""
        for k in np.flatnonzero(self.started & ~self.done):
            self._anchor(k, y)

    def _off(self, k):
        self.done[k] = True
        self.array[self.n + k, LOADS.S_ON] = 0.0

    def _anchor(self, k, y):
        """Record where the point is at the start (in world, or in reacts_on's axes)."""
        n = self.n
        row = self.array[n + k]
        rot = np.empty((n, 3, 3))
        kernel.loads_rotations(np.ascontiguousarray(y), int(n), rot)
        pos = state_views(y, n)[0]
        b = int(row[LOADS.S_BODY])
        point = pos[b] + rot[b] @ row[LOADS.span('S_POINT')]
        j = int(row[LOADS.S_REACT])
        if j >= 0:
            point = rot[j].T @ (point - pos[j])
        row[LOADS.span('S_ANCHOR')] = point

    def arm(self, y: np.ndarray):
        """
        Start at y: the braces' pads in contact there, and the contact pairs watched.

        A pair is watched if its shapes are apart at y, else once they part.
        """
        braces.anchor(self.array, self.n + self.brace_first, self.braces, y, self.n)
        for k in range(len(self.pairs)):
            row = self.n + self.contact_first + k
            self.array[row, LOADS.S_ON] = 1.0 if self.gap(k, y)[0] > CONTACT_GAP else 0.0

    def gap(self, k: int, y: np.ndarray):
        """
        Return contact pair k's shape distance at y (m), closest points (world, 6) and parts.

        The parts: the indices of the closest parts of each body's shape (0 for a
        convex shape, SPEC section 11).
        """
        n = self.n
        a, b = self.pairs[k].bodies
        pos, _, quat, _ = state_views(y, n)
        row = self.array[n + self.contact_first + k]
        shape_a = _unpack(self.array, int(row[LOADS.C_SHAPE_A]))
        shape_b = _unpack(self.array, int(row[LOADS.C_SHAPE_B]))
        d, points, parts = contacts.distances(shape_a, quat[a:a + 1], pos[a:a + 1], shape_b,
                                              quat[b:b + 1], pos[b:b + 1], parts=True)
        return float(d[0]), points[0], [int(v) for v in parts[0]]

    def touched(self, k: int):
        """Stop watching contact pair k until its shapes part again."""
        self.array[self.n + self.contact_first + k, LOADS.S_ON] = 0.0

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
        for brace in self.braces:
            out.append((bodies[brace.body].name, brace.name))
            if bodies[brace.carrier].dynamic:
                out.append((bodies[brace.carrier].name, brace.name))
        return out

    def switch_brace(self, k: int) -> bool:
        """Switch brace k's pad in or out of contact (its push changed sign now); return it."""
        row = self.array[self.n + self.brace_first + k]
        row[LOADS.BR_ON] = 0.0 if row[LOADS.BR_ON] > 0.0 else 1.0
        return bool(row[LOADS.BR_ON] > 0.0)


def _unpack(rows: np.ndarray, first: int) -> np.ndarray:
    """Return the packed shape kept from row first on (its length is in its header)."""
    flat = rows[first:, :AERO_ROW].reshape(-1)
    return flat[:contacts.packed_length(flat)].copy()
