# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Aerodynamic tables packed into flat arrays for the compiled step (``cpp/aero.hpp``).

One float64 array per body with an ``aero`` entry: a header laid out by the
extension (``kernel.AERO_TABLE``, ``cpp/layout.hpp``), then the alpha (rad),
beta (rad) and Mach grids, the free-stream coefficients (CX, CY, CZ, Cl, Cm,
Cn per node, alpha slowest, then beta, then Mach), then the proximity grids
(angles in rad) and increments (dCX .. dCn per node, the first axis slowest).
"""

from __future__ import annotations

from cfem_ros.core import rotations
from cfem_ros.core.model.loads import Aero
from cfem_ros.core.model.model import Model
from cfem_ros.core.native.kernel import AERO_TABLE as T
import numpy as np

#: Numbers of the header.
HEADER = T.WIDTH
#: Proximity axis codes, by the table's column names.
AXIS_CODES = {'dx': T.AXIS_DX, 'dy': T.AXIS_DY, 'dz': T.AXIS_DZ, 'dphi_deg': T.AXIS_DPHI,
              'dtheta_deg': T.AXIS_DTHETA, 'dpsi_deg': T.AXIS_DPSI, 'mach': T.AXIS_MACH}


def pack(aero: Aero, model: Model) -> np.ndarray:
    """
    Return one body's aerodynamic table, packed (shape (TOTAL,)).

    The body's CG in the carrier's axes at t = 0 (the origin of ``dx, dy,
    dz``) is taken from the model's initial poses.
    """
    head = np.zeros(HEADER)
    head[T.AREA], head[T.LENGTH] = aero.area, aero.length
    head[T.DENSITY] = aero.density if aero.altitude is None else 0.0
    head[T.ALTITUDE] = 0.0 if aero.altitude is None else aero.altitude
    head[T.span('WIND')] = aero.freestream
    head[T.span('DAMPING')] = aero.damping
    head[T.TEMPERATURE_OFFSET] = aero.temperature_offset
    head[T.span('REFERENCE')] = aero.reference_from_cg
    head[T.span('DELTA')] = aero.delta
    gravity = np.asarray(model.gravity, dtype=float)
    norm = float(np.linalg.norm(gravity))
    head[T.span('UP')] = -gravity / norm if norm > 0.0 else 0.0
    head[T.NA], head[T.NB], head[T.NM] = len(aero.alpha), len(aero.beta), len(aero.mach)
    head[T.BODY], head[T.CARRIER] = aero.body, -1
    parts = [head, aero.alpha, aero.beta, aero.mach, aero.coefficients.reshape(-1)]
    prox = aero.proximity
    if prox is not None:
        head[T.CARRIER] = prox.carrier
        head[T.PROX_AXES] = len(prox.axes)
        head[T.FADE] = 0.0 if prox.fade is None else prox.fade
        head[T.span('START')] = start_in_carrier(model, aero.body, prox.carrier)
        for k, (axis, grid) in enumerate(zip(prox.axes, prox.grids)):
            head[T.PROX_CODE + k] = AXIS_CODES[axis]
            head[T.PROX_SIZE + k] = len(grid)
            parts.append(np.radians(grid) if axis.endswith('_deg') else np.asarray(grid))
        parts.append(prox.increments.reshape(-1))
    packed = np.concatenate([np.asarray(part, dtype=float).reshape(-1) for part in parts])
    packed[T.TOTAL] = len(packed)
    return packed


def start_in_carrier(model: Model, body: int, carrier: int) -> np.ndarray:
    """Return a body's initial CG in the carrier's initial axes, from its CG, m."""
    b, c = model.bodies[body], model.bodies[carrier]
    rot = rotations.matrices(np.asarray(c.orientation_xyzw, dtype=float)[None])[0]
    return rot.T @ (np.asarray(b.position, dtype=float) - np.asarray(c.position, dtype=float))
