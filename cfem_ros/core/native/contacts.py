# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Collision shapes packed for the compiled distance (``cpp/distance.hpp``), and distances.

A packed shape (laid out in ``cpp/layout.hpp``, read here from the
extension: ``kernel.SHAPE``) is ``SHAPE_HEADER`` numbers (kind, size (3), the shape's
axes in its body's (row-major 3x3), its centre from the CG (body axes, m),
the hull's vertex count) and then the hull's vertices (shape axes, m).
``surface_distance`` is a point's distance to a compound shape's surface (a
sway brace's pad on its body, checked by the scenario).
A compound shape (SPEC section 11) is ``SHAPE_HEADER`` numbers (``COMPOUND``,
its part count, zeros) and then per part the radius of a sphere about the
part's centre that holds it (m) and the part packed as above.
"""

from __future__ import annotations

from cfem_ros.core import rotations
from cfem_ros.core.model.shapes import Shape
from cfem_ros.core.native import kernel
from cfem_ros.core.native.kernel import SHAPE
import numpy as np

#: Kind codes (``kernel.SHAPE``, laid out in ``cpp/layout.hpp``).
KIND_CODES = {'sphere': SHAPE.KIND_SPHERE, 'capsule': SHAPE.KIND_CAPSULE, 'box': SHAPE.KIND_BOX,
              'cylinder': SHAPE.KIND_CYLINDER, 'mesh': SHAPE.KIND_HULL}
COMPOUND = SHAPE.KIND_COMPOUND
SHAPE_HEADER = SHAPE.HEADER


def pack_shape(shape: Shape) -> np.ndarray:
    """Return a body's collision shape packed (a mesh by its hull's vertices)."""
    if shape.kind == 'compound':
        out = [np.zeros(SHAPE_HEADER)]
        out[0][SHAPE.SH_KIND], out[0][SHAPE.SH_PARTS] = COMPOUND, len(shape.parts)
        for part in shape.parts:
            packed = _pack_convex(part)
            out += [np.array([kernel.shape_reach(packed)]), packed]
        return np.concatenate(out)
    return _pack_convex(shape)


def _pack_convex(shape: Shape) -> np.ndarray:
    hull = np.asarray(shape.hull, dtype=float).reshape(-1, 3) if shape.kind == 'mesh' else ()
    if shape.kind == 'mesh' and not len(hull):
        raise ValueError(f'the mesh {shape.mesh} has no hull (not a local file)')
    out = np.zeros(SHAPE_HEADER + 3 * len(hull))
    out[SHAPE.SH_KIND] = KIND_CODES[shape.kind]
    size = shape.size if shape.kind != 'mesh' else ()
    out[SHAPE.SH_SIZE:SHAPE.SH_SIZE + len(size)] = size
    axes = rotations.matrices(np.asarray(shape.orientation_xyzw, dtype=float)[None])[0]
    out[SHAPE.span('SH_AXES')] = axes.ravel()
    out[SHAPE.span('SH_CENTRE')] = shape.offset
    out[SHAPE.SH_VERTICES] = len(hull)
    out[SHAPE_HEADER:] = np.ravel(hull)
    return out


def packed_length(flat: np.ndarray) -> int:
    """Return how many numbers the packed shape at the start of flat takes."""
    if int(flat[SHAPE.SH_KIND]) != COMPOUND:
        return SHAPE_HEADER + 3 * int(flat[SHAPE.SH_VERTICES])
    at = SHAPE_HEADER
    for _ in range(int(flat[SHAPE.SH_PARTS])):
        at += 1 + SHAPE_HEADER + 3 * int(flat[at + 1 + SHAPE.SH_VERTICES])
    return at


def bounding_radius(packed: np.ndarray) -> float:
    """Return the radius about the body's CG of a sphere holding a packed shape, m (kernel's)."""
    return kernel.bounding_radius(packed)


def distances(shape_a: np.ndarray, quat_a: np.ndarray, position_a: np.ndarray,
              shape_b: np.ndarray, quat_b: np.ndarray, position_b: np.ndarray,
              parts: bool = False):
    """
    Return the distance between two packed shapes at n pose pairs, and the closest points.

    Parameters
    ----------
    shape_a, shape_b : ndarray
        From ``pack_shape``.
    quat_a, quat_b : ndarray, shape (n, 4)
        Body-to-world orientations (x, y, z, w).
    position_a, position_b : ndarray, shape (n, 3)
        The bodies' CGs, world, m.
    parts : bool
        Also return the closest parts (below).

    Returns
    -------
    distance : ndarray, shape (n,)
        Signed, m: negative by the penetration depth when the shapes overlap
        (the shortest translation that parts them; EPA's, ``cpp/distance.hpp``).
    points : ndarray, shape (n, 6)
        The closest (or, overlapping, deepest) point on a, then on b, world, m.
    parts : ndarray of int, shape (n, 2)
        Only if ``parts``: the closest parts of a and b (0 for a convex
        shape); the distance is the least over the pairs of parts.

    """
    rot_a = rotations.matrices(np.asarray(quat_a, dtype=float)).reshape(-1, 9)
    rot_b = rotations.matrices(np.asarray(quat_b, dtype=float)).reshape(-1, 9)
    found = kernel.distance(shape_a, rot_a, position_a, shape_b, rot_b, position_b)
    return found if parts else found[:2]


def distance_at(shape_a: np.ndarray, rot_a, position_a, shape_b: np.ndarray, rot_b,
                position_b) -> float:
    """
    Return the signed distance between two packed shapes at one pose pair, m.

    ``distances`` for one pose pair given as plain numbers (a search's one
    time after another): rot_a, rot_b the body-to-world matrices, nine
    numbers row by row; position_a, position_b the CGs, world, m.
    """
    return float(kernel.distance(shape_a, [rot_a], [position_a], shape_b, [rot_b],
                                 [position_b])[0][0])


def surface_distance(pieces, point: np.ndarray) -> float:
    """
    Return a point's distance to the surface of a union of convex shapes, m (< 0 inside).

    Outside all of them: the least distance (the compiled distance to a point);
    inside: the depth below the surface of the piece it is deepest in.
    """
    dot = pack_shape(Shape('sphere', (1e-300,), offset=tuple(point)))
    identity, origin = np.array([[0.0, 0.0, 0.0, 1.0]]), np.zeros((1, 3))
    outside = []
    for piece in pieces:
        d = float(distances(dot, identity, origin, pack_shape(piece), identity, origin)[0][0])
        outside.append(d)
    if min(outside) > 0.0:
        return min(outside)
    return -max(_depth(piece, point) for piece, d in zip(pieces, outside) if d <= 0.0)


def _depth(shape, point: np.ndarray) -> float:
    """Return how deep a point lies inside a convex shape, m (its distance to the surface)."""
    axes = rotations.matrices(np.asarray(shape.orientation_xyzw, dtype=float)[None])[0]
    p = axes.T @ (np.asarray(point, dtype=float) - np.asarray(shape.offset))
    size = shape.size
    if shape.kind == 'box':
        return float(np.min(0.5 * np.asarray(size) - np.abs(p)))
    if shape.kind == 'sphere':
        return float(size[0] - np.linalg.norm(p))
    if shape.kind == 'cylinder':
        return float(min(size[0] - np.hypot(p[1], p[2]), 0.5 * size[1] - abs(p[0])))
    if shape.kind == 'capsule':
        half = 0.5 * size[1] - size[0]
        return float(size[0] - np.linalg.norm([max(abs(p[0]) - half, 0.0), p[1], p[2]]))
    from scipy.spatial import ConvexHull
    equations = ConvexHull(np.array(shape.hull)).equations   # outward normals, offsets
    return float(np.min(-(equations[:, :3] @ p + equations[:, 3])))
