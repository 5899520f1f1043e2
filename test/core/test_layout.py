# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The layout the kernel and Python share is the extension's, whole and in one place.

``cpp/layout.hpp`` and ``cpp/workspace.hpp`` lay out every shared array;
Python reads each column, width and workspace part from the extension
(``kernel.LOADS``, ``kernel.views`` ...). These tests walk the exported tables
(a column that overlaps another, a part that does not add up) and the Python
sources (a column index written as a number of Python's own, which could drift):
a name given a number, and a literal index or slice into a kernel array
(``kernel_arrays``' scan, below).
"""

import ast
import math
import pathlib
import re
import textwrap

from cfem_ros.core import _kernel
from cfem_ros.core.engine import loads
from cfem_ros.core.native import contacts, kernel, motion
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
    system = sim.topology.system
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
    for module, layout in ((loads, kernel.LOADS), (motion, kernel.BODIES),
                           (motion, kernel.TRAJECTORY)):
        for name, value in vars(module).items():
            if name in layout.columns or name in layout.numbers:
                assert value == getattr(layout, name), (module.__name__, name)
    assert contacts.SHAPE_HEADER == kernel.SHAPE.HEADER
    assert contacts.COMPOUND == kernel.SHAPE.KIND_COMPOUND


def test_a_sample_is_laid_out_as_the_kernel_writes_it():
    from cfem_ros import load_scenario, Simulator
    sample = kernel.SAMPLE
    # a joint's load, an applied source's wrench and InBodyAxes' six numbers: force, moment
    assert (sample.span('O_FORCE'), sample.span('O_MOMENT')) == (
        sample.span('O_WRENCH_FORCE'), sample.span('O_WRENCH_MOMENT')) == (
        slice(0, 3), slice(3, 6))
    # a pose message is the position and quaternion, a twist the velocity and rates, in turn
    assert sample.O_QUATERNION == sample.O_POSITION + 3
    assert sample.O_RATES == sample.O_VELOCITY + 3
    sim = Simulator(load_scenario(str(ROOT / 'config' / 'store_separation_aero.yaml')))
    assert sim.advance_to(0.05)
    out = sim.outputs()
    n, joints = sim.n, len(sim.active_joints)
    assert len(out) == (sample.BODY * n + sample.JOINT * joints
                        + sample.WRENCH * len(sim.applied_sources)
                        + sample.AIR * len(sim.model.aero) + sample.BODY * len(
                            sim.model.references))
    bodies = out[:sample.BODY * n].reshape(n, sample.BODY)
    np.testing.assert_array_equal(bodies[:, sample.span('O_POSITION')], sim.position)
    np.testing.assert_array_equal(bodies[:, sample.span('O_QUATERNION')], sim.orientation)
    air = sim.air()
    assert air.shape == (len(sim.model.aero), sample.AIR)
    # the dynamic pressure the sample holds is the air's density and speed, the kernel's way
    np.testing.assert_array_equal(air[:, sample.O_PRESSURE], kernel.dynamic_pressure(
        air[:, sample.O_DENSITY], air[:, sample.O_SPEED]))
    assert abs(air[0, sample.O_PRESSURE]
               - 0.5 * air[0, sample.O_DENSITY] * air[0, sample.O_SPEED] ** 2) <= 1e-12 * abs(
                   air[0, sample.O_PRESSURE])


# --------------------------------------------- no literal column into a kernel array
#
# kernel_arrays scans Python source (ast) for an integer written as an index or a slice
# bound of a column of an array the kernel shares. What counts as such an array: the
# result of a call into the extension (``kernel.*``, ``_kernel.*``) or of a method that
# returns one (KERNEL_METHODS: ``Simulator.outputs``, ``held_wrenches``, ``air`` ...);
# the attributes that hold one (KERNEL_ATTRIBUTES: ``loads``, ``plan``, ``rows_f`` ...;
# TABLE_ATTRIBUTES when indexed by row and column: ``bodies`` is also a model's list of
# bodies); a name bound from any of these in the same function (through indexing,
# ``reshape``, ``copy``); and a sample row: a method's result that is one row
# (ROW_METHODS) or a parameter named ``outputs`` or ``row``. For a 2-d index the columns
# are the entries after the first (a row offset such as ``rows_f[1:, ...]`` is no column);
# a sample row is flagged for any literal index, and so is the integrator's state (STATE:
# a name in STATE_NAMES, an attribute ``y``, the result of a STATE_METHODS call, whose
# blocks start at multiples of n: ``y[6 * n:10 * n]``), and so is an odometry input's
# values (``kernel.ODOMETRY``: an attribute in ODOMETRY_ATTRIBUTES, ``item.values[3:7]``,
# or a name bound from one). It does not follow arrays across
# functions or through containers, nor arithmetic such as ``13 * i``: a name it does
# not know is not checked (the scan says where literal columns are, not that there are
# none anywhere).

KERNEL_MODULES = {'kernel', '_kernel'}
KERNEL_METHODS = {'outputs', 'held_wrenches', 'relative_states', 'air', 'applied_loads',
                  'sample_rows', 'joint_projection', 'mass_table', 'views', 'next_row',
                  'joint_wrenches', 'aero_wrench', 'distance', 'distances'}
ROW_METHODS = {'outputs', 'next_row'}
ROW_PARAMETERS = {'outputs', 'row'}
KERNEL_ATTRIBUTES = {'loads', 'plan', 'rows_i', 'rows_f', 'joints_i', 'joints_f', 'work'}
TABLE_ATTRIBUTES = {'bodies', 'outputs', 'values'}
STATE_NAMES = {'y', 'y0', 'y1', 'dy'}
STATE_METHODS = {'derivative', 'initial_state', 'motion_place'}
ODOMETRY_ATTRIBUTES = {'values'}


def _callee(node):
    """Return 'kernel' for a call into the extension, the method or function name, or None."""
    if not isinstance(node, ast.Call):
        return None
    func = node.func
    if isinstance(func, ast.Attribute):
        if isinstance(func.value, ast.Name) and func.value.id in KERNEL_MODULES:
            return 'kernel'
        return func.attr
    return func.id if isinstance(func, ast.Name) else None


def _number(node) -> bool:
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        node = node.operand
    return isinstance(node, ast.Constant) and type(node.value) is int


def _literal(node) -> bool:
    """Return whether an index or a slice's bounds hold an integer written out (13 * i too)."""
    if isinstance(node, ast.Slice):
        return any(b is not None and _literal(b) for b in (node.lower, node.upper))
    if isinstance(node, ast.BinOp):
        return _literal(node.left) or _literal(node.right)
    return _number(node)


class _Scan(ast.NodeVisitor):
    """Collect the subscripts of a module that index a kernel array by a literal column."""

    def __init__(self):
        self.found = []
        self.arrays, self.rows, self.states, self.odometry = [set()], [set()], [set()], [set()]

    def visit_FunctionDef(self, node):
        self.arrays.append(set())
        self.states.append(set())
        self.odometry.append(set())
        self.rows.append({a.arg for a in node.args.args if a.arg in ROW_PARAMETERS})
        self.generic_visit(node)
        self.arrays.pop()
        self.states.pop()
        self.odometry.pop()
        self.rows.pop()

    visit_AsyncFunctionDef = visit_FunctionDef

    def kind(self, node):
        """Return 'row', 'array', 'state', 'odometry' or None: what node is (through indexing)."""
        while True:
            callee = _callee(node)
            if callee in ('reshape', 'copy', 'ravel', 'view'):
                node = node.func.value
            elif callee is not None:
                return ('row' if callee in ROW_METHODS else 'state' if callee in STATE_METHODS else
                        'array' if callee == 'kernel' or callee in KERNEL_METHODS else None)
            elif isinstance(node, ast.Subscript):
                node = node.value
            elif isinstance(node, ast.Name):
                return ('row' if node.id in self.rows[-1] else
                        'array' if node.id in self.arrays[-1] else
                        'odometry' if node.id in self.odometry[-1] else
                        'state' if node.id in STATE_NAMES | self.states[-1] else None)
            elif isinstance(node, ast.Attribute) and node.attr == 'y':
                return 'state'
            elif isinstance(node, ast.Attribute) and node.attr in ODOMETRY_ATTRIBUTES:
                return 'odometry'
            else:
                return ('array' if isinstance(node, ast.Attribute)
                        and node.attr in KERNEL_ATTRIBUTES else None)

    def visit_Assign(self, node):
        self.generic_visit(node)
        kind = self.kind(node.value)
        for target in node.targets if kind else ():
            for name in target.elts if isinstance(target, ast.Tuple) else [target]:
                if isinstance(name, ast.Name):
                    {'row': self.rows, 'state': self.states, 'odometry': self.odometry}.get(
                        kind, self.arrays)[-1].add(name.id)

    def visit_Subscript(self, node):
        kind, index = self.kind(node.value), node.slice
        if isinstance(index, ast.Tuple):
            table = isinstance(node.value, ast.Attribute) and node.value.attr in TABLE_ATTRIBUTES
            hit = (kind is not None or table) and any(_literal(e) for e in index.elts[1:])
        else:
            hit = kind in ('row', 'state', 'odometry') and _literal(index)
        if hit:
            self.found.append((node.lineno, ast.unparse(node)))
        self.generic_visit(node)


def kernel_arrays(source: str) -> list:
    """Return (line, text) of each literal column index or slice into a kernel array."""
    scan = _Scan()
    scan.visit(ast.parse(source))
    return scan.found


def test_python_indexes_no_kernel_array_by_a_literal_column():
    found = [f'{path.relative_to(ROOT)}:{line}: {text}'
             for path in sorted((ROOT / 'cfem_ros').rglob('*.py'))
             for line, text in kernel_arrays(path.read_text(encoding='utf-8'))]
    assert not found, found


@pytest.mark.parametrize('source', [
    'sim.outputs()[13:20]',
    'outputs = sim.outputs()\noutputs[13 * i + 3:13 * i + 7]',
    'row = sim.outputs()\nrow[3:7]',
    'def f(outputs):\n    return outputs[0]',
    'def arrows(self, row):\n    state = row[:13 * n].reshape(n, 13)\n    return state[:, 3:7]',
    '_, air = kernel.aero_wrench(*args)\nair[:, 4]',
    'self.loads[k, 7]',
    'free, table = mass_table(model)\ntable[:, 2:11]',
    'self.bodies[:, 0]',
    'delta = self.joint_projection(top, y)\ndelta[:, 3:]',
    'held = sim.held_wrenches()\nheld[body, 7:10]',
    'y = np.zeros(13)\ny[0:3]',
    'quat = y[6 * n:10 * n].reshape(n, 4)',
    'sim.y[8:12]',
    'rates = sim.derivative(sim.y)\nrates[3 * n + 3 * i:3 * n + 3 * i + 3]',
    # the odometry input's values as inputs.py, stamps.py and recorder.py sliced them
    'norm = np.linalg.norm(item.values[3:7])',
    'v = item.values\ncarriers.set_odometry(body, at, v[0:3], v[3:7], v[7:10], v[10:13])',
    'v = item.values\nrotations.matrices(v[None, 3:7] / np.linalg.norm(v[3:7]))[0] @ v[7:10]',
])
def test_the_scan_finds_a_literal_column(source):
    assert kernel_arrays(textwrap.dedent(source)), source


@pytest.mark.parametrize('source', [
    'sim.outputs()[SAMPLE.span("O_POSITION")]',
    'model.bodies[0]',
    'top.plan[:, PLAN.P_JOINT]',
    'self.rows_f[1:, points]',
    'kind = self.rows_i[:, ROWS_I.R_KIND]',
    'found = kernel.distance(*args)\nfound[:2]',
    'y = np.zeros(STATE.BODY)\nstate_block(y, 1, "Y_POSITION")',
    'def f(values):\n    return values[3:]',
    'item.values[ODOMETRY.span("D_QUATERNION")]',
    'position, quaternion, velocity, rates = odometry_parts(item.values)\nquaternion[None]',
])
def test_the_scan_leaves_layout_reads_and_other_arrays(source):
    assert not kernel_arrays(textwrap.dedent(source)), source
