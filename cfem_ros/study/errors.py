# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The sweep file's error, and the small checks its parsers share."""

from __future__ import annotations

import math

from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio.messages import show


class SweepError(ScenarioError):
    """A sweep file that cannot be run (file, key path, problem, expected)."""


def number_list(fail, key, value, length=None):
    if not isinstance(value, list) or (length is not None and len(value) != length):
        fail(key, f'is {show(value)}', f'a list of {length} numbers' if length
             else 'a list of numbers')
    for v in value:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            fail(key, f'holds {show(v)}', 'finite numbers')
    return [float(v) for v in value]
