# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What a run watches besides its joints: sway braces' pads, contact pairs, aero tables' ranges.

``Watch`` is the part of ``Simulator`` that arms them at a state (the
start, or a state set: ``Simulator.set_state``) and turns what a located
step found of them into events, and into the stop of the run where a
contact pair (``on_contact: stop``) or a table (``outside: stop``) says so.
Ejector strokes, also located in the step, are the applied loads'
(``ScheduledLoads.end_strokes``, ``strokes.stroke_end_event``).
"""

from __future__ import annotations

from cfem_ros.core.engine import braces
from cfem_ros.core.engine.aero import AeroWatch
from cfem_ros.core.engine.events import Event, Status
from cfem_ros.core.native.kernel import CLOSEST
import numpy as np


class Watch:
    """
    The braces, contact pairs and aero tables a run watches, as the kernel packs them.

    Parameters
    ----------
    model : Model
        The run's model.
    scheduled : ScheduledLoads
        The applied loads, whose packed rows hold the braces, the contact
        pairs and the aero entries (``loads``).
    n : int
        Bodies.

    Attributes
    ----------
    aero : AeroWatch
        Where each body is on its aero tables' axes.

    """

    def __init__(self, model, scheduled, n: int):
        self.model, self.scheduled = model, scheduled
        self.aero = AeroWatch(model, scheduled.array, n + scheduled.count)

    def arm(self, y: np.ndarray, t: float) -> tuple:
        """
        Watch from state y at time t: pads in contact and pairs apart there, the tables' axes.

        Returns (events, stops) as ``located`` does: an aero axis outside at
        y is an event now.
        """
        self.scheduled.arm(y)
        return self.aero_events(self.aero.arm(y, t))

    def aero_events(self, events: list) -> tuple:
        """Return (events, stops) of aero_outside / aero_inside events (a table may stop)."""
        stop = self.aero.stop_message
        return events, [(Status.AERO_OUTSIDE, stop)] if stop else []

    def located(self, rows, y: np.ndarray, y_end: np.ndarray, t: float) -> tuple:
        """
        Return (events, stops) of the watched rows a located step ended on, at state y, time t.

        rows: the packed rows found (``kernelcalls.locate``) past the
        scheduled wrenches (the strokes, the caller's); y_end the step's
        end had it not been cut (an aero table's crossing is found between
        them). stops: (status, message) of each watch that says to stop the
        run, in order; the first applies.
        """
        events, stops = [], []
        first, count = self.scheduled.contact_first, self.scheduled.count
        first_brace = self.scheduled.brace_first
        for k in rows:
            if k >= first_brace:   # a pad's push changed sign
                contact = self.scheduled.switch_brace(k - first_brace)
                events.append(braces.contact_event(self.model.braces[k - first_brace],
                                                   contact, t))
            elif k >= first:
                event, stop = self._contact(k - first, y, t)
                events.append(event)
                stops += stop
            elif k >= count:   # a body left (or came back to) an aero table's range
                more, stop = self.aero_events(self.aero.crossed(k - count, y, y_end, t))
                events += more
                stops += stop
        return events, stops

    def _contact(self, k: int, y: np.ndarray, t: float) -> tuple:
        """Return contact pair k's first touch at y, t, and its stop if the pair says so."""
        pair = self.model.contacts[k]
        names = [self.model.bodies[b].name for b in pair.bodies]
        _, points, parts = self.scheduled.gap(k, y)
        point = [float(v) for v in 0.5 * (points[CLOSEST.span('P_A')]
                                          + points[CLOSEST.span('P_B')])]
        event = {'event': Event.CONTACT, 'bodies': names, 'time': t, 'point': point,
                 'parts': parts}
        self.scheduled.touched(k)   # watched again once the shapes part
        if not pair.stop:
            return event, []
        where = f'[{point[0]:.6g}, {point[1]:.6g}, {point[2]:.6g}] (world, m)'
        return event, [(Status.CONTACT, f'at t = {t:.9g} s: {names[0]} touches {names[1]} at '
                                        f'{where}')]
