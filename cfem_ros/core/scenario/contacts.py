# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The ``contacts`` section (SPEC section 8): the pairs of bodies whose shapes are watched."""

from __future__ import annotations

from cfem_ros.core.fileio.messages import show
from cfem_ros.core.model.model import Contact
from cfem_ros.core.scenario.checker import body_of, Checker, key_path

CONTACT_KEYS = ('bodies', 'on_contact')


def parse_contacts(check: Checker, doc, index: dict, bodies) -> tuple:
    """Parse ``contacts``: the pairs of bodies whose shapes are watched (SPEC section 8)."""
    if doc is None:
        return ()
    if not isinstance(doc, list):
        check.fail('contacts', f'is {show(doc)}', 'a list of {bodies: [a, b]} entries')
    out, seen = [], set()
    for k, spec in enumerate(doc):
        key = f'contacts[{k}]'
        spec = check.mapping(spec, key, CONTACT_KEYS, required=('bodies',))
        pair = spec['bodies']
        if not isinstance(pair, list) or len(pair) != 2:
            check.fail(f'{key}.bodies', f'is {show(pair)}', 'two body names [a, b]')
        a, b = (body_of(check, name, f'{key}.bodies[{i}]', index) for i, name in enumerate(pair))
        if a == b:
            check.fail(f'{key}.bodies', f'names {show(pair[0])} twice', 'two different bodies')
        if frozenset((a, b)) in seen:
            check.fail(f'{key}.bodies', f'repeats the pair {show(pair)}', 'each pair once')
        seen.add(frozenset((a, b)))
        if bodies[a].fixed and bodies[b].fixed:
            check.fail(f'{key}.bodies', 'are both fixed, so they never move',
                       'a pair with a body that moves')
        for i, name in zip((a, b), pair):
            shape = bodies[i].shape
            if shape is None:
                check.fail(key_path('bodies', name) + '.shape', 'missing, and the body is watched '
                           f'for contact ({key})', 'a shape: box, cylinder, sphere, capsule '
                           'or mesh')
            for k, piece in enumerate(shape.pieces()):
                if piece.kind == 'mesh' and not piece.hull:
                    where = '.shape' + (f'.parts[{k}]' if shape.kind == 'compound' else '')
                    check.fail(key_path('bodies', name) + where + '.mesh',
                               f'is {show(piece.mesh)}, not a local file, so it has no hull '
                               'to watch', 'a local STL or OBJ file (its convex hull is the '
                               'collision shape)')
        stop = spec.get('on_contact', 'stop')
        if stop not in ('stop', 'continue'):
            check.fail(f'{key}.on_contact', f'is {show(stop)}', 'stop or continue')
        out.append(Contact(bodies=(a, b), stop=stop == 'stop'))
    return tuple(out)
