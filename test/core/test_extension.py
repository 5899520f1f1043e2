# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The compiled core as an extension module: its arguments, threads, its solves, no JIT.

The numbers themselves are tested where they matter (test_solver against a dense
numpy KKT solve, the crossing tests against scipy's brentq (test/crossings.py), the
paper cases against analytic solutions); here, what the C++ binding adds.
"""

import pathlib
import threading

from cfem_ros import load_scenario, Simulator
from cfem_ros.core import _kernel
from cfem_ros.core._kernel import testing
from cfem_ros.core.native import kernel
import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
CONFIG = ROOT / 'config'


def _sim(name='double_pendulum', duration=None):
    path = CONFIG / f'{name}.yaml'
    if not path.exists():
        path = CONFIG / 'joints' / f'{name}.yaml'
    return Simulator(load_scenario(str(path), duration=duration))


def test_the_kernel_is_the_extension_and_no_source_imports_a_jit():
    assert kernel.advance is _kernel.advance
    assert pathlib.Path(_kernel.__file__).suffix in ('.so', '.pyd')
    for path in (ROOT / 'cfem_ros').rglob('*.py'):
        text = path.read_text(encoding='utf-8')
        assert 'import numba' not in text and 'from numba' not in text, path
        # one Python face: kernel.py alone imports the extension
        if path.name != 'kernel.py':
            assert 'import _kernel' not in text, path
    # what only the tests call is apart, in _kernel.testing, out of the API
    for name in ('rk4_step', 'conditions', 'loads_strokes', 'inverse', 'cholesky',
                 'multilinear'):
        assert hasattr(testing, name), name
        assert not hasattr(_kernel, name) and not hasattr(kernel, name), name


def _system_args(sim):
    """Return the arguments of sim's System, by name (``Topology.bind``)."""
    top = sim.topology
    names = ('joints_i', 'joints_f', 'watch', 'limits', 'triggers', 'watch_plan')
    return dict(bodies=sim._bodies, gravity=sim.gravity, loads=sim._loads, rows_i=top.rows_i,
                rows_f=top.rows_f, plan=top.plan, roots=top.roots, eta=sim.eta,
                dense=top.dense, **dict(zip(names, sim.releases.watched())),
                order=top.line[np.flatnonzero(sim.active)])


def test_arrays_it_cannot_take_are_refused_by_name_never_copied():
    sim = _sim()
    top = sim.topology
    args = _system_args(sim)
    y = sim.y.copy()
    dy = np.empty_like(y)
    assert kernel.derivative(top.system, y, dy) >= 0.0
    good = dy.copy()
    cases = [
        ('bodies', sim._bodies.astype(np.float32), TypeError),
        ('loads', sim._loads.astype('>f8'), TypeError),
        ('loads', np.repeat(sim._loads, 2, axis=1)[:, ::2], ValueError),   # not contiguous
        ('loads', sim._loads[:1].copy(), ValueError),                      # too short
        ('plan', top.plan.astype(np.int32), TypeError),
        ('rows_f', top.rows_f[:, :8].copy(), ValueError),
        ('gravity', [0.0, 0.0, -9.81], TypeError),
        ('dense', 3, ValueError),
        ('watch_plan', np.full(len(args['watch']) + 1, 0, dtype=np.int64), ValueError),
        ('order', np.array([len(top.plan)], dtype=np.int64), ValueError),
    ]
    for name, bad, error in cases:
        with pytest.raises(error, match=name):
            kernel.System(**dict(args, **{name: bad}))
    read_only = np.empty_like(y)
    read_only.flags.writeable = False
    with pytest.raises(ValueError, match='dy'):
        kernel.derivative(top.system, y, read_only)
    with pytest.raises(ValueError, match='dy'):
        kernel.derivative(top.system, y, np.empty(len(y) + 1))
    with pytest.raises(ValueError, match='dense'):
        top.system.dense = -1
    # an output is written in place: the caller's array, not a copy; the System reads
    # the caller's arrays, not copies of them
    out = np.zeros_like(y)
    kernel.derivative(top.system, y, out)
    np.testing.assert_array_equal(out, good)
    sim.set_wrench(1, [0.0, 0.0, 50.0], [0.0, 0.0, 0.0])
    kernel.derivative(top.system, y, out)
    assert not np.array_equal(out, good)
    # the vectorised functions refuse to convert (a copy) too; kernel's wrappers convert
    shape = np.array(sim._loads[:0, 0])
    with pytest.raises(TypeError):
        _kernel.distance(shape, np.eye(3).reshape(1, 9).astype(np.float32), np.zeros((1, 3)),
                         shape, np.eye(3).reshape(1, 9), np.zeros((1, 3)))


def test_the_gil_is_released_while_the_kernel_steps():
    sim = _sim('double_pendulum', duration=100.0)
    started, counted = threading.Event(), []

    def step():
        started.set()
        sim.advance_to(60.0)   # 60 000 steps in one kernel call: tenths of a second

    worker = threading.Thread(target=step)
    worker.start()
    started.wait()
    count = 0
    while worker.is_alive():
        count += 1
    worker.join()
    counted.append(count)
    # with the GIL held the whole call, this loop would wait for it, counting only the
    # few turns before the call starts
    assert sim.t == 60.0
    assert counted[0] > 10_000, counted


def test_runs_in_threads_give_the_numbers_of_runs_one_after_another():
    names = ('double_pendulum', 'store_separation', 'universal', 'store_separation_ejectors')
    alone = []
    for name in names:
        sim = _sim(name)
        sim.advance_to(1.0)
        alone.append(sim.y.copy())
    sims = [_sim(name) for name in names]
    threads = [threading.Thread(target=s.advance_to, args=(1.0,)) for s in sims]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for name, sim, y in zip(names, sims, alone):
        np.testing.assert_array_equal(sim.y, y, err_msg=name)


@pytest.mark.parametrize('name', ['double_pendulum', 'universal', 'ball', 'planar', 'slider',
                                  'cylindrical', 'store_separation'])
def test_the_dense_solves_give_the_tree_solve_accelerations(name):
    # the same open chain solved as a tree, as one Schur complement by LU (dense 1)
    # and by the least-squares eigen-solve used for redundant rows (dense 2)
    sim = _sim(name)
    sim.advance_to(0.05)
    top = sim.topology
    assert top.dense == 0
    found = []
    for dense in (0, 1, 2):
        top.dense = dense
        dy = np.empty_like(sim.y)
        assert kernel.derivative(top.system, sim.y.copy(), dy) >= 0.0
        found.append(dy)
    scale = np.abs(found[0]).max()
    np.testing.assert_allclose(found[1], found[0], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(found[2], found[0], rtol=0, atol=1e-9 * scale)


def test_an_exactly_singular_complement_is_reported_not_solved():
    # two bodies held by the same joint twice over: the complement is singular (LU, dense
    # 1: SINGULAR, as numpy's LinAlgError was) and solved in least squares (dense 2)
    sim = _sim('hinge')
    top = sim.topology
    rows_i = np.ascontiguousarray(np.concatenate([top.rows_i, top.rows_i]))
    rows_f = np.ascontiguousarray(np.concatenate([top.rows_f, top.rows_f]))
    twice = kernel.System(**dict(_system_args(sim), rows_i=rows_i, rows_f=rows_f, dense=1))
    dy = np.empty_like(sim.y)
    assert kernel.derivative(twice, sim.y, dy) == -1.0
    twice.dense = 2
    assert kernel.derivative(twice, sim.y, dy) >= 0.0
    reference = np.empty_like(sim.y)
    kernel.derivative(top.system, sim.y, reference)
    np.testing.assert_allclose(dy, reference, rtol=0, atol=1e-9 * np.abs(reference).max())


def _kinds(sim):
    """Return {kind: first row} of the rows of sim's loads past the bodies'."""
    n = len(sim._bodies)
    kinds = {}
    for row in range(n, len(sim._loads)):
        kinds.setdefault(float(sim._loads[row, kernel.LOADS.S_KIND]), row)
    return kinds


def _with(args, name, changes):
    """Return args with a copy of args[name] whose entries are changed ({where: value})."""
    array = args[name].copy()
    for where, value in changes.items():
        array[where] = value
    return dict(args, **{name: array})


def test_an_index_out_of_range_is_refused_by_name_when_the_system_is_made():
    # the step loop trusts every index (no check per step); a body 10^7 in a plan line
    # or a row killed the process with SIGSEGV at the first step. Refused once, here, with
    # the argument, row, column and value, and the range that would do.
    L, P, R, J, B = (kernel.LOADS, kernel.PLAN, kernel.ROWS_I, kernel.JOINTS_I,
                     kernel.BODIES)
    sim = _sim('store_release_two_hooks')
    args = _system_args(sim)
    n, m, rows = len(sim._bodies), len(args['rows_i']), len(sim._loads)
    kinds = _kinds(sim)
    s, a = kinds[L.KIND_SCHEDULED], kinds[L.KIND_AERO]
    c, b, t = kinds[L.KIND_CONTACT], kinds[L.KIND_BRACE], kinds[L.KIND_TABLE]
    # the packed table's TOTAL: AERO_ROW numbers a row, from the row A_FIRST names on
    first = int(sim._loads[a, L.A_FIRST])
    T = kernel.AERO_TABLE

    def header(column):
        return first + column // L.AERO_ROW, column % L.AERO_ROW

    total = header(T.TOTAL)
    timed = {(s, L.S_TABLE): L.TABLE_TIME}
    shape = int(sim._loads[c, L.C_SHAPE_B])   # its first number, the kind, made no kind
    cases = [
        ('plan', {(0, P.P_CHILD): 10**7}, r'plan\[0, P_CHILD\] = 10000000: not a body'),
        ('plan', {(0, P.P_PARENT): -1}, r'plan\[0, P_PARENT\] = -1'),
        ('plan', {(0, P.P_ROW): m}, r'plan\[0, P_ROW\]'),
        ('plan', {(0, P.P_NR): 4}, r'plan\[0, P_NR\]'),
        ('plan', {(-1, P.P_NT): 3, (-1, P.P_NR): 3}, r'P_ROW \+ P_NT \+ P_NR\]'),
        ('plan', {(0, P.P_SIGN): 0}, r'plan\[0, P_SIGN\]'),
        ('rows_i', {(0, R.R_CHILD): 10**7}, r'rows_i\[0, R_CHILD\] = 10000000'),
        ('rows_i', {(m - 1, R.R_PARENT): n}, rf'rows_i\[{m - 1}, R_PARENT\]'),
        ('rows_i', {(0, R.R_KIND): 3}, r'rows_i\[0, R_KIND\]'),
        ('rows_i', {(0, R.R_KIND): R.KIND_SAME_POINT}, r'rows_i\[0, R_KIND\]'),
        ('roots', {0: 3}, r'roots\[0\]'),
        ('joints_i', {(0, J.J_CHILD): 10**7}, r'joints_i\[0, J_CHILD\]'),
        ('order', {0: -1}, r'order\[0\]'),
        ('bodies', {(0, B.M_REF): n + 1}, r'bodies\[0, M_REF\]'),
        ('bodies', {(0, B.M_KIND): 7.0}, r'bodies\[0, M_KIND\]'),
        ('loads', {(s, L.S_BODY): 1e7}, rf'loads\[{s}, S_BODY\] = 10000000'),
        ('loads', {(s, L.S_BODY): 0.5}, rf'loads\[{s}, S_BODY\] = 0.5'),
        ('loads', {(s, L.S_REACT): n}, rf'loads\[{s}, S_REACT\]'),
        ('loads', {(s, L.S_FRAME): np.nan}, rf'loads\[{s}, S_FRAME\] = nan'),
        ('loads', {(s, L.S_TABLE): 3}, rf'loads\[{s}, S_TABLE\]'),
        ('loads', {**timed, (s, L.S_FIRST): 1e9}, rf'loads\[{s}, S_FIRST\]'),
        ('loads', {**timed, (s, L.S_FIRST): t, (s, L.S_COUNT): rows - t},
         rf'loads\[{s}, S_COUNT\]'),
        ('loads', {(a, L.A_BODY): -1}, rf'loads\[{a}, A_BODY\]'),
        ('loads', {(a, L.A_CARRIER): n}, rf'loads\[{a}, A_CARRIER\]'),
        ('loads', {(a, L.A_FIRST): rows - 1}, rf'loads\[{a}, A_FIRST\]'),
        ('loads', {total: 0.0}, rf'loads\[{a}, A_FIRST\] = {first}: no packed'),
        ('loads', {total: 1e6}, rf'loads\[{a}, A_FIRST\] = {first}: .* does not fit'),
        ('loads', {header(T.NA): 1e6}, rf'loads\[{a}, A_FIRST\] = {first}: .* header'),
        ('loads', {header(T.NB): 0.5}, rf'loads\[{a}, A_FIRST\] = {first}: .* header'),
        ('loads', {header(T.PROX_AXES): 8}, rf'loads\[{a}, A_FIRST\] = {first}: .* header'),
        ('loads', {(c, L.C_B): 1e7}, rf'loads\[{c}, C_B\]'),
        ('loads', {(c, L.C_SHAPE_A): rows - 1}, rf'loads\[{c}, C_SHAPE_A\]'),
        ('loads', {(shape, 0): 9.0}, rf'loads\[{c}, C_SHAPE_B\] = {shape}: no packed shape'),
        ('loads', {(b, L.BR_CARRIER): -1}, rf'loads\[{b}, BR_CARRIER\]'),
        ('loads', {(-1, L.S_KIND): L.KIND_TABLE}, r'S_KIND\] = 2: the last row'),
    ]
    for name, changes, message in cases:
        with pytest.raises(ValueError, match=message):
            kernel.System(**_with(args, name, changes))
    watching = _system_args(_sim('store_separation'))   # a joint released by its loads
    for name, value in (('watch', len(watching['joints_i'])), ('watch_plan', -1)):
        with pytest.raises(ValueError, match=rf'{name}\[0\] = {value}: not a'):
            kernel.System(**_with(watching, name, {0: value}))
    # the arrays as the engine lays them out are taken, and step
    system = kernel.System(**args)
    dy = np.empty_like(sim.y)
    assert kernel.derivative(system, sim.y.copy(), dy) >= 0.0


def test_a_sample_too_short_for_its_outputs_is_refused_by_name():
    # a sample's outputs: the bodies, the sampled joints' loads, every applied load and
    # the air (sample_applied), and the states relative to a reference: System.outputs
    sim = _sim('store_release_two_hooks')
    system = sim.topology.system
    assert system.outputs == len(sim.outputs())
    y = sim.y.copy()
    with pytest.raises(ValueError, match='out: expected at least'):
        kernel.sample_outputs(system, y, np.empty(system.outputs - 1))
    info = np.zeros(kernel.ADVANCE_INFO.WIDTH)
    for grid, samples, message in (([1.0, 0.0, 0.0], np.empty((2, system.outputs - 1)),
                                    'samples: '),
                                   ([1.0, 0.0, 3.0], np.empty((2, system.outputs)),
                                    r'grid\[2\] = 3'),
                                   ([1.0, 0.0, -1.0], np.empty((2, system.outputs)),
                                    r'grid\[2\] = -1')):
        with pytest.raises(ValueError, match=message):
            kernel.advance(system, y, info, 0.01, np.inf, np.inf, 0.001,
                           np.array(grid), samples)


def test_the_free_functions_refuse_a_body_count_or_joint_outside_their_arrays():
    sim = _sim('store_release_two_hooks')
    loads, n = sim._loads.copy(), len(sim._bodies)
    for bad in (-1, len(loads) + 1):
        with pytest.raises(ValueError, match=rf'n = {bad}: expected the number of bodies'):
            kernel.loads_set_time(loads, bad, 0.0)
        with pytest.raises(ValueError, match=rf'n = {bad}'):
            testing.loads_strokes(sim.y.copy(), loads, bad, np.empty(len(loads)))
    joints_i, joints_f = sim.joints.joints_i, sim.joints.joints_f
    out = np.empty((1, 3))
    with pytest.raises(ValueError, match=r'watch\[0\] = 3: not a joint'):
        testing.conditions(sim.y.copy(), joints_i, joints_f, np.array([3]), out)
    far = joints_i.copy()
    far[0, 1] = n
    with pytest.raises(ValueError, match=rf'joints_i\[0, 1\] = {n}: not a body of y'):
        testing.conditions(sim.y.copy(), far, joints_f, np.array([0]), out)


@pytest.mark.parametrize('name', ['store_release_two_hooks', 'store_release_near_pylon'])
def test_aero_wrench_refuses_a_packed_table_whose_header_does_not_give_its_length(name):
    sim = _sim(name)
    L, T = kernel.LOADS, kernel.AERO_TABLE
    first = int(sim._loads[_kinds(sim)[L.KIND_AERO], L.A_FIRST])
    flat = sim._loads[first:, :L.AERO_ROW].reshape(-1)
    packed = flat[:int(flat[T.TOTAL])].copy()
    state = [np.zeros((1, 3)), np.array([[200.0, 0.0, 0.0]]), np.eye(3).reshape(1, 9),
             np.zeros((1, 3)), np.zeros((1, 3)), np.eye(3).reshape(1, 9)]
    force, _ = kernel.aero_wrench(packed, *state)
    assert np.isfinite(force).all() and np.abs(force).max() > 0.0
    cases = [(T.NA, 1e6), (T.NM, 0.0), (T.PROX_AXES, 8.0)]
    if packed[T.PROX_AXES] > 0:   # the pylon's flow field: a code no axis has
        cases += [(T.PROX_CODE, T.AXIS_MACH + 1.0), (T.PROX_SIZE, 1e7)]
    else:
        cases += [(T.PROX_AXES, 1.0)]   # an axis of no grid node
    for column, value in cases:
        bad = packed.copy()
        bad[column] = value
        with pytest.raises(ValueError, match='packed: a table from '
                                             r'cfem_ros\.core\.engine\.aeropack\.pack'):
            kernel.aero_wrench(bad, *state)
