# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Readable names with units for a sweep table's columns (figures and reports).

``label('bodies.store.mass')`` is 'store mass [kg]',
``label('clearance_store_pylon_min')`` 'min clearance store-pylon [m]'.
Body, joint and wrench names come from the base scenario (so names with
underscores split right); a column no rule knows keeps its name.
"""

from __future__ import annotations

import re
from typing import Optional

from cfem_ros.recording import units as output_units
from cfem_ros.study.keypaths import parse_key_path

AXES = ('x', 'y', 'z')
ANGLES = ('roll', 'pitch', 'yaw')
#: Last key of a key path -> (words, unit, names of the list's items).
KEYS = {
    'mass': ('mass', 'kg', None),
    'inertia': ('inertia', 'kg m^2', ('Ixx', 'Iyy', 'Izz', 'Ixy', 'Ixz', 'Iyz')),
    'position': ('initial position', 'm', AXES),
    'velocity': ('initial velocity', 'm/s', ('u', 'v', 'w')),
    'angular_velocity': ('initial rates', 'rad/s', ('P', 'Q', 'R')),
    'angular_velocity_deg': ('initial rates', 'deg/s', ('P', 'Q', 'R')),
    'orientation_rpy_deg': ('initial attitude', 'deg', ANGLES),
    'anchor': ('anchor', 'm', AXES),
    'axis': ('axis', '', AXES),
    'angle_deg': ('release angle', 'deg', None),
    'time': ('release time', 's', None),
    'distance': ('release distance', 'm', None),
    'force': ('force', 'N', AXES),
    'torque': ('torque', 'N m', AXES),
    'moment': ('moment', 'N m', AXES),
    'point': ('point', 'm', AXES),
    'stroke': ('stroke', 'm', None),
    'delay': ('delay', 's', None),
    'duration': ('duration', 's', None),
    'dt': ('time step dt', 's', None),
    'gravity': ('gravity', 'm/s^2', AXES),
    # flight: (SPEC section 14) and the atmosphere of aero
    'mach': ('Mach number', '', None),
    'airspeed': ('true airspeed', 'm/s', None),
    'altitude': ('altitude', 'm', None),
    'temperature_offset': ('temperature offset', 'K', None),
    'flight_path_deg': ('flight path angle', 'deg', None),
    'load_factor': ('load factor n', 'g', None),
    'roll_rate_deg_s': ('roll rate', 'deg/s', None),
    'alpha_deg': ('angle of attack', 'deg', None),
}
#: Stroke-end columns (SPEC section 7): suffix -> (words, unit), units as an export's.
STROKE = {'time': ('end of stroke time', 's')}
STROKE.update((q, (f'{q} at end of stroke', output_units.BODY[q])) for q in 'uvwpqr')
#: Columns of every sweep table that have no unit: the run's index, its status and message.
PLAIN = ('run', 'status', 'message')


def _names(document: Optional[dict]) -> tuple:
    document = document or {}
    bodies = sorted(document.get('bodies') or {}, key=len, reverse=True)
    joints = sorted(document.get('joints') or {}, key=len, reverse=True)
    wrenches = [w.get('name', str(i)) if isinstance(w, dict) else str(i)
                for i, w in enumerate(document.get('wrenches') or [])]
    return bodies, joints, wrenches


def unit(column: str, document: Optional[dict] = None) -> str:
    """Return the unit of a column ('' if none or unknown)."""
    return unit_rule(column, document) or ''


def unit_rule(column: str, document: Optional[dict] = None) -> Optional[str]:
    """Return the unit a rule gives a column ('' for a number without one), None if no rule."""
    if column in PLAIN:
        return ''
    text = label(column, document)
    if text == column:
        return None
    match = re.search(r'\[([^\]]*)\]$', text)
    return match.group(1) if match else ''


def _with(words: str, unit_text: str) -> str:
    return f'{words} [{unit_text}]' if unit_text else words


def _key_path(column: str, document) -> Optional[str]:
    try:
        tokens = parse_key_path(column)
    except ValueError:
        return None
    if '.' not in column and '[' not in column and column not in KEYS:
        return None
    _, _, wrenches = _names(document)
    owner = ''
    if tokens[0] in ('bodies', 'joints') and len(tokens) >= 3:
        owner, rest = str(tokens[1]), tokens[2:]
    elif tokens[0] == 'wrenches' and len(tokens) >= 3 and isinstance(tokens[1], int):
        name = wrenches[tokens[1]] if tokens[1] < len(wrenches) else str(tokens[1])
        owner, rest = f'wrench {name}', tokens[2:]
    else:
        rest = tokens
    index = rest[-1] if isinstance(rest[-1], int) else None
    words = [str(t) for t in rest if not isinstance(t, int)]
    known = KEYS.get(words[-1]) if words else None
    if known is None:
        text = ' '.join(w.replace('_', ' ') for w in words)
        suffix = {'deg': 'deg', 's': 's', 'm': 'm', 'hz': 'Hz', 'n': 'N'}.get(
            words[-1].rsplit('_', 1)[-1].lower() if '_' in words[-1] else '', '')
        if words[-1].lower().endswith('_deg_s'):   # a rate in deg/s, not a time
            suffix = 'deg/s'
        if index is not None:
            text += f' [{index}]'
        return _with(' '.join(p for p in (owner, text) if p), suffix)
    what, unit_text, items = known
    if words[-1] == 'time' and tokens[0] != 'joints':
        what = 'time'
    if index is not None:
        item = items[index] if items and index < len(items) else f'[{index}]'
        what = f'{what} {item}'
    return _with(' '.join(p for p in (owner, what) if p), unit_text)


def _pair(rest: str, bodies) -> Optional[tuple]:
    for a in bodies:
        if rest.startswith(a + '_'):
            tail = rest[len(a) + 1:]
            for b in bodies:
                if tail.startswith(b + '_') or tail == b:
                    return a, b, tail[len(b) + 1:]
    parts = rest.split('_')
    if len(parts) >= 3:
        return parts[0], parts[1], '_'.join(parts[2:])
    return None


def label(column: str, document: Optional[dict] = None) -> str:
    """
    Return a column's readable name with its unit in brackets.

    Parameters
    ----------
    column : str
        A varied key path or a metric column of a sweep table.
    document : dict, optional
        The base scenario (names of bodies, joints, wrenches).

    """
    bodies, joints, wrenches = _names(document)
    path = _key_path(column, document)
    if path is not None:
        return path
    for kind, words in (('clearance', 'clearance'), ('distance', 'shape distance')):
        if column.startswith(kind + '_'):
            found = _pair(column[len(kind) + 1:], bodies)
            if found:
                a, b, what = found
                if what == 'min':
                    return f'min {words} {a}-{b} [m]'
                if what == 'min_time':
                    return f'time of min {words} {a}-{b} [s]'
                if what in ('point_a', 'point_b'):
                    return f'{words} {a}-{b}: index of {what.replace("_", " ")}'
                point = re.fullmatch(r'point_([ab])_([xyz])', what)
                if point:   # the closest points (SPEC section 8)
                    return f'{words} {a}-{b}: closest point {point.group(1)} ' \
                           f'{point.group(2)} [m]'
    if column.startswith('contact_') and column.endswith('_time'):
        found = _pair(column[len('contact_'):], bodies)
        if found:
            return f'contact time {found[0]}-{found[1]} [s]'
    match = re.fullmatch(r'release_(.+)_(time|cause)', column)
    if match:
        return _with(f'{match.group(1)} release {match.group(2)}',
                     's' if match.group(2) == 'time' else '')
    match = re.fullmatch(r'peak_(force|moment)_(.+)', column)
    if match:
        return _with(f'peak {match.group(1)} in {match.group(2)}',
                     'N' if match.group(1) == 'force' else 'N m')
    match = re.fullmatch(r'stroke_(.+)_(time|[uvwpqr])', column)
    if match and match.group(1) in wrenches + [str(i) for i in range(len(wrenches))] \
            or (match and not wrenches):
        words, unit_text = STROKE[match.group(2)]
        return _with(f'{match.group(1)} {words}', unit_text)
    quantity = '|'.join(output_units.BODY)
    at_units = {**output_units.BODY, **output_units.RELATIVE}
    match = re.fullmatch(rf'(.+)_at_([0-9.eE+-]+)(r?)_({"|".join(at_units)})', column)
    if match:
        body, time, after, what = match.groups()
        since = ' after its release' if after else ''
        return f'{body} {what.replace("_deg", "")} at {time} s{since} ' \
               f'[{at_units[what]}]'
    match = re.fullmatch(r'aero_outside_(.+)', column)
    if match:
        return f'time {match.group(1)} spends outside its aero tables [s]'
    match = re.fullmatch(rf'(.+)_(min|max)_({quantity})', column)
    if match and (not bodies or match.group(1) in bodies):
        body, which, what = match.groups()
        return f'{which} {body} {what.replace("_deg", "")} [{output_units.BODY[what]}]'
    return column
