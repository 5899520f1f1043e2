# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The scenario's ``aero`` section (SPEC sections 8 and 10): read and checked.

Free-stream coefficient tables over (alpha, beta, Mach), the air the body
flies through (at rest in the world frame, plus a constant ``wind``, or the
``freestream`` of a fixed carrier), the atmosphere at the body's own altitude
(ISA, or ISA with a temperature offset), the point the moment coefficients
are about, constant increments, what a table does beyond its range, and
interference increments on a regular grid over the body's position and
attitude relative to a carrier (``proximity``), read from a long-format CSV
or Parquet file. This module only reads and checks; the loads are computed
in the compiled step (``cpp/aero.hpp``).
"""

from __future__ import annotations

from dataclasses import dataclass
import math
import os
from typing import Optional

from cfem_ros.core.model.loads import Aero, Proximity
from cfem_ros.core.native.atmosphere import (
    ALTITUDE_RANGE, isa_density, OFFSET_RANGE, STANDARD_RANGE)
from cfem_ros.core.scenario.aeroscale import (
    AERO_COEFFICIENTS, DAMPING_DERIVATIVES, factors_of, INCREMENTS, refuse_lone_increments,
    scaled)
import numpy as np

AERO_KEYS = ('area', 'length', 'density', 'altitude', 'atmosphere', 'freestream', 'wind',
             'alpha_deg', 'beta_deg', 'mach', 'CX', 'CY', 'CZ', 'Cl', 'Cm', 'Cn', 'Clp', 'Cmq',
             'Cnr', 'scale', 'delta', 'reference_point', 'outside', 'proximity', 'zero')
ATMOSPHERE_KEYS = ('altitude', 'temperature_offset')
#: What a table does beyond the range of an axis.
OUTSIDE = ('hold', 'stop')
PROXIMITY_KEYS = ('carrier', 'table', 'outside')
#: Axis columns of a proximity table, in the order the grid nests them.
PROXIMITY_AXES = ('dx', 'dy', 'dz', 'dphi_deg', 'dtheta_deg', 'dpsi_deg', 'mach')
#: The axes that are positions (m): a fade is measured along them.
POSITION_AXES = ('dx', 'dy', 'dz')
#: Most points of a proximity grid.
MAX_GRID_POINTS = 2_000_000


@dataclass
class _Context:
    """What parsing the aero section needs from the scenario parser."""

    check: object
    index: dict
    bodies: tuple
    base_dir: str
    gravity: np.ndarray
    unscaled: bool = False


def parse_aero(check, doc, index: dict, bodies, base_dir: str = '', gravity=None,
               unscaled: bool = False) -> tuple:
    """
    Parse ``aero``: body name -> reference values, tables, air and proximity.

    ``check`` is the scenario parser's checker (``fail``, ``mapping``,
    ``number``, ``vector``); ``index`` maps body names to indices;
    ``base_dir`` is the folder proximity tables are relative to;
    ``gravity`` (world, m/s^2) says which way is up, for each body's own
    altitude at t = 0 (refused beyond the standard atmosphere). ``unscaled``:
    each entry's tables as read, its ``scale`` and ``delta`` checked and not
    applied (``aeroscale.rescaled`` applies them).
    """
    if doc is None:
        return ()
    if not isinstance(doc, dict):
        check.fail('aero', f'is {doc!r:.80}', 'a mapping of body names')
    gravity = np.zeros(3) if gravity is None else np.asarray(gravity, dtype=float)
    context = _Context(check, index, tuple(bodies), base_dir, gravity, unscaled)
    return tuple(_parse_body(context, name, spec) for name, spec in doc.items())


def _body_of(context: _Context, name, key: str) -> int:
    if not isinstance(name, str) or name not in context.index:
        context.check.fail(key, f'{name!r:.80} is not a body',
                           'one of ' + ', '.join(list(context.index)[:8]))
    return context.index[name]


def _parse_body(context: _Context, name, spec) -> Aero:
    check = context.check
    key = f'aero.{name}'
    body = _body_of(context, name, key)
    if context.bodies[body].fixed:
        check.fail(key, f'{name!r} is fixed', 'a body that can move')
    if not context.bodies[body].dynamic:
        check.fail(key, f'{name!r} is kinematic', 'a body moved by forces')
    spec = check.mapping(spec, key, AERO_KEYS, required=('area', 'length', 'alpha_deg'))
    given = [k for k in ('density', 'altitude', 'atmosphere') if k in spec]
    if len(given) != 1:
        check.fail(f'{key}.{given[0] if given else "density"}',
                   f'{" and ".join(given)} given together' if given else 'missing',
                   'one of density (kg/m^3), altitude (m, ISA) or atmosphere ({altitude: m, '
                   'temperature_offset: K})')
    if 'wind' in spec and 'freestream' in spec:
        check.fail(f'{key}.wind', 'given together with freestream',
                   'one of wind (air moving over the ground) or freestream (the air past a '
                   'fixed carrier): both are the velocity of the air, world axes, m/s')
    altitude, offset = _atmosphere(check, spec, key)
    if altitude is not None:
        _body_altitude(context, body, altitude, altitude_key(spec, key))
    density = (check.number(spec['density'], f'{key}.density', positive=True)
               if altitude is None else isa_density(altitude, offset))
    air = spec.get('wind', spec.get('freestream', [0.0, 0.0, 0.0]))
    air = check.vector(air, f'{key}.{"freestream" if "freestream" in spec else "wind"}')
    grids = [_grid(check, spec.get('alpha_deg'), f'{key}.alpha_deg', 'angles, deg', True),
             _grid(check, spec.get('beta_deg', [0.0]), f'{key}.beta_deg', 'angles, deg', True),
             _grid(check, spec.get('mach', [0.0]), f'{key}.mach', 'Mach numbers', False)]
    if 'mach' in spec and altitude is None and len(grids[2]) > 1:
        check.fail(f'{key}.density', 'is given with a table over Mach',
                   'altitude (m) or atmosphere: its speed of sound gives the Mach number')
    if len(grids[2]) and grids[2][0] < 0.0:
        check.fail(f'{key}.mach', f'starts at {grids[2][0]:g}', 'Mach numbers >= 0')
    _complete(check, spec, key)
    given = [True, 'beta_deg' in spec, 'mach' in spec]
    table = _coefficients(check, spec, key, grids, given)
    damping = np.array([check.number(spec.get(d, 0.0), f'{key}.{d}')
                        for d in DAMPING_DERIVATIVES])
    proximity = None
    if 'proximity' in spec:
        proximity = _parse_proximity(context, spec['proximity'], f'{key}.proximity', body)
    # multipliers of the coefficients, damping derivatives and increments, and increments
    # added after interpolation and scale (what a study varies): applied last (aeroscale)
    factors, added = factors_of(check, spec, key)
    if proximity is not None and 'mach' in proximity.axes and altitude is None:
        check.fail(f'{key}.density', 'is given with a proximity table over Mach',
                   'altitude (m): the ISA speed of sound there gives the Mach number')
    refuse_lone_increments(check, factors, proximity, key)
    outside = spec.get('outside', 'hold')
    if outside not in OUTSIDE:
        check.fail(f'{key}.outside', f'is {outside!r:.80}',
                   'hold (the tables held at their edges) or stop (the run ends there)')
    reference = check.vector(spec.get('reference_point', [0.0, 0.0, 0.0]),
                             f'{key}.reference_point')
    cg_offset = np.asarray(getattr(context.bodies[body], 'cg_offset', np.zeros(3)), float)
    aero = Aero(body=body, area=check.number(spec['area'], f'{key}.area', positive=True),
                length=check.number(spec['length'], f'{key}.length', positive=True),
                density=density, freestream=air, alpha=np.radians(grids[0]),
                beta=np.radians(grids[1]), coefficients=table, damping=damping,
                mach=grids[2], altitude=altitude, proximity=proximity,
                temperature_offset=offset, reference_point=np.asarray(reference, float),
                reference_from_cg=np.asarray(reference, float) - cg_offset,
                delta=np.zeros(len(AERO_COEFFICIENTS)),
                stop_outside=outside == 'stop', zero=tuple(spec.get('zero', ())))
    return aero if context.unscaled else scaled(aero, factors, added)


def _atmosphere(check, spec: dict, key: str) -> tuple:
    """Return (altitude m or None, temperature offset K) of ``altitude`` or ``atmosphere``."""
    if 'density' in spec:
        return None, 0.0
    if 'altitude' in spec:
        where, altitude, offset = f'{key}.altitude', spec['altitude'], 0.0
    else:
        doc = check.mapping(spec['atmosphere'], f'{key}.atmosphere', ATMOSPHERE_KEYS,
                            required=('altitude',))
        where, altitude = f'{key}.atmosphere.altitude', doc['altitude']
        offset = check.number(doc.get('temperature_offset', 0.0),
                              f'{key}.atmosphere.temperature_offset')
        if not OFFSET_RANGE[0] <= offset <= OFFSET_RANGE[1]:
            check.fail(f'{key}.atmosphere.temperature_offset', f'is {offset:g}',
                       f'K added to the ISA temperature, from {OFFSET_RANGE[0]:g} to '
                       f'{OFFSET_RANGE[1]:g}')
    altitude = check.number(altitude, where)
    if not ALTITUDE_RANGE[0] <= altitude <= ALTITUDE_RANGE[1]:
        check.fail(where, f'is {altitude:g}',
                   f'an altitude from {ALTITUDE_RANGE[0]:g} to {ALTITUDE_RANGE[1]:g} m (ISA)')
    return altitude, offset


def _complete(check, spec: dict, key: str):
    """
    Refuse an aero entry that leaves a coefficient out without saying it is meant to be zero.

    A coefficient left out would be zero (SPEC section 10): a forgotten
    ``Cm`` would give a store no pitching moment without a word, so every
    one of CX, CY, CZ, Cl, Cm, Cn has a table or a value, or is listed in
    ``zero``; one listed there and given too is refused (which is meant?).
    """
    zero = spec.get('zero', [])
    if not isinstance(zero, list):
        check.fail(f'{key}.zero', f'is {zero!r:.80}',
                   'a list of coefficients meant to be zero, from ' + ', '.join(AERO_COEFFICIENTS))
    for i, name in enumerate(zero):
        if name not in AERO_COEFFICIENTS:
            check.fail(f'{key}.zero[{i}]', f'is {name!r:.80}', 'one of '
                       + ', '.join(AERO_COEFFICIENTS))
        if name in zero[:i]:
            check.fail(f'{key}.zero[{i}]', f'repeats {name}', 'each coefficient once')
        if name in spec:
            check.fail(f'{key}.zero[{i}]', f'is {name}, and {key}.{name} is given too',
                       f'either a table or value for {name} or {name} in zero, not both')
    missing = [c for c in AERO_COEFFICIENTS if c not in spec and c not in zero]
    if missing:
        one = len(missing) == 1
        listed = ', '.join(missing)
        check.fail(f'{key}.{listed}' if one else key,
                   f'missing, and {key}.zero does not list it' if one else
                   f'gives no {listed}, and {key}.zero does not list them',
                   f'a table or a value for {listed}, or {key}.zero: '
                   f'[{", ".join(zero + missing)}] if {"it is" if one else "they are"} '
                   'meant to be zero (a coefficient left out is not taken as zero)')


def _body_altitude(context: _Context, body: int, altitude: float, given: str):
    body_altitude(context.check, context.gravity, context.bodies[body], altitude, given)


def altitude_key(spec: dict, key: str) -> str:
    """Return the key path an aero entry gives its altitude at."""
    return f'{key}.atmosphere.altitude' if 'atmosphere' in spec else f'{key}.altitude'


def body_altitude(check, gravity, body, altitude: float, given: str):
    """Refuse a body whose own altitude at t = 0 is beyond the standard atmosphere."""
    norm = float(np.linalg.norm(gravity))
    up = -gravity / norm if norm > 0.0 else np.zeros(3)
    position = np.asarray(body.position, dtype=float)
    own = altitude + float(up @ position)   # as the kernel: its height along -gravity
    if STANDARD_RANGE[0] <= own <= STANDARD_RANGE[1]:
        return
    name = body.name
    check.fail(f'bodies.{name}.position', f'puts {name} at {own:.6g} m ({given} '
               f'{altitude:g} m at the world origin, {own - altitude:+.6g} m from '
               'there along -gravity), beyond the standard atmosphere',
               f'a body from {STANDARD_RANGE[0]:g} to {STANDARD_RANGE[1]:g} m '
               '(the 1976 standard, geopotential)')


def _grid(check, values, key: str, what: str, angles: bool) -> np.ndarray:
    """Return a strictly increasing list of numbers (angles within +-180 deg)."""
    if not isinstance(values, list) or not values:
        check.fail(key, f'is {values!r:.80}', f'a list of {what}')
    grid = np.array([check.number(v, f'{key}[{i}]') for i, v in enumerate(values)])
    if np.any(np.diff(grid) <= 0):
        check.fail(key, f'is {values!r:.80}', f'strictly increasing {what}')
    if angles and (grid[0] < -180.0 or grid[-1] > 180.0):
        check.fail(key, f'is {values!r:.80}', 'angles from -180 to 180 deg')
    return grid


def _coefficients(check, spec: dict, key: str, grids, given) -> np.ndarray:
    """
    Return the (alpha, beta, Mach, 6) table of the free-stream coefficients.

    A coefficient is a number, or lists nested alpha, then beta (if given),
    then Mach (if given); fewer levels are constant along the levels left out.
    """
    sizes = [len(g) for g in grids]
    nested = [len(g) for g, is_given in zip(grids, given) if is_given]
    names = [n for n, is_given in zip(('alpha', 'beta', 'Mach'), given) if is_given]
    table = np.zeros(tuple(sizes) + (6,))
    for c, coefficient in enumerate(AERO_COEFFICIENTS):
        value = spec.get(coefficient, 0.0)
        where = f'{key}.{coefficient}'
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            table[..., c] = check.number(value, where)
            continue
        try:
            rows = np.array(value, dtype=object)
        except ValueError:   # ragged lists
            rows = np.array([None])
        shape = rows.shape
        if not value or len(shape) > len(nested) or list(shape) != nested[:len(shape)]:
            levels = ', then '.join(f'{n} values per {name}' for n, name in zip(nested, names))
            check.fail(where, f'has shape {shape}',
                       f'a number or lists nested as the grids: {levels} (trailing levels '
                       'may be left out)')
        numbers = np.empty(shape)
        for at, v in np.ndenumerate(rows):
            numbers[at] = check.number(v, where + ''.join(f'[{i}]' for i in at))
        # the levels map onto the given axes in order; the others are held constant
        levels = iter(shape)
        full = [next(levels, 1) if is_given else 1 for is_given in given]
        table[..., c] = np.broadcast_to(numbers.reshape(full), tuple(sizes))
    return table


def _parse_proximity(context: _Context, doc, key: str, body: int) -> Proximity:
    check = context.check
    doc = check.mapping(doc, key, PROXIMITY_KEYS, required=('carrier', 'table', 'outside'))
    carrier = _body_of(context, doc['carrier'], f'{key}.carrier')
    if carrier == body:
        check.fail(f'{key}.carrier', f'is {doc["carrier"]!r}, the body itself',
                   'the body whose flow field the table describes (the aircraft, the pylon)')
    outside = doc['outside']
    fade = None
    if outside != 'hold':
        if not isinstance(outside, dict) or list(outside) != ['fade']:
            check.fail(f'{key}.outside', f'is {outside!r:.80}',
                       'hold, or {fade: m} (the increments fade to zero over that distance)')
        fade = check.number(outside['fade'], f'{key}.outside.fade', positive=True)
    path = doc['table']
    if not isinstance(path, str) or not path.strip():
        check.fail(f'{key}.table', f'is {path!r:.80}', 'a CSV or Parquet file name')
    path = path if os.path.isabs(path) else os.path.join(context.base_dir, path)
    columns = read_columns(check, path, f'{key}.table')
    axes, grids, increments = grid_of(check, columns, f'{key}.table', path)
    if fade is not None and not any(a in POSITION_AXES for a in axes):
        check.fail(f'{key}.outside', 'fades over a distance, and the table has no position '
                   'axis (dx, dy, dz)', 'hold, or a table over positions')
    return Proximity(carrier=carrier, axes=axes, grids=grids, increments=increments,
                     fade=fade, source=path)


def read_columns(check, path: str, key: str) -> dict:
    """Return a table file's columns by name (CSV with a header row, or Parquet)."""
    shown = os.path.basename(path)
    if not os.path.isfile(path):
        check.fail(key, f'names {path!r:.200}, which is not a file',
                   'a CSV or Parquet file, relative to the scenario file')
    if path.lower().endswith(('.parquet', '.pq')):
        try:
            import pyarrow.parquet as pq
        except ImportError:
            check.fail(key, f'{shown} is Parquet and pyarrow is not installed',
                       "pip install 'cfem_ros[study]', or the table as CSV")
        try:
            data = pq.read_table(path)
        except Exception as err:  # noqa: B902 - any reader error is the file's fault
            check.fail(key, f'{shown} is not a readable Parquet file ({_one_line(err)})',
                       'a Parquet file with one column per axis and increment')
        return _parquet_columns(check, data, key, shown)
    with open(path, encoding='utf-8-sig', errors='replace') as handle:   # a BOM is no name
        lines = [ln for ln in handle.read().splitlines()
                 if ln.strip() and not ln.lstrip().startswith('#')]
    if not lines:
        check.fail(key, f'{shown} is empty', 'a header row naming the columns, then numbers')
    header = [h.strip() for h in lines[0].split(',')]
    _distinct_columns(check, header, key, shown)
    if len(lines) < 2:
        check.fail(key, f'{shown} has a header and no data rows',
                   'a row of numbers per grid point')
    values = np.empty((len(lines) - 1, len(header)))
    for r, line in enumerate(lines[1:]):
        cells = line.split(',')
        if len(cells) != len(header):
            check.fail(key, f'{shown}, data row {r + 1} has {len(cells)} cells',
                       f'{len(header)} numbers, one per column of the header')
        for c, cell in enumerate(cells):
            try:
                values[r, c] = float(cell)
            except ValueError:
                check.fail(key, f'{shown}, data row {r + 1}, column {header[c]!r} is '
                           f'{cell.strip()!r:.40}', 'a number')
    return {name: values[:, c] for c, name in enumerate(header)}


def _one_line(err) -> str:
    return ' '.join(str(err).split())[:200]


def _distinct_columns(check, names, key: str, shown: str):
    """Refuse a table that names a column twice (which of the two would be used?)."""
    seen = set()
    for name in names:
        if name in seen:
            check.fail(key, f'{shown} has the column {name!r:.40} twice', 'each column once')
        seen.add(name)


def _parquet_columns(check, data, key: str, shown: str) -> dict:
    """Return a Parquet table's columns as floats; only number columns, at least one row."""
    import pyarrow as pa
    _distinct_columns(check, data.column_names, key, shown)
    for name, kind in zip(data.column_names, data.schema.types):
        if not (pa.types.is_integer(kind) or pa.types.is_floating(kind)):
            check.fail(key, f'{shown}: column {name!r:.40} holds {kind}',
                       'numbers (integer or floating point) in every column')
    if data.num_rows == 0:
        check.fail(key, f'{shown} has no rows', 'a row of numbers per grid point')
    columns = {}
    for name in data.column_names:
        column = data.column(name)
        if column.null_count:
            check.fail(key, f'{shown}: column {name!r:.40} has {column.null_count} empty '
                       'cell(s)', 'a number in every cell')
        columns[name] = np.asarray(column.to_numpy(), dtype=float)
    return columns


def grid_of(check, columns: dict, key: str, path: str) -> tuple:
    """
    Return (axes, grids, increments) of a long-format table's columns.

    increments has shape (len(grid) per axis ..., 6), zero for the
    increments the table does not give. Raises the checker's error for an
    unknown or repeated column, a non-finite number, a point given twice or
    the first point of the full grid that is missing.
    """
    shown = os.path.basename(path)
    for name in columns:
        if name not in PROXIMITY_AXES + INCREMENTS:
            check.fail(key, f'{shown} has a column {name!r:.40}',
                       'axis columns from ' + ', '.join(PROXIMITY_AXES)
                       + ' and increment columns from ' + ', '.join(INCREMENTS))
    axes = tuple(a for a in PROXIMITY_AXES if a in columns)
    given = [d for d in INCREMENTS if d in columns]
    if not axes or not given:
        check.fail(key, f'{shown} has columns {list(columns)!r:.120}',
                   'at least one axis column (' + ', '.join(PROXIMITY_AXES)
                   + ') and one increment column (' + ', '.join(INCREMENTS) + ')')
    rows = len(columns[axes[0]])
    for name, values in columns.items():
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            check.fail(key, f'{shown}, data row {bad[0] + 1}, column {name} is '
                       f'{values[bad[0]]}', 'a finite number')
    grids = tuple(np.unique(columns[a]) for a in axes)
    sizes = tuple(len(g) for g in grids)
    count = math.prod(sizes)
    if count > MAX_GRID_POINTS:
        check.fail(key, f'{shown} spans {count} grid points', f'at most {MAX_GRID_POINTS}')
    for a, g in zip(axes, grids):
        if len(g) < 2:
            check.fail(key, f'{shown}: axis {a} has the one value {g[0]:g}',
                       'two values or more per axis (leave a constant axis out)')
    where = np.stack([np.searchsorted(g, columns[a]) for a, g in zip(axes, grids)])
    flat = np.ravel_multi_index(where, sizes)
    seen = np.zeros(count, dtype=np.int64)
    np.add.at(seen, flat, 1)
    twice = np.flatnonzero(seen > 1)
    if twice.size:
        row = int(np.flatnonzero(flat == twice[0])[1])
        check.fail(key, f'{shown}, data row {row + 1} repeats the grid point '
                   f'{_point(axes, grids, twice[0], sizes)}', 'each grid point once')
    missing = np.flatnonzero(seen == 0)
    if missing.size:
        check.fail(key, f'{shown} has {rows} rows for a grid of {count} points and misses '
                   f'{_point(axes, grids, missing[0], sizes)} (the first missing, the axes '
                   f'nested {", ".join(axes)})', 'a full regular grid: one row per point')
    increments = np.zeros(sizes + (6,))
    for c, name in enumerate(INCREMENTS):
        if name in columns:
            increments.reshape(count, 6)[flat, c] = columns[name]
    return axes, grids, increments


def _point(axes, grids, flat: int, sizes) -> str:
    at = np.unravel_index(flat, sizes)
    return ', '.join(f'{a}={g[i]:g}' for a, g, i in zip(axes, grids, at))


def describe(aero: Aero, names) -> Optional[str]:
    """Return one line on an aero entry's day, data and tables beyond the basics (``check``)."""
    parts = []
    if aero.zero:   # said, so that a table missing a coefficient never reads as complete
        parts.append(f'zero (as the scenario says): {", ".join(aero.zero)}')
    if aero.temperature_offset:
        parts.append(f'ISA {aero.temperature_offset:+g} K (pressure ISA)')
    if np.any(aero.reference_point):
        r = aero.reference_point
        parts.append(f'moments about [{r[0]:g}, {r[1]:g}, {r[2]:g}] m from the nominal CG')
    if np.any(aero.delta):
        added = zip(AERO_COEFFICIENTS, aero.delta)
        parts.append('delta ' + ', '.join(f'{c} {d:+g}' for c, d in added if d))
    parts.append('outside the tables: ' + ('stop' if aero.stop_outside else 'hold'))
    if len(aero.mach) > 1:
        parts.append(f'Mach {aero.mach[0]:g} to {aero.mach[-1]:g} ({len(aero.mach)} values)')
    if aero.proximity is not None:
        p = aero.proximity
        fade = 'held' if p.fade is None else f'fading over {p.fade:g} m'
        parts.append(f'proximity to {names[p.carrier]} over {", ".join(p.axes)} '
                     f'({p.increments[..., 0].size} points, {fade} outside)')
    return '; '.join(parts) or None
