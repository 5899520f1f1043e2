# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
One unit per quantity in every output table (SPEC section 15), and the Parquet metadata saying it.

A body's state is written in the same units wherever a person reads it:
an export's ``<body>_p``, a sweep's ``<body>_max_p`` and ``stroke_<w>_p``
and the log line of ``cfem-sim run`` all give body rates in deg/s, angles
in deg (with ``_deg`` in the column's name), positions in m. The tables
take their units from here, and a Parquet file carries each column's unit
as the field metadata ``unit``. A CSV has no metadata: its header gives
each number column's unit after its name, ``store_q [deg/s]``
(``csv_header``), a number without a unit ``[1]`` (``mach [1]``), a text
column its bare name (``status``). A reader of the package's CSVs
(``bare_columns``) takes either ``name [unit]`` or the bare ``name``, and
refuses a bracketed unit other than the one it expects.
"""

from __future__ import annotations

import re
from typing import Optional

from cfem_ros.recording.errors import RecordingError

__all__ = ['BODY', 'JOINT', 'AERO', 'RELATIVE', 'ANGLE', 'RATE', 'bare_columns', 'csv_header',
           'read_csv', 'read_units', 'with_units']

#: The units of angles and angular rates wherever a person reads them.
ANGLE = 'deg'
RATE = 'deg/s'
#: A body's state after ``<body>_`` (export) or ``<body>_at_<t>_``, ``<body>_min_`` (sweeps):
#: CG position (m), attitude Z-Y-X (deg), CG velocity (m/s) and body rates, body axes.
BODY = {'x': 'm', 'y': 'm', 'z': 'm', 'roll_deg': ANGLE, 'pitch_deg': ANGLE,
        'yaw_deg': ANGLE, 'u': 'm/s', 'v': 'm/s', 'w': 'm/s', 'p': RATE, 'q': RATE,
        'r': RATE}
#: With a carrier (``--relative-to``), after ``<body>_``: the CG's velocity seen from the
#: carrier, in its axes (``relative.relative_velocity``).
RELATIVE = {'u_rel': 'm/s', 'v_rel': 'm/s', 'w_rel': 'm/s'}
#: A joint's load after ``<joint>_``: force (N) and moment about the joint point (N m).
JOINT = {'fx': 'N', 'fy': 'N', 'fz': 'N', 'mx': 'N m', 'my': 'N m', 'mz': 'N m'}
#: An aero body's air data after ``<body>_``.
AERO = {'alpha_deg': ANGLE, 'beta_deg': ANGLE, 'mach': '', 'dynamic_pressure': 'Pa'}
#: Parquet field metadata key of a column's unit ('' for a number without one).
KEY = b'unit'
#: A CSV header's unit for a number without one.
DIMENSIONLESS = '1'
#: A CSV header with its unit: the name, one space, the unit in brackets at the end.
HEADER = re.compile(r'^(?P<name>.*\S) \[(?P<unit>[^\[\]]*)\]$')


def with_units(table, units: Optional[dict]):
    """
    Return a pandas DataFrame as a pyarrow Table whose fields carry their units.

    Parameters
    ----------
    table : pandas.DataFrame
        The table to write.
    units : dict of str to str, optional
        Column -> unit ('' dimensionless); a column not in it has no
        metadata (a text column, an index).

    """
    import pyarrow as pa
    arrow = pa.Table.from_pandas(table, preserve_index=False)
    if not units:
        return arrow
    fields = [f.with_metadata({KEY: units[f.name].encode()}) if f.name in units else f
              for f in arrow.schema]
    return arrow.cast(pa.schema(fields, metadata=arrow.schema.metadata))


def read_units(path: str) -> dict:
    """Return {column: unit} of a Parquet file's fields that say their unit."""
    import pyarrow.parquet as pq
    schema = pq.read_schema(path)
    return {f.name: f.metadata[KEY].decode() for f in schema
            if f.metadata and KEY in f.metadata}


def csv_header(name: str, unit: Optional[str]) -> str:
    """Return a CSV column's header: ``name [unit]``, ``name [1]`` for '' and name for None."""
    if unit is None:
        return name
    return f'{name} [{unit or DIMENSIONLESS}]'


def bare_columns(path: str, headers, expected: dict) -> list:
    """
    Return a CSV's column names without their units, checking the units given.

    Parameters
    ----------
    path : str
        The CSV file (named in the error).
    headers : iterable of str
        Its header, as read (``name`` or ``name [unit]``).
    expected : dict of str to str
        Column -> the unit the reader takes ('' dimensionless: ``[1]`` or
        ``[]``); a column not in it keeps any bracketed unit unchecked.

    Raises
    ------
    RecordingError
        If a column of expected says another unit in its header.

    """
    names = []
    for header in headers:
        header = str(header)
        match = HEADER.match(header)
        if match is None:
            names.append(header)
            continue
        name, unit = match['name'], match['unit'].strip()
        want = expected.get(name)
        if want is not None and unit != want and not (want == '' and unit in ('', DIMENSIONLESS)):
            raise RecordingError(
                f"{path}: column '{header}' is in {unit or '(no unit)'}; expected "
                f"{want or DIMENSIONLESS} ('{csv_header(name, want)}' or '{name}')")
        names.append(name)
    return names


def read_csv(path: str, expected: Optional[dict] = None):
    """
    Return a CSV the package wrote as a pandas DataFrame whose columns have their bare names.

    expected: {column: unit} to check in the header (``bare_columns``);
    raises RecordingError on another unit.
    """
    import pandas as pd
    table = pd.read_csv(path, encoding='utf-8-sig')
    table.columns = bare_columns(path, table.columns, expected or {})
    return table
