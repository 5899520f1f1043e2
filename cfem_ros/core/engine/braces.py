# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Sway braces (SPEC section 11): one-sided preloaded pads between a body and its carrier.

A brace pushes its body at a point along a direction (both in the body's
axes) with ``preload + stiffness * s + damping * ds/dt``, s the pad's
compression since t = 0, while the pad touches; it never pulls. Its carrier
takes the opposite force at the same point. Each brace is one row of the
kernel's packed ``loads`` (``cpp/braces.hpp`` reads it): the compiled step
applies it at every RK4 stage, the step in which the push changes sign is
cut where it does (located like a release condition), and the engine
switches the pad in or out of contact there (a ``brace_contact`` event).

This module reads the scenario's ``sway_braces`` and packs the rows (their
columns ``LOADS.BR_*``, kind ``LOADS.KIND_BRACE``: ``cpp/layout.hpp``).
"""

from __future__ import annotations

from dataclasses import dataclass

from cfem_ros.core.scenario import cgoffset
import numpy as np

#: The scenario keys of a brace.
BRACE_KEYS = ('name', 'body', 'carrier', 'point', 'direction', 'preload', 'stiffness',
              'damping')
#: A brace's point may lie at most this far from its body's given shape, m (a pad
#: touches the body's skin; the tolerance covers a drawn shape's simplification).
NEAR_SHAPE = 0.05
#: Without a given shape, from the box of its mass and inertia: a fraction of its largest edge.
NEAR_BOX = 0.25


@dataclass(frozen=True)
class SwayBrace:
    """
    A one-sided preloaded spring-damper between a body and its carrier.

    Attributes
    ----------
    name : str
        The load's source name (``bodies/<body>/applied/<name>``).
    body, carrier : int
        The body the pad pushes, the body it is mounted on.
    point : ndarray, shape (3,)
        The contact point at t = 0, body axes from the CG, m.
    direction : ndarray, shape (3,)
        Unit vector, body axes: the pad pushes the body along it.
    preload, stiffness, damping : float
        N at t = 0, N/m, N s/m.

    """

    name: str
    body: int
    carrier: int
    point: np.ndarray
    direction: np.ndarray
    preload: float
    stiffness: float
    damping: float = 0.0


def parse_braces(check, doc, index: dict, bodies, wrenches=()) -> tuple:
    """
    Parse ``sway_braces`` (a list) into ``SwayBrace`` tuples; ``check`` reports errors.

    Refused with the key path: a brace on a body that does not move, a
    carrier that is the body itself, a negative preload, stiffness or
    damping, a zero direction, a point far from the body's shape, a name
    used twice on a body (a brace's or a wrench's: each is a load source).
    """
    if doc is None:
        return ()
    if not isinstance(doc, list):
        check.fail('sway_braces', f'is {doc!r:.80}', 'a list of brace mappings')
    taken = {(w.body, w.name): f'wrenches[{k}]' for k, w in enumerate(wrenches)}
    out = []
    for k, spec in enumerate(doc):
        brace = _parse_brace(check, k, spec, index, bodies)
        key = f'sway_braces[{k}]'
        if (brace.body, brace.name) in taken:
            check.fail(f'{key}.name', f'{brace.name!r} already names '
                       f'{taken[brace.body, brace.name]} on the same body',
                       'a name of its own (each load is published under its name)')
        taken[brace.body, brace.name] = key
        out.append(brace)
    return tuple(out)


def _parse_brace(check, k: int, spec, index: dict, bodies) -> SwayBrace:
    key = f'sway_braces[{k}]'
    spec = check.mapping(spec, key, BRACE_KEYS,
                         required=('body', 'carrier', 'point', 'direction', 'preload',
                                   'stiffness'))
    names = ', '.join(index)
    for side in ('body', 'carrier'):
        if spec[side] not in index:
            check.fail(f'{key}.{side}', f'{spec[side]!r:.80} is not a body', f'one of {names}')
    body, carrier = index[spec['body']], index[spec['carrier']]
    if not bodies[body].dynamic:
        check.fail(f'{key}.body', f'{spec["body"]!r} is fixed or kinematic',
                   'a body moved by forces (the pad pushes it)')
    if carrier == body:
        check.fail(f'{key}.carrier', f'is {spec["carrier"]!r}, the braced body',
                   'the body the pad is mounted on (another body)')
    name = check.name(spec.get('name', f'brace{k}'), f'{key}.name')
    if name in ('wrench', 'aero'):
        check.fail(f'{key}.name', f'{name!r} is the name of another load source', 'another name')
    point = cgoffset.from_cg(bodies[body], check.vector(spec['point'], f'{key}.point'))
    direction = check.direction(spec['direction'], f'{key}.direction')
    direction = direction / np.linalg.norm(direction)
    preload = check.number(spec['preload'], f'{key}.preload', minimum=0.0)
    stiffness = check.number(spec['stiffness'], f'{key}.stiffness', minimum=0.0)
    damping = check.number(spec.get('damping', 0.0), f'{key}.damping', minimum=0.0)
    _check_near_shape(check, f'{key}.point', point, bodies[body])
    return SwayBrace(name=name, body=body, carrier=carrier, point=point, direction=direction,
                     preload=preload, stiffness=stiffness, damping=damping)


def _check_near_shape(check, key: str, point: np.ndarray, body):
    """Refuse a brace point farther than ``NEAR_SHAPE`` from the body's shape (inside or out)."""
    from cfem_ros.core.model import shapes

    shape = body.shape
    if shape is None:
        shape = shapes.equivalent_box(body.mass, body.inertia)
        near = NEAR_BOX * max(shape.size)
        what = f'the box of its mass and inertia ({_edges(shape.size)} m)'
    else:
        near = NEAR_SHAPE
        what = 'its shape'
    pieces = [p for p in shape.pieces() if p.kind != 'mesh' or p.hull]
    if not pieces:
        return   # a mesh that is no local file: nothing to measure against
    distance = surface_distance(pieces, point)
    if abs(distance) > near:
        side = 'inside' if distance < 0 else 'from'
        check.fail(key, f'is {list(map(float, point))}, {abs(distance):.3g} m {side} the '
                   f'surface of {what} of {body.name!r}',
                   f"the pad's contact point on the body, within {near:.3g} m of its surface")


def surface_distance(pieces, point: np.ndarray) -> float:
    """
    Return a point's distance to the surface of a union of convex shapes, m (< 0 inside).

    Outside all of them: the least distance (the compiled distance to a point);
    inside: the depth below the surface of the piece it is deepest in.
    """
    from cfem_ros.core.engine import contacts
    from cfem_ros.core.model import shapes

    dot = contacts.pack_shape(shapes.Shape('sphere', (1e-300,), offset=tuple(point)))
    identity, origin = np.array([[0.0, 0.0, 0.0, 1.0]]), np.zeros((1, 3))
    outside = []
    for piece in pieces:
        d = float(contacts.distances(dot, identity, origin, contacts.pack_shape(piece),
                                     identity, origin)[0][0])
        outside.append(d)
    if min(outside) > 0.0:
        return min(outside)
    return -max(_depth(piece, point) for piece, d in zip(pieces, outside) if d <= 0.0)


def _depth(shape, point: np.ndarray) -> float:
    """Return how deep a point lies inside a convex shape, m (its distance to the surface)."""
    from cfem_ros.core import rotations

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


def _edges(size) -> str:
    return ' x '.join(f'{v:.3g}' for v in size)


def pack(rows: np.ndarray, first: int, braces):
    """Write the braces' rows from row ``first`` on (their pads placed by ``anchor``)."""
    from cfem_ros.core.engine.kernel import LOADS

    for k, brace in enumerate(braces):
        r = rows[first + k]
        r[:] = 0.0
        r[LOADS.S_KIND] = LOADS.KIND_BRACE
        r[LOADS.BR_BODY], r[LOADS.BR_CARRIER] = brace.body, brace.carrier
        r[LOADS.span('BR_POINT')] = brace.point
        r[LOADS.span('BR_DIRECTION')] = brace.direction
        r[LOADS.BR_PRELOAD], r[LOADS.BR_STIFFNESS] = brace.preload, brace.stiffness
        r[LOADS.BR_DAMPING] = brace.damping


def anchor(rows: np.ndarray, first: int, braces, y: np.ndarray, n: int):
    """
    Put the braces' pads where their points are at state y, in contact (t = 0 of a run).

    The compression is measured from there: each pad's point is kept in its
    carrier's axes.
    """
    from cfem_ros.core import rotations
    from cfem_ros.core.engine.kernel import LOADS

    pos = y[:3 * n].reshape(n, 3)
    quat = y[6 * n:10 * n].reshape(n, 4)
    rot = rotations.matrices(quat / np.linalg.norm(quat, axis=1)[:, None])
    for k, brace in enumerate(braces):
        r = rows[first + k]
        b, c = brace.body, brace.carrier
        world = pos[b] + rot[b] @ brace.point
        r[LOADS.span('BR_PAD')] = rot[c].T @ (world - pos[c])
        r[LOADS.BR_ON] = 1.0


def contact_event(brace: SwayBrace, contact: bool, t: float) -> dict:
    """Return a pad's event (SPEC section 11): it touches again (True) or lets go (False)."""
    return {'event': 'brace_contact', 'brace': brace.name, 'contact': bool(contact),
            'time': float(t)}
