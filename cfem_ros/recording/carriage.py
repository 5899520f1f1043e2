# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A named point of a carrier, in the carrier's axes (SPEC section 15).

Positions relative to a carrier are measured from its CG unless a point is
named: ``carriage`` or ``[x, y, z]``. A point ``[x, y, z]`` is in the
carrier's axes, m, from its CG (the origin of its recorded body frame, the
actual CG with a ``cg_offset``). ``carriage`` is the mean of the anchors of
the joints between the body and the carrier that the run released (all the
joints between them if it released none, a run ended before its release):
the point the store hangs from. A joint's anchor is a world point at t = 0
fixed on both bodies (SPEC section 1), so in the carrier's axes it is
``R_c(0)^T (anchor - p_c(0))`` with the carrier's pose at t = 0, the same
point the simulation carries (``topology.JointTables`` ``anchor_a``); it
stays there whatever the carrier does afterwards.

``parse_point`` reads ``--point`` or a metric's ``point:``;
``carriage_point`` (from ``joint_anchors``) and ``carrier_offsets`` give
the point in the carrier's axes; ``scenario_model`` reads the scenario a
recording names.
"""

from __future__ import annotations

import math
import os
from typing import Optional, Union

from cfem_ros.core import rotations
from cfem_ros.core.errors import ArgumentError
from cfem_ros.core.scenario.checker import MAX_MAGNITUDE
from cfem_ros.recording.errors import RecordingError
import numpy as np

__all__ = ['CARRIAGE', 'EXPECTED', 'carriage_point', 'carrier_offsets', 'joint_anchors',
           'parse_point', 'scenario_model']

CARRIAGE = 'carriage'
#: What a point may be, for the errors.
EXPECTED = (f"'{CARRIAGE}' (the mean of the released joints' anchors) or [x, y, z] (m, the "
            "carrier's axes, from its CG)")


def parse_point(value) -> Union[str, np.ndarray]:
    """
    Return ``'carriage'`` or the point [x, y, z] (m) a ``--point`` or ``point:`` gives.

    value: 'carriage', a list of 3 numbers, or the text '[x, y, z]' (or 'x,y,z').

    Raises
    ------
    ArgumentError
        If it is neither (the message says what it is; ``EXPECTED`` what it may be).

    """
    said = repr(value)
    if isinstance(value, str):
        text = value.strip()
        if text == CARRIAGE:
            return CARRIAGE
        parts = text[1:-1] if text.startswith('[') and text.endswith(']') else text
        try:
            value = [float(p) for p in parts.split(',')]
        except ValueError:
            raise ArgumentError(f'{said} is neither {CARRIAGE} nor three numbers') from None
    if not isinstance(value, (list, tuple)) or len(value) != 3 or any(
            isinstance(v, bool) or not isinstance(v, (int, float)) for v in value):
        raise ArgumentError(f'{said} is neither {CARRIAGE} nor three numbers')
    if not all(math.isfinite(v) and abs(v) <= MAX_MAGNITUDE for v in value):
        raise ArgumentError(f'{said} is not finite within {MAX_MAGNITUDE:g} m')
    return np.array(value, dtype=float)


def joint_anchors(model) -> list:
    """Return a model's joints as (name, parent name, child name, anchor (world, t = 0))."""
    names = [b.name for b in model.bodies]
    return [(j.name, names[j.parent], names[j.child], np.asarray(j.anchor, dtype=float))
            for j in model.joints]


def scenario_model(run):
    """Return the scenario named in a recording's metadata, parsed (None if gone or invalid)."""
    from cfem_ros.core.errors import CfemError
    from cfem_ros.core.scenario.parse import load_scenario
    path = run.metadata.get('scenario')
    if not path or not os.path.isfile(path):
        return None
    try:
        return load_scenario(path)
    except CfemError:
        return None


def carriage_point(joints, body: str, carrier: str, released, carrier_position,
                   carrier_quaternion) -> Optional[np.ndarray]:
    """
    Return the carriage of body on carrier in the carrier's axes (m), None if no joint.

    Parameters
    ----------
    joints : iterable of (name, parent, child, anchor)
        The scenario's joints (``joint_anchors``): anchors in the world at t = 0.
    body, carrier : str
        Body names.
    released : iterable of str
        The joints the run released.
    carrier_position, carrier_quaternion : array_like (3,), (4,)
        The carrier's CG (world, m) and attitude (x y z w) at t = 0.

    """
    between = [(name, anchor) for name, parent, child, anchor in joints
               if {parent, child} == {body, carrier} and body != carrier]
    released = set(released)
    anchors = [a for name, a in between if name in released] or [a for _, a in between]
    if not anchors:
        return None
    quaternion = np.asarray(carrier_quaternion, dtype=float)
    turn = rotations.matrices(quaternion[None] / np.linalg.norm(quaternion))[0]
    mean = np.mean(np.asarray(anchors, dtype=float), axis=0)
    return turn.T @ (mean - np.asarray(carrier_position, dtype=float))


def carrier_offsets(run, model, reference: str, point, names, warn=None) -> dict:
    """
    Return {body: its point of the reference (reference axes, m)} for ``export --point``.

    point: as ``parse_point`` takes it (None: {}); model: the recording's
    scenario (None if it cannot be read: ``carriage`` is refused). A body
    without a joint to the reference gets NaN (and a ``warn`` line), unless
    none has one: refused.

    Raises
    ------
    RecordingError
        If point is no point, or its carriage cannot be found.

    """
    if point is None:
        return {}
    try:
        point = parse_point(point)
    except ValueError as err:
        raise RecordingError(f'{run.path}: --point {err}; expected {EXPECTED}') from None
    if not isinstance(point, str):
        return {name: point for name in names}
    if model is None:
        raise RecordingError(
            f'{run.path}: --point {CARRIAGE}: the scenario named in the recording '
            f"({run.metadata.get('scenario') or 'none'}) cannot be read for its joints' "
            f"anchors; expected --point [x, y, z] (m, the carrier's axes, from its CG)")
    ref = run.bodies[reference]
    if not len(ref.time) or abs(ref.time[0]) > 1e-9:
        raise RecordingError(f'{run.path}: --point {CARRIAGE}: no sample of {reference} at '
                             't = 0, where the anchors are given; expected [x, y, z]')
    released = [joint for _, joint, _ in run.releases()]
    joints = joint_anchors(model)
    out = {name: carriage_point(joints, name, reference, released, ref.position[0],
                                ref.quaternion[0]) for name in names}
    if all(p is None for p in out.values()):
        raise RecordingError(f'{run.path}: --point {CARRIAGE}: no joint between '
                             f'{reference} and {", ".join(names) or "another body"}; expected '
                             'a carrier that holds a body, or --point [x, y, z]')
    for name in [n for n, p in out.items() if p is None]:
        out[name] = np.full(3, np.nan)
        if warn is not None:
            warn(f'{run.path}: {name} has no joint to {reference}: its x, y, z from the '
                 f'{CARRIAGE} are NaN')
    return out
