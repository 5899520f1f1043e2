# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Which metrics of a sweep table differ by rounding only (drawn as one value, not ranked).

A metric zero by symmetry (a lateral offset, a hinge's moment about its
free axis) takes values of about 1e-17 m or 1e-13 N m that differ from run
to run by rounding. Judged against its own size they would look like a
spread; judged against the size of its quantity (the other states of the
same unit at that time, the joint's force on a 1 m lever arm) they are one
value.
"""

from __future__ import annotations

from cfem_ros.core.engine.events import Status
from cfem_ros.study.labels import unit
import numpy as np

#: Values that differ by less than this times their scale are equal (as plots.ROUNDING).
ROUNDING = 1e-9


def at_rounding_level(values: np.ndarray, scale: float = 0.0) -> bool:
    """
    Return whether values spread by no more than ROUNDING x their size.

    Their size is their largest magnitude, or scale if larger: the size of
    the quantity they belong to (``family_scale``), so that values that
    are all rounding around zero (a lateral offset of 1e-17 m when the
    store falls 0.4 m) are one value too.
    """
    if not len(values):
        return False
    size = max(float(np.abs(values).max()), abs(scale))
    return float(values.max() - values.min()) <= ROUNDING * size


def family_scale(table, column: str, document=None) -> float:
    """
    Return the largest magnitude over the metrics of the same unit and kind as column.

    The states at a time share one scale per unit (m, deg), the other
    metrics one per unit: what a component zero by symmetry is rounding of.
    """
    own = unit(column, document)
    if not own:
        return 0.0
    kind = column.split('_at_')[0] if '_at_' in column else None
    ok = (table['status'] == Status.OK).to_numpy()
    size = 0.0
    for name in table.columns:
        if name in ('run', 'status', 'message') or table[name].dtype.kind != 'f' \
                or unit(name, document) != own or is_key_path(name):
            continue
        if kind is not None and name.split('_at_')[0] != kind:
            continue
        values = np.abs(table.loc[ok, name].to_numpy(dtype=float))
        values = values[np.isfinite(values)]
        if len(values):
            size = max(size, float(values.max()))
    return size


def is_key_path(name: str) -> bool:
    """Return whether a column is a varied key path, not a metric (a state at a time)."""
    return name == 'dt' or (('.' in name or '[' in name) and '_at_' not in name)


def rounding_only(table, column: str, document=None) -> bool:
    """
    Return whether a metric's values over the finished runs differ by rounding only.

    A joint's peak moment is judged against its peak force on a 1 m lever
    arm as well; any other metric against ``family_scale``.
    """
    ok = (table['status'] == Status.OK).to_numpy()
    values = table.loc[ok, column].to_numpy(dtype=float)
    values = values[np.isfinite(values)]
    scale = family_scale(table, column, document)
    force = 'peak_force_' + column[len('peak_moment_'):]
    if column.startswith('peak_moment_') and force in table:
        forces = np.abs(table.loc[ok, force].to_numpy(dtype=float))
        forces = forces[np.isfinite(forces)]
        scale = max([scale] + ([float(forces.max())] if len(forces) else []))
    return at_rounding_level(values, scale)
