# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A run's time histories as one table (``cfem-sim export``, SPEC section 12).

Everything comes from the recording: the recorded poses and twists,
composed into another body's axes with ``--relative-to``
(``relative.relative_pose``), the joints' loads as published in their
frames, and each aero body's alpha, beta, Mach and dynamic pressure
computed from its recorded state with the scenario's air (the scenario
named in the recording's metadata). Nothing is simulated again.

Columns: ``time`` (s), with a reference also ``time_from_release`` (s,
NaN before the first release); per body ``<body>_x, _y, _z`` (m),
``_roll_deg, _pitch_deg, _yaw_deg`` (Z-Y-X), ``_u, _v, _w`` (m/s, CG
velocity relative to the world in body axes), ``_p, _q, _r`` (deg/s,
body axes), with a reference also ``_u_rel, _v_rel, _w_rel`` (m/s, the
CG's velocity seen from the reference, in its axes:
``relative.relative_velocity``); per joint ``<joint>_fx, _fy, _fz`` (N)
and ``_mx, _my, _mz`` (N m about the joint point), joint frame, NaN once
released; per aero body ``<body>_alpha_deg, _beta_deg, _mach,
_dynamic_pressure`` (Pa). With a reference and a point (``--point
carriage`` or ``[x, y, z]``, ``carriage.carrier_offsets``) the positions
are from that point of the reference instead of its CG.

Units: a Parquet file says each column's unit in its field metadata
(``unit``), a CSV in its header after the name (``store_q [deg/s]``,
``[1]`` for a number without one: ``units.csv_header``); the names are
the same in both.
"""

from __future__ import annotations

import math
import os
from typing import Optional
import uuid

from cfem_ros.core import rotations
from cfem_ros.recording.carriage import carrier_offsets, scenario_model
from cfem_ros.recording.errors import RecordingError
from cfem_ros.recording.relative import matching, relative_pose, relative_velocity, release_time
from cfem_ros.recording.units import AERO, BODY, csv_header, JOINT, RELATIVE, with_units
import numpy as np

__all__ = ['BODY_COLUMNS', 'JOINT_COLUMNS', 'AERO_COLUMNS', 'RELATIVE_COLUMNS', 'export_table',
           'write_table']

BODY_COLUMNS = tuple(BODY)
JOINT_COLUMNS = tuple(JOINT)
AERO_COLUMNS = tuple(AERO)
RELATIVE_COLUMNS = tuple(RELATIVE)
FORMATS = ('.csv', '.parquet')


def _sample_stamps(run, rate: Optional[float]) -> np.ndarray:
    """Return the stamps of the rows: every pose sample, or those on multiples of 1/rate."""
    stamps = np.unique(np.concatenate([b.stamp_ns for b in run.bodies.values()]))
    if rate is None:
        return stamps
    if not (isinstance(rate, (int, float)) and math.isfinite(rate) and rate > 0):
        raise RecordingError(f'--rate {rate}: expected a rate > 0 Hz')
    recorded = run.metadata.get('rate_hz', '')
    try:
        faster = float(recorded) > 0 and rate > float(recorded) * (1 + 1e-9)
    except ValueError:
        faster = False
    if faster:   # refused before its count of missing times, which may have 300 digits
        raise RecordingError(f"{run.path}: --rate {rate:.6g}: faster than the recording's "
                             f'{float(recorded):g} Hz; expected a rate that divides it (rows '
                             'are recorded samples, never interpolated)')
    since = stamps - run.start_ns
    step_ns = 1e9 / rate   # inf below 1e-300 Hz: then only t = 0 is on the grid
    off = np.mod(since, step_ns)
    kept = stamps[(off <= 0.5) | (step_ns - off <= 0.5)]
    wanted = int(math.floor(since[-1] / step_ns + 1e-9)) + 1 if len(since) else 0
    if len(kept) < wanted:
        raise RecordingError(
            f'{run.path}: --rate {rate:g}: {wanted - len(kept)} of the times k/{rate:g} s '
            f'have no recorded sample (recorded at {recorded or "another rate"} Hz); expected '
            "a rate that divides the recording's (rows are recorded samples, never "
            'interpolated)')
    return kept


def _fill(n: int, width: int, rows: np.ndarray, values: np.ndarray) -> np.ndarray:
    out = np.full((n, width), np.nan)
    out[rows] = values
    return out


def _body_block(run, name: str, stamps: np.ndarray, reference: Optional[str],
                point=None) -> np.ndarray:
    """
    Return a body's 12 columns at the stamps (NaN where it has no sample).

    With a reference, 15: then ``u_rel, v_rel, w_rel``, the positions from
    point (the reference's axes, m; its CG if None; NaN to leave them NaN).
    """
    track = run.bodies[name]
    rows, mine = matching(stamps, track.stamp_ns)
    position, quaternion = track.position[mine], track.quaternion[mine]
    extra = []
    if reference is not None:
        ref = run.bodies[reference]
        ref_rows, theirs = matching(stamps, ref.stamp_ns)
        both, here, there = np.intersect1d(rows, ref_rows, return_indices=True)
        rows, mine, theirs = both, mine[here], theirs[there]
        position, quaternion = relative_pose(track.position[mine], track.quaternion[mine],
                                             ref.position[theirs], ref.quaternion[theirs])
        if point is not None:
            position = position - np.asarray(point, dtype=float)
        extra = [relative_velocity(track, ref, mine, theirs)]
    euler = rotations.to_rpy_deg(quaternion) if len(rows) else np.zeros((0, 3))
    values = np.column_stack([position, euler, track.velocity[mine],
                              np.degrees(track.rates[mine])] + extra)
    return _fill(len(stamps), values.shape[1], rows, values)


def _joint_block(run, name: str, stamps: np.ndarray) -> np.ndarray:
    track = run.joint_frame[name]
    rows, mine = matching(stamps, track.stamp_ns)
    return _fill(len(stamps), 6, rows, np.column_stack([track.force[mine], track.moment[mine]]))


def aero_blocks(run, stamps: np.ndarray, model) -> dict:
    """
    Return per aero body its (n, 4) alpha (deg), beta (deg), Mach, dynamic pressure (Pa).

    From the recorded pose and twist (the air of the scenario: wind,
    altitude, ISA), through the compiled core's ``aero_wrench`` (``core.native.kernel``).
    """
    from cfem_ros.core.engine import aeropack
    from cfem_ros.core.native import kernel
    out = {}
    for aero in model.aero:
        name = model.bodies[aero.body].name
        track = run.bodies.get(name)
        if track is None:
            continue
        rows, mine = matching(stamps, track.stamp_ns)
        k = len(rows)
        carrier_position, carrier_rot = np.zeros((k, 3)), np.tile(np.eye(3).reshape(9), (k, 1))
        if aero.proximity is not None:
            carrier = run.bodies.get(model.bodies[aero.proximity.carrier].name)
            if carrier is not None:
                c_rows, theirs = matching(stamps, carrier.stamp_ns)
                keep = np.isin(rows, c_rows)
                rows, mine = rows[keep], mine[keep]
                at = np.searchsorted(c_rows, rows)
                carrier_position = carrier.position[theirs[at]]
                carrier_rot = rotations.matrices(carrier.quaternion[theirs[at]]).reshape(-1, 9)
        rot = rotations.matrices(track.quaternion[mine]).reshape(-1, 9)
        _, air = kernel.aero_wrench(
            aeropack.pack(aero, model), np.ascontiguousarray(track.position[mine]),
            np.ascontiguousarray(track.velocity_world[mine]), np.ascontiguousarray(rot),
            np.ascontiguousarray(track.rates[mine]), np.ascontiguousarray(carrier_position),
            np.ascontiguousarray(carrier_rot))
        columns = kernel.AERO_AIR   # the kernel's own dynamic pressure, not a copy of it
        values = np.column_stack([np.degrees(air[:, columns.W_ALPHA]),
                                  np.degrees(air[:, columns.W_BETA]), air[:, columns.W_MACH],
                                  air[:, columns.W_PRESSURE]])
        out[name] = _fill(len(stamps), 4, rows, values)
    return out


def export_table(run, relative_to: Optional[str] = None, rate: Optional[float] = None,
                 warn=None, point=None):
    """
    Return a recording's time histories as a pandas DataFrame (columns as the module says).

    Parameters
    ----------
    run : recording.analysis.Run
        The recording, read.
    relative_to : str, optional
        A body: the others' positions and attitudes in its axes (from its
        CG), and ``time_from_release``; the body itself is left out.
    rate : float, optional
        Keep only the samples at multiples of 1/rate s (a rate that divides
        the recording's).
    warn : callable, optional
        Called with a line when the aero columns cannot be made (the
        scenario file is gone), or a body has no ``carriage``.
    point : str or sequence of 3 floats, optional
        With relative_to: the positions from this point of it instead of
        its CG, ``'carriage'`` or [x, y, z] (``carriage.parse_point``).

    Raises
    ------
    RecordingError
        If relative_to is not a body of the recording, rate does not
        divide the recording's, or point is not a point of relative_to.

    """
    import pandas as pd
    if relative_to is not None and relative_to not in run.bodies:
        raise RecordingError(f'{run.path}: --relative-to {relative_to}: no such body in the '
                             f'recording; expected one of {", ".join(run.bodies)}')
    if point is not None and relative_to is None:
        raise RecordingError(f'{run.path}: --point {point}: without --relative-to; expected '
                             '--relative-to BODY (the carrier the point is on)')
    model = scenario_model(run)
    others = [name for name in run.bodies if name != relative_to]
    points = carrier_offsets(run, model, relative_to, point, others, warn)
    stamps = _sample_stamps(run, rate)
    time = (stamps - run.start_ns) / 1e9
    columns = {'time': time}
    if relative_to is not None:
        released = release_time(run)
        since = time - released
        since[~(time >= released - 0.5e-9)] = np.nan
        columns['time_from_release'] = since
    names = BODY_COLUMNS + (RELATIVE_COLUMNS if relative_to is not None else ())
    for name in others:
        block = _body_block(run, name, stamps, relative_to, points.get(name))
        columns.update((f'{name}_{c}', block[:, k]) for k, c in enumerate(names))
    order = [j.name for j in model.joints] if model is not None else []
    joints = [n for n in order if n in run.joint_frame] + [n for n in run.joint_frame
                                                           if n not in order]
    for name in joints:   # in the scenario's order
        block = _joint_block(run, name, stamps)
        columns.update((f'{name}_{c}', block[:, k]) for k, c in enumerate(JOINT_COLUMNS))
    aero = aero_blocks(run, stamps, model) if model is not None else {}
    if model is not None:
        for name, block in aero.items():
            columns.update((f'{name}_{c}', block[:, k]) for k, c in enumerate(AERO_COLUMNS))
    elif warn is not None and run.metadata.get('scenario'):
        warn(f'{run.path}: its scenario {run.metadata["scenario"]} cannot be read: no aero '
             'columns')
    table = pd.DataFrame(columns)
    table.attrs['units'] = export_units(table.columns, list(run.bodies), joints, list(aero))
    return table


def export_units(names, bodies, joints, aero) -> dict:
    """Return {column: unit} of an export's columns (``units.BODY``, ``JOINT``, ``AERO``)."""
    units = {'time': 's', 'time_from_release': 's'}
    for owners, table in ((bodies, BODY), (bodies, RELATIVE), (joints, JOINT), (aero, AERO)):
        units.update((f'{name}_{c}', u) for name in owners for c, u in table.items())
    return {name: units[name] for name in names if name in units}


def write_table(table, path: str) -> str:
    """Write a table as CSV (pandas) or Parquet (pyarrow) by path's extension, atomically."""
    extension = os.path.splitext(path)[1].lower()
    if extension not in FORMATS:
        raise RecordingError(f'-o {path}: unknown format {extension or "(no extension)"}; '
                             'expected FILE.csv or FILE.parquet')
    return write_frame(table, path, float_format='%.17g', units=table.attrs.get('units'))


def write_frame(table, path: str, float_format=None, units: Optional[dict] = None) -> str:
    """
    Write a DataFrame to Parquet (pyarrow), or CSV (pandas) for .csv, through a temporary file.

    float_format: the CSV's number format (pandas' default, shortest round trip, if None);
    units: {column: unit}, written as the Parquet fields' metadata (``units.with_units``)
    or, in a CSV, after each column's name (``units.csv_header``: ``store_q [deg/s]``).
    """
    tmp = f'{path}.tmp-{os.getpid()}-{uuid.uuid4().hex[:8]}'
    try:
        if path.lower().endswith('.csv'):   # T.CSV is CSV too, as write_table takes it
            header = [csv_header(c, (units or {}).get(c)) for c in table.columns]
            table.to_csv(tmp, index=False, float_format=float_format, header=header)
        else:
            import pyarrow.parquet as pq
            pq.write_table(with_units(table, units), tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return path
