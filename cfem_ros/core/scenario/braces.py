# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The ``sway_braces`` section (SPEC section 11): the pads between a body and its carrier.

Each brace is checked against its body (a pad touches the body's skin:
``NEAR_SHAPE``, ``NEAR_BOX``; it pushes into the body, away from the
carrier it is mounted on), named once among the body's loads, and the
braces together against the step (``bracestep``: a pad so stiff that RK4
cannot follow it with dt is refused with the dt that would do).
"""

from __future__ import annotations

from cfem_ros.core import rotations
from cfem_ros.core.model.loads import SwayBrace
from cfem_ros.core.native.contacts import surface_distance
from cfem_ros.core.scenario import bracestep, cgoffset
from cfem_ros.core.scenario.checker import body_of
import numpy as np

#: The scenario keys of a brace.
BRACE_KEYS = ('name', 'body', 'carrier', 'point', 'direction', 'preload', 'stiffness',
              'damping', 'pad_radius')
#: The pad's radius when not given, m (SPEC section 11).
PAD_RADIUS = 0.05
#: A brace's point may lie at most this far from its body's given shape, m (a pad
#: touches the body's skin; the tolerance covers a drawn shape's simplification).
NEAR_SHAPE = 0.05
#: Without a given shape, from the box of its mass and inertia: a fraction of its largest edge.
NEAR_BOX = 0.25


def parse_braces(check, doc, index: dict, bodies, wrenches=(), dt=None) -> tuple:
    """
    Parse ``sway_braces`` (a list) into ``SwayBrace`` tuples; ``check`` reports errors.

    Refused with the key path: a brace on a body that does not move, a
    carrier that is the body itself, a negative preload, stiffness or
    damping, a zero direction or one that points out of the body (towards
    the carrier), a pad radius that is not positive, a point far from the
    body's shape, a name used twice on a body (a brace's or a wrench's: each
    is a load source), and with the step dt (s) given, braces so stiff that
    RK4 is unstable with it.
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
    if dt is not None:
        bracestep.check_step(check, out, bodies, dt)
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
    given = check.vector(spec['point'], f'{key}.point')
    point = cgoffset.from_cg(bodies[body], given)
    direction = check.direction(spec['direction'], f'{key}.direction')
    direction = direction / np.linalg.norm(direction)
    preload = check.number(spec['preload'], f'{key}.preload', minimum=0.0)
    stiffness = check.number(spec['stiffness'], f'{key}.stiffness', minimum=0.0)
    damping = check.number(spec.get('damping', 0.0), f'{key}.damping', minimum=0.0)
    radius = check.number(spec.get('pad_radius', PAD_RADIUS), f'{key}.pad_radius',
                          positive=True)
    _check_near_shape(check, f'{key}.point', given, point, bodies[body])
    _check_pushes_in(check, key, spec, point, direction, bodies[body], bodies[carrier])
    return SwayBrace(name=name, body=body, carrier=carrier, point=point, direction=direction,
                     preload=preload, stiffness=stiffness, damping=damping, pad_radius=radius)


def _check_pushes_in(check, key: str, spec: dict, point, direction, body, carrier):
    """
    Refuse a direction that points out of the body at its point, towards the carrier.

    A pad mounted on the carrier presses on the body's skin: its push points
    into the body (towards its CG side of the point). One pointing out of it
    would push the body into the carrier the pad is mounted on.
    """
    if float(np.dot(direction, -point)) >= 0.0:
        return
    turn = rotations.matrices(np.asarray(body.orientation_xyzw, dtype=float)[None])[0]
    world = [round(float(v), 4) for v in turn @ direction]
    check.fail(f'{key}.direction', f'is {list(spec["direction"])}: it points out of '
               f'{body.name!r} at its point (world {world} at t = 0), towards the carrier '
               f'{carrier.name!r} the pad is mounted on, so the pad would push {body.name!r} '
               'into it', f'the direction the pad pushes {body.name!r} away from '
               f'{carrier.name!r}, into the body (e.g. {[-v for v in spec["direction"]]})')


def _check_near_shape(check, key: str, given, point: np.ndarray, body):
    """
    Refuse a brace point farther than ``NEAR_SHAPE`` from the body's shape (inside or out).

    point: from the actual CG (where it is measured); given: as the file gives it
    (from the nominal CG), the value the message names.
    """
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
        check.fail(key, f'is {list(map(float, given))}, {abs(distance):.3g} m {side} the '
                   f'surface of {what} of {body.name!r}',
                   f"the pad's contact point on the body, within {near:.3g} m of its surface")


def _edges(size) -> str:
    return ' x '.join(f'{v:.3g}' for v in size)
