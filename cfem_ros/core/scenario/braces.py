# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The ``sway_braces`` section (SPEC section 11): the pads between a body and its carrier.

Each brace is checked against its body (a pad touches the body's skin:
``NEAR_SHAPE``, ``NEAR_BOX``) and named once among the body's loads.
"""

from __future__ import annotations

from cfem_ros.core.model.loads import SwayBrace
from cfem_ros.core.native.contacts import surface_distance
from cfem_ros.core.scenario import cgoffset
from cfem_ros.core.scenario.checker import body_of
import numpy as np

#: The scenario keys of a brace.
BRACE_KEYS = ('name', 'body', 'carrier', 'point', 'direction', 'preload', 'stiffness',
              'damping')
#: A brace's point may lie at most this far from its body's given shape, m (a pad
#: touches the body's skin; the tolerance covers a drawn shape's simplification).
NEAR_SHAPE = 0.05
#: Without a given shape, from the box of its mass and inertia: a fraction of its largest edge.
NEAR_BOX = 0.25


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
    body = body_of(check, spec['body'], f'{key}.body', index)   # a list is no name
    carrier = body_of(check, spec['carrier'], f'{key}.carrier', index)
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


def _edges(size) -> str:
    return ' x '.join(f'{v:.3g}' for v in size)
