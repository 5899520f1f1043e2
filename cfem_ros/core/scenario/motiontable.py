# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""A kinematic body's motion table (SPEC section 5): [t, x, y, z, qx, qy, qz, qw] rows or CSV."""

from __future__ import annotations

import os

from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio.messages import show
from cfem_ros.core.fileio.textfile import read_text
from cfem_ros.core.model.bodies import Body, Motion
from cfem_ros.core.model.model import Model
from cfem_ros.core.scenario.checker import Checker, MAX_MAGNITUDE, MIN_DT
import numpy as np

#: Columns of a motion table (a CSV file's header may name them in any order).
MOTION_COLUMNS = ('t', 'x', 'y', 'z', 'qx', 'qy', 'qz', 'qw')
#: How far a motion table's quaternion may be from unit length (it is normalized).
MOTION_QUATERNION_TOLERANCE = 1e-3


def motion_start(data: Motion):
    """Return a table motion's CG position and attitude at t = 0."""
    from cfem_ros.core.native import kernel, motion as trajectories  # noqa: F401 - kernel first
    probe = Model(name='', frame_id='', gravity=np.zeros(3), duration=1.0, dt=1.0,
                  baumgarte=0.0, bodies=(Body(
                      name='', fixed=False, mass=0.0, inertia=np.zeros((3, 3)),
                      position=np.zeros(3), orientation_xyzw=np.array([0.0, 0, 0, 1]),
                      velocity_world=np.zeros(3), rates_body=np.zeros(3), motion=data),),
                  joints=())
    position, _, quat, _, _, _ = trajectories.state_at(probe, 0.0)[0]
    return position, quat


def parse_motion_table(check: Checker, value, key: str):
    """Return the times, positions and unit quaternions of a motion table."""
    if isinstance(value, str):
        rows = _read_motion_csv(check, value, key)
    elif isinstance(value, list):
        rows = []
        for k, row in enumerate(value):
            rows.append(check.vector(row, f'{key}[{k}]', length=8))
        rows = np.array(rows, dtype=float).reshape(-1, 8)
    else:
        check.fail(key, f'is {show(value)}', 'a CSV file name or a list of rows '
                   '[t, x, y, z, qx, qy, qz, qw]')
    if len(rows) < 2:
        check.fail(key, f'has {len(rows)} row(s)', 'at least 2 rows')
    times = rows[:, 0]
    steps = np.diff(times)
    if not (steps >= MIN_DT).all():
        k = int(np.flatnonzero(~(steps >= MIN_DT))[0]) + 1
        check.fail(f'{key}[{k}]', f'has time {times[k]!r} s after {times[k - 1]!r} s',
                   f'strictly increasing times, at least {MIN_DT:g} s apart')
    if times[0] > 0.0:
        check.fail(f'{key}[0]', f'starts at {times[0]:g} s', 'a table that starts at or '
                   'before t = 0')
    norms = np.linalg.norm(rows[:, 4:8], axis=1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > MOTION_QUATERNION_TOLERANCE)
    if bad.size:
        k = int(bad[0])
        check.fail(f'{key}[{k}]', f'has a quaternion of norm {norms[k]:.9g}',
                   f'unit quaternions [qx, qy, qz, qw] (within {MOTION_QUATERNION_TOLERANCE:g})')
    return (times.copy(), rows[:, 1:4].copy(), rows[:, 4:8] / norms[:, None])


def _read_motion_csv(check: Checker, name: str, key: str) -> np.ndarray:
    """Read a motion table's CSV file, relative to the scenario's folder."""
    base = os.path.dirname(check.source) if os.path.isfile(check.source) else ''
    path = name if os.path.isabs(name) else os.path.join(base, name)
    try:
        text = read_text(path, path, what='a readable, regular CSV file')
    except ScenarioError as err:   # one message: the key, the file, what is wrong with it
        shown = show(name) if path == name else f'{show(name)} ({show(path)})'
        check.fail(key, f'{shown}: {err.problem}', err.expected)
    text = text.removeprefix('\ufeff')   # a byte order mark, as a scenario file may have
    lines = [line for line in text.splitlines() if line.strip() and not line.startswith('#')]
    order = list(range(8))
    if lines and not _numeric(lines[0].split(',')[0]):
        header = [h.strip() for h in lines[0].split(',')]
        missing = [c for c in MOTION_COLUMNS if c not in header]
        if missing:
            check.fail(key, f'{path}: the header lacks {", ".join(missing)}',
                       f'columns {", ".join(MOTION_COLUMNS)}')
        order = [header.index(c) for c in MOTION_COLUMNS]
        lines = lines[1:]
    rows = np.empty((len(lines), 8))
    for k, line in enumerate(lines):
        cells = [c.strip() for c in line.split(',')]
        try:
            values = [float(cells[i]) for i in order]
        except (IndexError, ValueError):
            check.fail(f'{key}[{k}]', f'{path}: row {show(line)}',
                       f'{len(order)} numbers {", ".join(MOTION_COLUMNS)}')
        if not np.isfinite(values).all():
            check.fail(f'{key}[{k}]', f'{path}: row {show(line)} is not finite',
                       'finite numbers')
        if max(abs(v) for v in values) > MAX_MAGNITUDE:
            check.fail(f'{key}[{k}]', f'{path}: row {show(line)} holds a magnitude beyond '
                       f'{MAX_MAGNITUDE:g}', f'times (s) and positions (m) of magnitude at most '
                       f'{MAX_MAGNITUDE:g}, as everywhere in a scenario')
        rows[k] = values
    return rows


def _numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
