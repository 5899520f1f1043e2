# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A body's CG away from its nominal place (``cg_offset``, SPEC section 10).

The scenario gives the nominal CG (``position``) and, optionally, where the
CG actually is relative to it, in body axes. The simulation's body frame is
at the actual CG, so the body's initial CG moves by the offset (turned into
world axes by its initial attitude), and everything given in the body's axes
"from the CG" stays on the geometry: it is measured from the nominal CG, so
from the actual CG it is that point less the offset. Joint anchors are given
in world axes and stay where they are; mass and inertia are about the actual
CG, as given.
"""

from __future__ import annotations

from dataclasses import replace

from cfem_ros.core import rotations
import numpy as np


def moved(body, cg_offset) -> object:
    """Return the body with its CG moved by cg_offset (body axes, m), its shape kept in place."""
    offset = np.asarray(cg_offset, dtype=float)
    if not offset.any():
        return body
    turn = rotations.matrices(np.asarray(body.orientation_xyzw, dtype=float)[None])[0]
    shape = None if body.shape is None else _shifted(body.shape, offset)
    return replace(body, position=np.asarray(body.position, dtype=float) + turn @ offset,
                   shape=shape, cg_offset=offset)


def _shifted(shape, offset: np.ndarray):
    """Return a shape placed from the actual CG (a compound: each of its parts)."""
    if shape.parts:
        return replace(shape, parts=tuple(_shifted(part, offset) for part in shape.parts))
    return replace(shape, offset=tuple(float(v) for v in np.asarray(shape.offset) - offset))


def from_cg(body, point) -> np.ndarray:
    """Return a point given from the nominal CG (body axes, m) from the actual CG."""
    return np.asarray(point, dtype=float) - np.asarray(body.cg_offset, dtype=float)
