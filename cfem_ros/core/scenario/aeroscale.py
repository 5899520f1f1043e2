# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
An aero entry's ``scale`` and ``delta`` (SPEC section 10), set on its tables parsed once.

``aeroparse`` reads an entry's tables unscaled and hands them here; a sweep
that varies only ``aero.<body>.scale.*`` and ``aero.<body>.delta.*`` sets
each run's values on the same unscaled entry (``parse.reparse``) instead of
reading the tables and the proximity file again: the same arithmetic on the
same numbers, so the same model to the bit.
"""

from __future__ import annotations

from cfem_ros.core.model.loads import Aero, Proximity
import numpy as np

AERO_COEFFICIENTS = ('CX', 'CY', 'CZ', 'Cl', 'Cm', 'Cn')
DAMPING_DERIVATIVES = ('Clp', 'Cmq', 'Cnr')
#: Increment columns of a proximity table.
INCREMENTS = ('dCX', 'dCY', 'dCZ', 'dCl', 'dCm', 'dCn')


def factors_of(check, spec: dict, key: str) -> tuple:
    """Return (scale factors, deltas) of an aero entry, by name, each checked."""
    scales = check.mapping(spec.get('scale', {}), f'{key}.scale',
                           AERO_COEFFICIENTS + DAMPING_DERIVATIVES + INCREMENTS)
    factors = {c: check.number(v, f'{key}.scale.{c}') for c, v in scales.items()}
    deltas = check.mapping(spec.get('delta', {}), f'{key}.delta',
                           AERO_COEFFICIENTS + DAMPING_DERIVATIVES)
    added = {c: check.number(v, f'{key}.delta.{c}') for c, v in deltas.items()}
    return factors, added


def refuse_lone_increments(check, factors: dict, proximity, key: str):
    """Refuse a scale on a proximity increment of an entry with no proximity table."""
    if proximity is None and any(d in factors for d in INCREMENTS):
        first = next(d for d in INCREMENTS if d in factors)
        check.fail(f'{key}.scale.{first}', 'scales an increment, and there is no proximity '
                   'table', f'{key}.proximity, or no {first}')


def scaled(aero: Aero, factors: dict, added: dict) -> Aero:
    """
    Return an unscaled entry with its scale factors and deltas applied.

    The multipliers act on the free-stream tables, the damping derivatives
    and the proximity increments; the deltas add to the damping derivatives
    and, after interpolation, to the coefficients (``delta``). ``aero``'s
    arrays are not changed.
    """
    table = aero.coefficients.copy()
    for c, coefficient in enumerate(AERO_COEFFICIENTS):
        table[..., c] *= factors.get(coefficient, 1.0)
    damping = aero.damping.copy()
    damping *= [factors.get(d, 1.0) for d in DAMPING_DERIVATIVES]
    damping += [added.get(d, 0.0) for d in DAMPING_DERIVATIVES]
    proximity = aero.proximity
    if proximity is not None:
        increments = proximity.increments * [factors.get(d, 1.0) for d in INCREMENTS]
        proximity = Proximity(**{**proximity.__dict__, 'increments': increments})
    return Aero(**{**aero.__dict__, 'coefficients': table, 'damping': damping,
                   'proximity': proximity,
                   'delta': np.array([added.get(c, 0.0) for c in AERO_COEFFICIENTS])})


def rescaled(check, aero: Aero, spec: dict, key: str) -> Aero:
    """Return an unscaled entry with the scale and delta of its section ``spec`` applied."""
    factors, added = factors_of(check, spec, key)
    refuse_lone_increments(check, factors, aero.proximity, key)
    return scaled(aero, factors, added)
