# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A 1,000-run store-separation sweep end to end, against MuJoCo's rollout module.

cfem_ros: ``Sweep.run`` on a Dask LocalCluster of 1 and 2 worker processes,
every run to 1.5 s at dt = 1 ms with its metrics, results.parquet written;
timed with the cluster's start (and close) included, and on a running,
warm cluster. MuJoCo: ``mujoco.rollout.rollout`` (multi-threaded C++
rollouts, 1 and 2 threads) stepping the same store on its hinge (MuJoCo has
no releasable joint) for the same number of steps, from 1,000 initial
states. The sides take turns; figures are medians over the repeats.

Usage: .venv/bin/python benchmarks/bench_sweep.py [--runs 1000] [--repeats 3]
(needs the study and bench extras: pip install -e '.[study,bench]').
"""

import argparse
import os
import pathlib
import statistics
import sys
import tempfile
import time

from cfem_ros.study import Sweep
from dask import distributed
import mujoco
from mujoco import rollout
import numpy as np
import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import models  # noqa: E402, I100

ROOT = pathlib.Path(__file__).resolve().parents[1]
DURATION, DT = 1.5, 0.001
STEPS = int(round(DURATION / DT))


def sweep_file(folder, runs):
    """Write the benchmark's sweep file (the example sweep without its dt grid)."""
    with open(ROOT / 'config' / 'sweeps' / 'store_separation_sweep.yaml') as stream:
        sweep = yaml.safe_load(stream)
    sweep['scenario'] = str(ROOT / 'config' / 'store_separation.yaml')
    sweep['runs'] = runs
    del sweep['vary']['dt']
    path = os.path.join(folder, 'sweep.yaml')
    with open(path, 'w') as stream:
        yaml.safe_dump(sweep, stream)
    return path


def _warm():
    from cfem_ros.core import kernel  # noqa: F401 - loads the compiled kernel
    return os.getpid()


def cfem_sweep(path, workers, folder, with_cluster):
    """Return the seconds of one sweep (with the cluster's start and close, or not)."""
    sweep = Sweep.from_file(path)
    out = tempfile.mkdtemp(dir=folder)
    started = time.perf_counter()
    with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        if not with_cluster:
            client.run(_warm)
            started = time.perf_counter()
        table = sweep.run(client, out)
        spent = time.perf_counter() - started
    if with_cluster:
        spent = time.perf_counter() - started
    assert (table['status'] == 'ok').all() and len(table) == sweep.total
    return spent


def mujoco_rollout(runs, threads):
    """Return the seconds of ``runs`` rollouts of STEPS steps of the store on its hinge."""
    model = models.store(DT)
    datas = [mujoco.MjData(model) for _ in range(threads)]
    size = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    state = np.zeros((runs, size))
    mujoco.mj_getState(model, datas[0], state[0], mujoco.mjtState.mjSTATE_FULLPHYSICS)
    state[:] = state[0]
    rng = np.random.default_rng(0)
    state[:, 1 + model.nq] = rng.normal(0.0, 0.01, runs)   # a little initial pitch rate
    started = time.perf_counter()
    rollout.rollout(model, datas, state, nstep=STEPS)
    return time.perf_counter() - started


def main():
    """Run the benchmark and print its figures."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    parser.add_argument('--runs', type=int, default=1000)
    parser.add_argument('--repeats', type=int, default=3)
    args = parser.parse_args()
    steps = args.runs * STEPS
    with tempfile.TemporaryDirectory() as folder:
        path = sweep_file(folder, args.runs)
        times = {}
        for _ in range(args.repeats):
            for workers in (1, 2):   # the sides take turns
                for with_cluster in (True, False):
                    times.setdefault(('cfem', workers, with_cluster), []).append(
                        cfem_sweep(path, workers, folder, with_cluster))
                times.setdefault(('mujoco', workers, False), []).append(
                    mujoco_rollout(args.runs, workers))
    print(f'{args.runs} runs of {STEPS} steps (store separation, dt {DT} s, '
          f'{DURATION} s), medians of {args.repeats}, {os.cpu_count()} CPUs')
    print(f'{"":<44} {"total s":>9} {"run-steps/s":>12}')
    for workers in (1, 2):
        ours = statistics.median(times[('cfem', workers, False)])
        whole = statistics.median(times[('cfem', workers, True)])
        theirs = statistics.median(times[('mujoco', workers, False)])
        print(f'{f"cfem_ros sweep, {workers} worker(s), cluster start incl.":<44} '
              f'{whole:9.2f} {steps / whole:12.3g}')
        print(f'{f"cfem_ros sweep, {workers} worker(s), warm cluster":<44} '
              f'{ours:9.2f} {steps / ours:12.3g}')
        print(f'{f"mujoco.rollout, {workers} thread(s)":<44} {theirs:9.2f} '
              f'{steps / theirs:12.3g}')
        print(f'{"":<4}cfem_ros / MuJoCo run-steps per second, {workers}: '
              f'{theirs / ours:.2f}x (warm), {theirs / whole:.2f}x (cluster start incl.)')


if __name__ == '__main__':
    main()
