# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The compiled core as an extension module: its arguments, threads, its solves, no JIT.

The numbers themselves are tested where they matter (test_solver against a dense
numpy KKT solve, test_roots and the crossing tests against scipy's brentq, the
paper cases against analytic solutions); here, what the C++ binding adds.
"""

import pathlib
import threading

from cfem_ros import load_scenario, Simulator
from cfem_ros.core import _kernel, kernel
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
    # the Python constants are the compiled ones
    for name in ('REACHED', 'CONDITION', 'NOT_FINITE', 'VIOLATION', 'SINGULAR', 'ROWS_FULL',
                 'LOADS_NOT_FINITE', 'NAN_VALUE', 'SAME_SIGNS', 'NO_CONVERGENCE',
                 'PIVOT_RTOL', 'CROSSING_XTOL', 'CROSSING_RTOL', 'CROSSING_MAXITER'):
        assert getattr(kernel, name) == getattr(_kernel, name), name


def test_arrays_it_cannot_take_are_refused_by_name_never_copied():
    sim = _sim()
    top = sim._topology
    args = list(top.kernel_args(sim))
    y = sim.y.copy()
    dy = np.empty_like(y)
    assert kernel.derivative(y, dy, *args) >= 0.0
    good = dy.copy()
    work = args[-1]
    cases = [
        ('work', work.astype(np.float32), TypeError),
        ('work', work.astype('>f8'), TypeError),
        ('work', np.repeat(work, 2)[::2], ValueError),   # not contiguous
        ('work', work[:10], ValueError),                 # too short
        ('plan', top.plan.astype(np.int32), TypeError),
        ('rows_f', top.rows_f[:, :8].copy(), ValueError),
        ('gravity', [0.0, 0.0, -9.81], TypeError),
    ]
    names = ('bodies', 'gravity', 'loads', 'rows_i', 'rows_f', 'plan', 'roots', 'eta', 'dense',
             'work')
    for name, bad, error in cases:
        wrong = list(args)
        wrong[names.index(name)] = bad
        with pytest.raises(error, match=name):
            kernel.derivative(y, dy, *wrong)
    read_only = np.empty_like(y)
    read_only.flags.writeable = False
    with pytest.raises(ValueError, match='dy'):
        kernel.derivative(y, read_only, *args)
    with pytest.raises(ValueError, match='dy'):
        kernel.derivative(y, np.empty(len(y) + 1), *args)
    # an output is written in place: the caller's array, not a copy
    out = np.zeros_like(y)
    kernel.derivative(y, out, *args)
    np.testing.assert_array_equal(out, good)


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
    top = sim._topology
    assert top.dense == 0
    args = list(top.kernel_args(sim))
    found = []
    for dense in (0, 1, 2):
        args[8] = dense   # a dense solve needs its m x m parts (a tree's workspace has none)
        args[9] = np.zeros(kernel.workspace_size(sim.n, top.m, len(top.plan), dense))
        dy = np.empty_like(sim.y)
        assert kernel.derivative(sim.y.copy(), dy, *args) >= 0.0
        found.append(dy)
    scale = np.abs(found[0]).max()
    np.testing.assert_allclose(found[1], found[0], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(found[2], found[0], rtol=0, atol=1e-9 * scale)


def test_an_exactly_singular_complement_is_reported_not_solved():
    # two bodies held by the same joint twice over: the complement is singular (LU, dense
    # 1: SINGULAR, as numpy's LinAlgError was) and solved in least squares (dense 2)
    sim = _sim('hinge')
    top = sim._topology
    rows_i = np.ascontiguousarray(np.concatenate([top.rows_i, top.rows_i]))
    rows_f = np.ascontiguousarray(np.concatenate([top.rows_f, top.rows_f]))
    m = len(rows_i)
    plan = top.plan.copy()
    work = np.zeros(kernel.workspace_size(sim.n, m, len(plan), 1))
    dy = np.empty_like(sim.y)
    args = [sim._bodies, sim.gravity, sim._loads, rows_i, rows_f, plan, top.roots, sim.eta]
    assert kernel.derivative(sim.y, dy, *args, 1, work) == -1.0
    assert kernel.derivative(sim.y, dy, *args, 2, work) >= 0.0
    reference = np.empty_like(sim.y)
    kernel.derivative(sim.y, reference, *top.kernel_args(sim))
    np.testing.assert_allclose(dy, reference, rtol=0, atol=1e-9 * np.abs(reference).max())
