# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Sway braces (SPEC section 11): one-sided preloaded pads between a body and its carrier.

A brace pushes its body at a point (body axes) along the pad's axis with
``preload + stiffness * s + damping * ds/dt``, s the pad's compression since
t = 0, while the pad touches; it never pulls. The pad is mounted on the
carrier: its face and its axis (the brace's direction at t = 0) are fixed in
the carrier's axes, s is the travel of the body's point along that axis
towards the carrier, and the pad touches only while the point lies within
its ``pad_radius`` of the axis. Its carrier takes the opposite force at the
same point. Each brace is one row of the
kernel's packed ``loads`` (``cpp/braces.hpp`` reads it): the compiled step
applies it at every RK4 stage, the step in which the push changes sign is
cut where it does (located like a release condition), and the engine
switches the pad in or out of contact there (a ``brace_contact`` event).

This module packs the rows (their columns ``LOADS.BR_*``, kind
``LOADS.KIND_BRACE``: ``cpp/layout.hpp``); ``scenario.braces`` reads the
scenario's ``sway_braces`` into ``model.SwayBrace``.
"""

from __future__ import annotations

from cfem_ros.core.engine.events import Event
from cfem_ros.core.model.loads import SwayBrace
import numpy as np

#: A pad that let go touches again only when it pushes more than this fraction of its
#: force scale (preload + stiffness * pad_radius + damping * 1 m/s): the instant it let
#: go is located to the last bits, so it cannot let go and touch again at that instant.
BAND = 1e-9


def pack(rows: np.ndarray, first: int, braces):
    """Write the braces' rows from row ``first`` on (their pads placed by ``anchor``)."""
    from cfem_ros.core.native.kernel import LOADS

    for k, brace in enumerate(braces):
        r = rows[first + k]
        r[:] = 0.0
        r[LOADS.S_KIND] = LOADS.KIND_BRACE
        r[LOADS.BR_BODY], r[LOADS.BR_CARRIER] = brace.body, brace.carrier
        r[LOADS.span('BR_POINT')] = brace.point
        r[LOADS.span('BR_DIRECTION')] = brace.direction
        r[LOADS.BR_PRELOAD], r[LOADS.BR_STIFFNESS] = brace.preload, brace.stiffness
        r[LOADS.BR_DAMPING] = brace.damping
        r[LOADS.BR_RADIUS] = brace.pad_radius
        r[LOADS.BR_BAND] = BAND * (brace.preload + brace.stiffness * brace.pad_radius
                                   + brace.damping * 1.0)


def anchor(rows: np.ndarray, first: int, braces, y: np.ndarray, n: int):
    """
    Put the braces' pads where their points are at state y, in contact (t = 0 of a run).

    The compression is measured from there: each pad's face point and its
    axis (the brace's direction now) are kept in its carrier's axes.
    """
    from cfem_ros.core import rotations
    from cfem_ros.core.engine.bodies import state_views
    from cfem_ros.core.native.kernel import LOADS

    pos, _, quat, _ = state_views(y, n)
    rot = rotations.matrices(quat / np.linalg.norm(quat, axis=1)[:, None])
    for k, brace in enumerate(braces):
        r = rows[first + k]
        b, c = brace.body, brace.carrier
        world = pos[b] + rot[b] @ brace.point
        r[LOADS.span('BR_PAD')] = rot[c].T @ (world - pos[c])
        r[LOADS.span('BR_AXIS')] = rot[c].T @ (rot[b] @ brace.direction)
        r[LOADS.BR_ON] = 1.0


def contact_event(brace: SwayBrace, contact: bool, t: float) -> dict:
    """Return a pad's event (SPEC section 11): it touches again (True) or lets go (False)."""
    return {'event': Event.BRACE_CONTACT, 'brace': brace.name, 'contact': bool(contact),
            'time': float(t)}
