# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Body shapes as 2D outlines in another body's axes (the snapshots of SPEC section 12).

A shape (``core.model.shapes.Shape``: box, cylinder, sphere, capsule, a mesh by
its convex hull, or a compound shape's ``parts``, each placed in the body's
axes) becomes points on its surface in the body's axes; placed at a pose
relative to the reference and projected on a view plane, each convex
part's outline is the convex hull of its projected points (exact for a box
and a mesh hull, to ``CIRCLE_POINTS`` for round shapes).
"""

from __future__ import annotations

from cfem_ros.core import rotations
import numpy as np

#: Points on a circle of a round shape.
CIRCLE_POINTS = 72
#: View name -> (horizontal axis, vertical axis) of the reference's axes.
VIEWS = {'side': (0, 2), 'top': (0, 1), 'front': (1, 2)}


def _circle(radius: float, x: float) -> np.ndarray:
    angle = np.linspace(0.0, 2.0 * np.pi, CIRCLE_POINTS, endpoint=False)
    return np.column_stack([np.full(CIRCLE_POINTS, x), radius * np.cos(angle),
                            radius * np.sin(angle)])


def _sphere(radius: float, center_x: float = 0.0) -> np.ndarray:
    """Points on a sphere: circles about x, y and z (its outline in any view through them)."""
    ring = _circle(radius, 0.0)
    rings = [ring, ring[:, [1, 0, 2]], ring[:, [1, 2, 0]]]
    # and latitude circles, for views along other directions
    for height in np.linspace(-radius, radius, 9)[1:-1]:
        rings.append(_circle(np.sqrt(radius ** 2 - height ** 2), height))
    points = np.vstack(rings)
    points[:, 0] += center_x
    return points


def shape_parts(shape) -> list:
    """
    Return a shape's convex parts as point clouds (k, 3) in the body's axes, m.

    A shape with ``parts`` (a compound shape, SPEC section 11) gives one per
    part; a mesh its hull's vertices (none when the mesh is not a local file).
    """
    parts = getattr(shape, 'parts', None)
    if parts:
        return [cloud for part in parts for cloud in shape_parts(part)]
    kind, size = shape.kind, tuple(float(v) for v in shape.size)
    if kind == 'box':
        corners = np.array([[i, j, k] for i in (-0.5, 0.5) for j in (-0.5, 0.5)
                            for k in (-0.5, 0.5)])
        local = corners * np.array(size)
    elif kind == 'cylinder':
        radius, length = size
        local = np.vstack([_circle(radius, -length / 2), _circle(radius, length / 2)])
    elif kind == 'sphere':
        local = _sphere(size[0])
    elif kind == 'capsule':
        radius, length = size
        half = max(length / 2 - radius, 0.0)
        local = np.vstack([_sphere(radius, -half), _sphere(radius, half)])
    elif kind == 'mesh':
        local = np.asarray(shape.hull, dtype=float).reshape(-1, 3)
        if not len(local):
            return []
    else:
        return []
    turn = rotations.matrices(np.asarray(shape.orientation_xyzw, dtype=float)[None])[0]
    return [local @ turn.T + np.asarray(shape.offset, dtype=float)]


def outline(points_2d: np.ndarray) -> np.ndarray:
    """Return the closed convex outline of 2D points, (m, 2): a segment if they are in line."""
    from scipy.spatial import ConvexHull, QhullError
    unique = np.unique(np.round(points_2d, 12), axis=0)
    if len(unique) >= 3:
        try:
            hull = ConvexHull(unique)
            ring = unique[hull.vertices]
            return np.vstack([ring, ring[:1]])
        except QhullError:
            pass
    # in line (a flat part seen edge on): the segment between the farthest points
    if not len(unique):
        return unique
    direction = unique[-1] - unique[0]
    order = np.argsort(unique @ direction)
    return unique[[order[0], order[-1]]]


def placed_outlines(clouds, position, quaternion, view: str) -> list:
    """Return the outlines (2D, m) of convex parts placed at a pose, in one view."""
    turn = rotations.matrices(np.asarray(quaternion, dtype=float)[None])[0]
    i, j = VIEWS[view]
    out = []
    for cloud in clouds:
        placed = cloud @ turn.T + np.asarray(position, dtype=float)
        out.append(outline(placed[:, [i, j]]))
    return out
