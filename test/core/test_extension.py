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


def _system_args(sim):
    """Return the arguments of sim's System, by name (``Topology.bind``)."""
    top = sim._topology
    names = ('joints_i', 'joints_f', 'watch', 'limits', 'triggers', 'watch_plan')
    return dict(bodies=sim._bodies, gravity=sim.gravity, loads=sim._loads, rows_i=top.rows_i,
                rows_f=top.rows_f, plan=top.plan, roots=top.roots, eta=sim.eta,
                dense=top.dense, **dict(zip(names, sim.releases.watched())),
                order=top.line[np.flatnonzero(sim.active)])


def test_arrays_it_cannot_take_are_refused_by_name_never_copied():
    sim = _sim()
    top = sim._topology
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
    top = sim._topology
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
    top = sim._topology
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
