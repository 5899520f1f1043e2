# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The layout the kernel and Python share is the extension's, whole and in one place.

``cpp/layout.hpp`` and ``cpp/workspace.hpp`` lay out every shared array;
Python reads each column, width and workspace part from the extension
(``kernel.LOADS``, ``kernel.views`` ...). These tests walk the exported tables
(a column that overlaps another, a part that does not add up) and the Python
sources (a column index written as a number of Python's own, which could drift).
"""

import math
import pathlib
import re

from cfem_ros.core import _kernel
from cfem_ros.core.engine import loads
from cfem_ros.core.native import kernel, motion
import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
LAYOUTS = {name: getattr(kernel, name.upper()) for name in _kernel.LAYOUT}


def _row_width(layout):
    """Return the numbers a row of the layout's array has (bodies: open-ended)."""
    return layout.numbers.get('WIDTH', math.inf)


@pytest.mark.parametrize('array', sorted(_kernel.LAYOUT))
def test_each_group_of_columns_fits_its_row_without_overlap(array):
    layout = LAYOUTS[array]
    assert layout.columns, array
    width = _row_width(layout)
    groups = {}
    for name, (group, first, span) in layout.columns.items():
        assert first >= 0 and span >= 0, name
        end = first + span if span else width
        assert end <= width, (array, name)
        groups.setdefault(group, []).append((first, end, name))
    shared = groups.pop('kind', [])   # loads: every row's kind, its last column
    for group, columns in groups.items():
        columns = sorted(columns + shared)
        for (_, end, name), (start, _, after) in zip(columns, columns[1:]):
            assert end <= start, f'{array}: {name} overlaps {after} ({group} rows)'


def test_the_loads_kinds_and_sizes_agree():
    kinds = [v for k, v in kernel.LOADS.numbers.items() if k.startswith('KIND_')]
    assert len(set(kinds)) == len(kinds)
    assert kernel.LOADS.S_KIND == kernel.LOADS.WIDTH - 1 == kernel.LOADS.AERO_ROW
    # the body columns end where the kinematic ones begin
    body = [c for c in kernel.BODIES.columns.values() if c[0] == 'body']
    assert max(first + span for _, first, span in body) == kernel.BODIES.BODY_COLUMNS
    assert min(c[1] for c in kernel.BODIES.columns.values() if c[0] == 'motion') == \
        kernel.BODIES.BODY_COLUMNS


@pytest.mark.parametrize('n, m, nj, dense', [(1, 0, 0, 0), (2, 5, 1, 1), (7, 40, 9, 0),
                                             (7, 40, 9, 2), (101, 500, 100, 0)])
def test_the_workspace_parts_tile_the_workspace(n, m, nj, dense):
    parts = _kernel.workspace_parts(n, m, nj, dense)
    names = [name for name, _, _ in parts]
    assert len(set(names)) == len(names)
    end = 0
    for name, start, shape in parts:
        assert start == end, name
        end = start + math.prod(shape)
    assert end == _kernel.workspace_size(n, m, nj, dense)


def test_the_views_are_the_systems_workspace_by_name():
    from cfem_ros import load_scenario, Simulator
    sim = Simulator(load_scenario(str(ROOT / 'config' / 'double_pendulum.yaml')))
    system = sim._topology.system
    views = kernel.views(system)
    assert views['jac'].shape == (system.m, 12) and views['rot'].shape == (sim.n, 3, 3)
    for view in views.values():
        assert view.base is system.work or view.base is system.work.base
    kernel.derivative(system, sim.y.copy(), np.empty_like(sim.y))
    np.testing.assert_array_equal(kernel.constraint_values(system), views['value'])
    assert np.abs(views['value']).max() < 1e-9   # the joints hold at the start


#: A column's name (the layout's prefixes) given a number of Python's own.
LITERAL = re.compile(r'^\s*((?:[A-Z]_[A-Z0-9_]+|[A-Z_]*WIDTH|BODY_COLUMNS|SEGMENT|AERO_ROW)'
                     r'(?:\s*,\s*[A-Z][A-Z0-9_]*)*)\s*=\s*\(?\s*-?\d', re.M)


def test_python_writes_no_column_of_its_own():
    found = []
    for path in sorted((ROOT / 'cfem_ros').rglob('*.py')):
        for match in LITERAL.finditer(path.read_text(encoding='utf-8')):
            found.append(f'{path.relative_to(ROOT)}: {match.group(0).strip()}')
    assert not found, found
    # the names Python modules keep for the columns are the extension's
    for module, layout in ((loads, kernel.LOADS), (motion, kernel.BODIES)):
        for name, value in vars(module).items():
            if name in layout.columns or name in layout.numbers:
                assert value == getattr(layout, name), (module.__name__, name)
