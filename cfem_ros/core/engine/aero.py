# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The air each body sees, and the events of leaving a table's range (SPEC section 10).

The loads themselves are computed in the compiled step (``cpp/aero.hpp``,
``cpp/loads.cpp``), which also watches, after each step, where each body with
aerodynamic tables is on every axis a table can be left (alpha, beta, Mach
with two grid values or more, and the proximity axes): below the grid, on it
or above. A change stops the kernel's step loop like a stroke end and is
located inside the step on the step's own RK4 map (``cpp/events.cpp``).
``AeroWatch`` turns those changes into ``aero_outside`` / ``aero_inside``
events, keeps the time each body spends outside, and stops the run of a body
whose tables say ``outside: stop``.

The scenario's ``aero`` section is read by ``aeroparse``; the atmosphere is
``atmosphere`` (the kernel's).
"""

from __future__ import annotations

import math

from cfem_ros.core.engine.bodies import state_views
from cfem_ros.core.engine.events import AERO_EVENTS, Event
from cfem_ros.core.native import kernel
from cfem_ros.core.native.atmosphere import STANDARD_RANGE
from cfem_ros.core.native.kernel import LOADS, SAMPLE
import numpy as np

#: The topics of the air a body sees, under ``bodies/<body>/aero/`` (Vector3Stamped):
#: what x, y and z hold.
AIR_TOPICS = (('flow', ('alpha_deg', 'beta_deg', 'mach')),
              ('air', ('dynamic_pressure_pa', 'density_kg_m3', 'airspeed_m_s')),
              ('force_coefficients', ('CX', 'CY', 'CZ')),
              ('moment_coefficients', ('Cl', 'Cm', 'Cn')))
#: Numbers a sample holds per body with aero tables (``cpp/layout.hpp``).
AIR_OUTPUTS = SAMPLE.AIR
#: Slots of the axes a body can leave: alpha, beta, Mach, the proximity axes.
SLOTS = LOADS.AERO_SLOTS
#: How close to a grid's end a value located at a crossing is (relative to 1 + |end|).
AT_END = 1e-9
#: The slots of the flow angles (alpha, beta): undefined at zero airspeed.
ANGLES = (0, 1)


def axis_names(aero) -> list:
    """Return the names of an aero entry's slots (the scenario's keys), '' for none."""
    names = ['alpha_deg', 'beta_deg', 'mach']
    if aero.proximity is not None:
        names += [f'proximity.{a}' for a in aero.proximity.axes]
    return names + [''] * (SLOTS - len(names))


def _in_units(name: str, value: float) -> float:
    """Return a slot's value (rad for angles) in the unit of its name (deg for ``_deg``)."""
    return math.degrees(value) if name.endswith('_deg') else float(value)


class AeroWatch:
    """
    Where each body with aero tables is on its tables' axes; the events of leaving them.

    Parameters
    ----------
    model : Model
    loads : ndarray
        The simulator's packed loads (``loads.ScheduledLoads.array``); the
        bodies' places are kept in its aero rows (``A_STATUS`` columns).
    first : int
        The first aero row.

    """

    def __init__(self, model, loads: np.ndarray, first: int):
        self.model = model
        self.loads = loads
        self.first = first
        self.n = len(model.bodies)
        self.names = [axis_names(a) for a in model.aero]
        self._outside = [0] * len(model.aero)      # slots outside, per entry
        # per entry, the angle slots whose place was taken at zero airspeed: not outside
        self._undefined = [set() for _ in model.aero]
        self.stop_message = ''
        gravity = np.asarray(model.gravity, dtype=float)
        norm = float(np.linalg.norm(gravity))
        self._up = -gravity / norm if norm > 0.0 else np.zeros(3)
        # per entry with an atmosphere: when its body's altitude was last looked at, and the
        # altitude (m) and its rate (m/s) then (None: an entry with a density has none)
        self._seen = [None] * len(model.aero)
        self._isa = [k for k, a in enumerate(model.aero) if a.altitude is not None]

    def _axes(self, k: int, y: np.ndarray) -> np.ndarray:
        out = np.empty((4, SLOTS))
        kernel.loads_aero_axes(np.ascontiguousarray(y), self.loads, self.n, self.first + k,
                               out)
        return out   # values, status, low, high

    def _status(self, k: int) -> np.ndarray:
        return self.loads[self.first + k, LOADS.span('A_STATUS')]

    def _still(self, k: int, y: np.ndarray) -> bool:
        """Tell whether entry k's body is at rest in the air at y (its angles undefined)."""
        aero = self.model.aero[k]
        velocity = state_views(y, self.n)[1][aero.body]
        return not np.any(velocity - np.asarray(aero.freestream, dtype=float))

    def arm(self, y: np.ndarray, t: float) -> list:
        """
        Take where each body is at y (time t) as known; return events for axes outside.

        A body at rest in the air has no alpha or beta (the kernel takes them
        as 0): their place is kept, so that the step does not find it again,
        but it is not outside; the body's first motion through the air tells.
        """
        events = []
        for k in range(len(self.model.aero)):
            self._status(k)[:] = 0.0
            self._outside[k] = 0
            self._undefined[k].clear()
            values, status, low, high = self._axes(k, y)
            still = self._still(k, y)
            for slot in np.flatnonzero(status):
                if still and slot in ANGLES:
                    self._status(k)[slot] = status[slot]
                    self._undefined[k].add(int(slot))
                    continue
                events += self._change(k, slot, status[slot], values, low, high, t)
        self._seen = [None] * len(self.model.aero)
        return events + self.atmosphere(y, t)

    def crossed(self, k: int, y: np.ndarray, y_end: np.ndarray, t: float) -> list:
        """
        Return the events of entry k's crossing located at y (time t).

        The axes that changed are those on which the body is elsewhere at the
        step's end y_end than it was, and whose value at y is at its grid's
        end (the others cross later in the step and are located then). A
        value that jumped past the end instead is an angle at zero airspeed
        (alpha and beta are undefined there, taken as 0 until the body moves
        through the air): its event names the value it jumped to, the one at
        y_end, never the 0 inside the table.
        """
        values, _, low, high = self._axes(k, y)
        after, target, _, _ = self._axes(k, y_end)
        was = self._status(k).copy()
        changed = np.flatnonzero(target != was)
        ends = np.where(was == 0, np.where(target > 0, high, low), np.where(was > 0, high, low))
        excess = np.where(was == 0, np.where(target > 0, values - high, low - values),
                          np.where(was > 0, high - values, values - low))
        at_end = [s for s in changed if excess[s] >= -AT_END * (1.0 + abs(ends[s]))]
        if not at_end and changed.size:
            at_end = [changed[np.argmax(excess[changed])]]
            values = np.where(np.arange(SLOTS) == at_end[0], after, values)   # it jumped
        events = []
        for slot in at_end:
            events += self._change(k, slot, target[slot], values, low, high, t)
        return events

    def _change(self, k, slot, status, values, low, high, t) -> list:
        """Record entry k's slot now at status (-1, 0, 1); return its events."""
        aero = self.model.aero[k]
        name = self.names[k][slot]
        body = self.model.bodies[aero.body].name
        was = int(self._status(k)[slot])
        if slot in self._undefined[k]:   # taken at rest in the air: it was never outside
            self._undefined[k].discard(slot)
            was = 0
        self._status(k)[slot] = float(status)
        figures = {'body': body, 'axis': name, 'value': _in_units(name, values[slot]),
                   'low': _in_units(name, low[slot]), 'high': _in_units(name, high[slot]),
                   'time': float(t)}
        events = []
        if was != 0:
            self._outside[k] -= 1
            events.append({'event': Event.AERO_INSIDE, **figures})
        if status != 0:
            self._outside[k] += 1
            events.append({'event': Event.AERO_OUTSIDE, **figures})
            if aero.stop_outside and not self.stop_message:
                self.stop_message = (
                    f'at t = {t:.9g} s: {body} left its aerodynamic tables: {name} = '
                    f'{figures["value"]:.6g} outside [{figures["low"]:.6g}, '
                    f'{figures["high"]:.6g}] (aero.{body}.outside: stop)')
        return events

    def atmosphere(self, y: np.ndarray, t: float) -> list:
        """
        Return the events of bodies leaving the standard atmosphere by t (or coming back).

        Looked at where the simulator stops (samples, events): between the
        last look (``inside_at``, or ``outside_at``) and this one
        (``seen_at``) the altitude is the cubic Hermite of the altitude and
        its rate at both, exact for a fall at constant acceleration, and
        each of its crossings of the standard's ends is an event at its
        ``time`` (so a body that leaves and comes back between two looks is
        told too). Beyond, the kernel continues a layer the standard does
        not have: the event says so.
        """
        events = []
        if not self._isa:
            return events
        positions, velocities = state_views(y, self.n)[:2]
        for k in self._isa:
            aero = self.model.aero[k]
            now = (float(t), aero.altitude + float(self._up @ positions[aero.body]),
                   float(self._up @ velocities[aero.body]))
            before, self._seen[k] = self._seen[k], now
            if before is None:   # the first look: beyond already, at once
                if not STANDARD_RANGE[0] <= now[1] <= STANDARD_RANGE[1]:
                    level = STANDARD_RANGE[1] if now[1] > STANDARD_RANGE[1] else STANDARD_RANGE[0]
                    events.append(self._atmosphere_event(k, True, level, now[0], now[0],
                                                         now[0]))
                continue
            for time, level, leaving in _hermite_crossings(before, now):
                events.append(self._atmosphere_event(k, leaving, level, time, before[0],
                                                     now[0]))
        return events

    def _atmosphere_event(self, k: int, leaving: bool, level: float, time: float,
                          looked: float, seen: float) -> dict:
        return {'event': Event.ATMOSPHERE_OUTSIDE if leaving else Event.ATMOSPHERE_INSIDE,
                'body': self.model.bodies[self.model.aero[k].body].name, 'altitude': level,
                'low': STANDARD_RANGE[0], 'high': STANDARD_RANGE[1], 'time': time,
                'inside_at' if leaving else 'outside_at': looked, 'seen_at': seen}


def _hermite_crossings(start: tuple, end: tuple) -> list:
    """
    Return (time, level, leaving) of the standard's ends crossed between two looks.

    start, end: (t s, altitude m, its rate m/s). The altitude between is the
    cubic Hermite of the two; a touch without crossing is none.
    """
    (t0, h0, d0), (t1, h1, d1) = start, end
    span = t1 - t0
    if not span > 0.0:
        return []
    # the cubic lies within the ends' range widened by span (|d0| + |d1|) 4/27 (the largest
    # of the rate basis functions): inside the standard with it, no crossing (the usual case)
    reach = span * (abs(d0) + abs(d1)) * 4.0 / 27.0
    if STANDARD_RANGE[0] < min(h0, h1) - reach and max(h0, h1) + reach < STANDARD_RANGE[1]:
        return []
    # h(s) for s in [0, 1] on the Hermite basis, the rates scaled by the span
    a = 2 * h0 - 2 * h1 + span * (d0 + d1)
    b = -3 * h0 + 3 * h1 - span * (2 * d0 + d1)
    c = span * d0
    out = []
    for level in STANDARD_RANGE:
        for r in np.roots(np.trim_zeros([a, b, c, h0 - level], 'f')):
            if abs(r.imag) > 1e-12 or not 0.0 < r.real <= 1.0:
                continue
            s = float(r.real)
            slope = (3 * a * s + 2 * b) * s + c
            if slope == 0.0:
                continue
            up = slope > 0.0
            out.append((t0 + span * s, level, up == (level == STANDARD_RANGE[1])))
    return sorted(out)


def outside_spans(events, body: str, t_end: float) -> list:
    """
    Return the (start, end) spans, s, in which a body was outside its tables' ranges.

    From its ``aero_outside`` / ``aero_inside`` events (in time order): the
    body is outside while any axis is; a span still open ends at t_end.
    """
    spans, outside, since = [], 0, 0.0
    for event in events:
        if event.get('body') != body or event.get('event') not in AERO_EVENTS:
            continue
        if event['event'] == Event.AERO_OUTSIDE:
            since = event['time'] if outside == 0 else since
            outside += 1
        elif outside > 0:
            outside -= 1
            if outside == 0:
                spans.append((since, event['time']))
    if outside > 0:
        spans.append((since, t_end))
    return spans


def seconds_outside(events, body: str, t_end: float) -> float:
    """Return the time a body spent outside its tables' ranges up to t_end, s."""
    return float(sum(end - start for start, end in outside_spans(events, body, t_end)))
