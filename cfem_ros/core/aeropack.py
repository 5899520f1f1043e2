# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Aerodynamic tables packed into flat arrays for the compiled step (``cpp/aero.hpp``).

One float64 array per body with an ``aero`` entry: a header of ``HEADER``
numbers at the offsets below (the same as ``cfem::aero::k*``), then the
alpha (rad), beta (rad) and Mach grids, the free-stream coefficients (CX,
CY, CZ, Cl, Cm, Cn per node, alpha slowest, then beta, then Mach), then
the proximity grids (angles in rad) and increments (dCX .. dCn per node,
the first axis slowest).
"""

from __future__ import annotations

from cfem_ros.core import rotations
from cfem_ros.core.model import Aero, Model
import numpy as np

AREA, LENGTH, DENSITY, ALTITUDE, WIND, DAMPING, UP = 0, 1, 2, 3, 4, 7, 10
NA, NB, NM, PROX_AXES, FADE, START = 13, 14, 15, 16, 17, 18
PROX_CODE, PROX_SIZE, TOTAL = 21, 28, 35
BODY, CARRIER = 36, 37
HEADER = 48
#: Proximity axis codes (``cfem::aero::kDx`` ..), by the table's column names.
AXIS_CODES = {'dx': 0, 'dy': 1, 'dz': 2, 'dphi_deg': 3, 'dtheta_deg': 4, 'dpsi_deg': 5,
              'mach': 6}


def pack(aero: Aero, model: Model) -> np.ndarray:
    """
    Return one body's aerodynamic table, packed (shape (TOTAL,)).

    The body's CG in the carrier's axes at t = 0 (the origin of ``dx, dy,
    dz``) is taken from the model's initial poses.
    """
    head = np.zeros(HEADER)
    head[AREA], head[LENGTH] = aero.area, aero.length
    head[DENSITY] = aero.density if aero.altitude is None else 0.0
    head[ALTITUDE] = 0.0 if aero.altitude is None else aero.altitude
    head[WIND:WIND + 3] = aero.freestream
    head[DAMPING:DAMPING + 3] = aero.damping
    gravity = np.asarray(model.gravity, dtype=float)
    norm = float(np.linalg.norm(gravity))
    head[UP:UP + 3] = -gravity / norm if norm > 0.0 else 0.0
    head[NA], head[NB], head[NM] = len(aero.alpha), len(aero.beta), len(aero.mach)
    head[BODY], head[CARRIER] = aero.body, -1
    parts = [head, aero.alpha, aero.beta, aero.mach, aero.coefficients.reshape(-1)]
    prox = aero.proximity
    if prox is not None:
        head[CARRIER] = prox.carrier
        head[PROX_AXES] = len(prox.axes)
        head[FADE] = 0.0 if prox.fade is None else prox.fade
        head[START:START + 3] = start_in_carrier(model, aero.body, prox.carrier)
        for k, (axis, grid) in enumerate(zip(prox.axes, prox.grids)):
            head[PROX_CODE + k] = AXIS_CODES[axis]
            head[PROX_SIZE + k] = len(grid)
            parts.append(np.radians(grid) if axis.endswith('_deg') else np.asarray(grid))
        parts.append(prox.increments.reshape(-1))
    packed = np.concatenate([np.asarray(part, dtype=float).reshape(-1) for part in parts])
    packed[TOTAL] = len(packed)
    return packed


def start_in_carrier(model: Model, body: int, carrier: int) -> np.ndarray:
    """Return a body's initial CG in the carrier's initial axes, from its CG, m."""
    b, c = model.bodies[body], model.bodies[carrier]
    rot = rotations.matrices(np.asarray(c.orientation_xyzw, dtype=float)[None])[0]
    return rot.T @ (np.asarray(b.position, dtype=float) - np.asarray(c.position, dtype=float))
