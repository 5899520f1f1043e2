# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
End-of-stroke figures: the store's motion relative to the rack when an ejector stops.

MIL-STD-2088 asks for the store's CG velocity and angular rates relative to
the aircraft at the end of each ejector's stroke. A scheduled wrench with a
``stroke`` ends where its point has moved that far (located inside the
step, ``loads.py``); the event written there (SPEC section 7) gives the
loaded body's motion relative to the wrench's ``reacts_on`` body (the world
when none), in the loaded body's axes.
"""

from __future__ import annotations

from cfem_ros.core import rotations
from cfem_ros.core.engine.bodies import state_views
from cfem_ros.core.engine.events import Event
import numpy as np


def relative_motion(y: np.ndarray, n: int, body: int, reference: int):
    """
    Return a body's CG velocity and angular velocity relative to another, in its own axes.

    Parameters
    ----------
    y : ndarray, shape (13 n,)
        The state (``engine`` module docstring).
    n : int
        Number of bodies.
    body : int
        The moving body.
    reference : int
        The body it is seen from (-1: the world).

    Returns
    -------
    velocity, rates : ndarray, shape (3,)
        The CG velocity seen by an observer fixed in ``reference``
        (v - v_ref - w_ref x (p - p_ref)), m/s, and w - w_ref, rad/s; both
        in ``body``'s axes.

    """
    pos, vel, quat, rates = state_views(y, n)
    turn = rotations.matrices(quat / np.linalg.norm(quat, axis=1)[:, None])
    velocity = vel[body].copy()
    omega = turn[body] @ rates[body]
    if reference >= 0:
        omega_ref = turn[reference] @ rates[reference]
        velocity -= vel[reference] + np.cross(omega_ref, pos[body] - pos[reference])
        omega = omega - omega_ref
    return turn[body].T @ velocity, turn[body].T @ omega


def stroke_end_event(sim, k: int) -> dict:
    """
    Return the event of scheduled wrench k's stroke ending now (SPEC section 7).

    ``{"event": "stroke_end", "wrench", "body", "time", "velocity": [u, v, w],
    "rates": [p, q, r]}`` plus ``"reacts_on"`` when it has one; velocity
    (m/s) and rates (rad/s) relative to ``reacts_on`` (the world when none),
    in the loaded body's axes.
    """
    model = sim.model
    wrench = model.wrenches[k]
    velocity, rates = relative_motion(sim.y, sim.n, wrench.body, wrench.reacts_on)
    event = {'event': Event.STROKE_END, 'wrench': wrench.name,
             'body': model.bodies[wrench.body].name, 'time': sim.t,
             'velocity': [float(v) for v in velocity], 'rates': [float(v) for v in rates]}
    if wrench.reacts_on >= 0:
        event['reacts_on'] = model.bodies[wrench.reacts_on].name
    return event
