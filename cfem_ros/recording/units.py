# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
One unit per quantity in every output table (SPEC section 15), and the Parquet metadata saying it.

A body's state is written in the same units wherever a person reads it:
an export's ``<body>_p``, a sweep's ``<body>_max_p`` and ``stroke_<w>_p``
and the log line of ``cfem-sim run`` all give body rates in deg/s, angles
in deg (with ``_deg`` in the column's name), positions in m. The tables
take their units from here, and a Parquet file carries each column's unit
as the field metadata ``unit`` (a CSV's column has the same name, so the
same unit: the guide's tables list them).
"""

from __future__ import annotations

from typing import Optional

__all__ = ['BODY', 'JOINT', 'AERO', 'ANGLE', 'RATE', 'with_units']

#: The units of angles and angular rates wherever a person reads them.
ANGLE = 'deg'
RATE = 'deg/s'
#: A body's state after ``<body>_`` (export) or ``<body>_at_<t>_``, ``<body>_min_`` (sweeps):
#: CG position (m), attitude Z-Y-X (deg), CG velocity (m/s) and body rates, body axes.
BODY = {'x': 'm', 'y': 'm', 'z': 'm', 'roll_deg': ANGLE, 'pitch_deg': ANGLE,
        'yaw_deg': ANGLE, 'u': 'm/s', 'v': 'm/s', 'w': 'm/s', 'p': RATE, 'q': RATE,
        'r': RATE}
#: A joint's load after ``<joint>_``: force (N) and moment about the joint point (N m).
JOINT = {'fx': 'N', 'fy': 'N', 'fz': 'N', 'mx': 'N m', 'my': 'N m', 'mz': 'N m'}
#: An aero body's air data after ``<body>_``.
AERO = {'alpha_deg': ANGLE, 'beta_deg': ANGLE, 'mach': '', 'dynamic_pressure': 'Pa'}
#: Parquet field metadata key of a column's unit ('' for a number without one).
KEY = b'unit'


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
