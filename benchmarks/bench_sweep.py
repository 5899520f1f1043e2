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


def sweep_file(folder, runs, scenario='hinge'):
    """
    Write the benchmark's sweep file.

    hinge: the example sweep without its dt grid (the store on its pivot,
    mass, release angle and pivot station drawn); ejectors: the store pushed
    off by its two ejectors (config/store_separation_ejectors.yaml, run to
    1.5 s), mass and the two ejector forces drawn.
    """
    with open(ROOT / 'config' / 'sweeps' / 'store_separation_sweep.yaml') as stream:
        sweep = yaml.safe_load(stream)
    sweep['scenario'] = str(ROOT / 'config' / 'store_separation.yaml')
    sweep['runs'] = runs
    del sweep['vary']['dt']
    if scenario == 'ejectors':
        with open(ROOT / 'config' / 'store_separation_ejectors.yaml') as stream:
            base = yaml.safe_load(stream)
        base['duration'] = DURATION
        sweep['scenario'] = os.path.join(folder, 'ejectors.yaml')
        with open(sweep['scenario'], 'w') as stream:
            yaml.safe_dump(base, stream)
        sweep['vary'] = {'bodies.store.mass': {'normal': [907.1848, 10.0]},
                         'wrenches[0].force[2]': {'normal': [10676, 500]},
                         'wrenches[1].force[2]': {'normal': [42703, 2000]}}
    path = os.path.join(folder, 'sweep.yaml')
    with open(path, 'w') as stream:
        yaml.safe_dump(sweep, stream)
    return path


def _warm():
    """Import what a task needs (a warm worker has run a task before)."""
    from cfem_ros.core.native import kernel  # noqa: F401 - loads the compiled kernel
    from cfem_ros.study import sweep  # noqa: F401
    import pandas  # noqa: F401
    import pyarrow.parquet  # noqa: F401
    return os.getpid()


def _peak_rss_mb():
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _cpu():
    return time.process_time()


def cfem_sweep(path, workers, folder, with_cluster):
    """
    Return (wall s, CPU s) of one sweep, with the cluster's start and close or not.

    CPU s: this process (client and scheduler) and the worker processes (their
    whole life with the start included; the nannies are left out).
    """
    sweep = Sweep.from_file(path)
    out = tempfile.mkdtemp(dir=folder)
    started, cpu = time.perf_counter(), _cpu()
    with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        before = 0.0
        if not with_cluster:
            client.run(_warm)
            started, cpu = time.perf_counter(), _cpu()
            before = sum(client.run(_cpu).values())
        table = sweep.run(client, out)
        spent = time.perf_counter() - started
        used = sum(client.run(_cpu).values()) - before + _cpu() - cpu
    if with_cluster:
        spent = time.perf_counter() - started   # CPU s: up to the close
    assert (table['status'] == 'ok').all() and len(table) == sweep.total
    return spent, used


def in_process(path, threads, folder):
    """Return (wall s, CPU s) of one sweep in this process on threads (``Sweep.run(None)``)."""
    sweep = Sweep.from_file(path)
    started, cpu = time.perf_counter(), _cpu()
    table = sweep.run(None, tempfile.mkdtemp(dir=folder), threads=threads)
    spent, used = time.perf_counter() - started, _cpu() - cpu
    assert (table['status'] == 'ok').all() and len(table) == sweep.total
    return spent, used


def mujoco_rollout(runs, threads):
    """Return (wall s, CPU s) of ``runs`` rollouts of STEPS steps of the store on its hinge."""
    model = models.store(DT)
    datas = [mujoco.MjData(model) for _ in range(threads)]
    size = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    state = np.zeros((runs, size))
    mujoco.mj_getState(model, datas[0], state[0], mujoco.mjtState.mjSTATE_FULLPHYSICS)
    state[:] = state[0]
    rng = np.random.default_rng(0)
    state[:, 1 + model.nq] = rng.normal(0.0, 0.01, runs)   # a little initial pitch rate
    started, cpu = time.perf_counter(), _cpu()
    rollout.rollout(model, datas, state, nstep=STEPS)
    return time.perf_counter() - started, _cpu() - cpu


def profile(path, runs):
    """Print where a run's time goes, in this process, one thread (ms per run)."""
    from cfem_ros.core.engine.simulator import Simulator
    from cfem_ros.study import metrics, runmodels, runs as study_runs, sweep as study_sweep
    spec = Sweep.from_file(path).spec
    models = runmodels.Models(spec)
    phases = dict.fromkeys(('whole parse (before)', 'document edit + parse', 'Simulator',
                            'run (kernel, samples taken)', 'sample collection', 'metrics',
                            'rows -> Parquet part'), 0.0)
    rows = []
    for k in list(range(min(5, runs))) + list(range(runs)):   # 5 to warm up
        values = spec.run_values(k)
        t0 = time.perf_counter()
        runmodels.full_model(spec, k, values)
        t1 = time.perf_counter()
        model = models.model(k, values)
        t2 = time.perf_counter()
        sim = Simulator(model)
        t3 = time.perf_counter()
        collector = metrics.Collector(sim)
        study_runs.session_run(sim, model, spec, collector)
        t4 = time.perf_counter()
        samples = collector.samples()
        t5 = time.perf_counter()
        rows.append(metrics.compute(samples, spec.metrics))
        t6 = time.perf_counter()
        for name, spent in zip(phases, (t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4,
                                        t6 - t5)):
            phases[name] += spent
    for name in phases:   # the warm-up's share out
        phases[name] *= runs / (runs + min(5, runs))
    with tempfile.TemporaryDirectory() as folder:
        t0 = time.perf_counter()   # a worker's first part: imports, once
        study_sweep.write_atomic(study_sweep.frame([], study_sweep.columns(spec)),
                                 os.path.join(folder, 'first.parquet'))
        first = time.perf_counter() - t0
        t0 = time.perf_counter()
        table = []
        for k, row in zip(range(runs), rows[-runs:]):   # what run_one adds to the metrics
            values = spec.run_values(k)
            table.append({'run': k, **{v.path: study_runs.column_value(
                values[v.path], study_runs.numeric(v)) for v in spec.variables},
                'status': 'ok', 'message': '', **row})
        study_sweep.write_atomic(study_sweep.frame(table, study_sweep.columns(spec)),
                                 os.path.join(folder, 'part.parquet'))
    phases['rows -> Parquet part'] = time.perf_counter() - t0
    total = sum(v for k, v in phases.items() if k != 'whole parse (before)')
    print(f'profile: {runs} runs in this process, one thread, load average '
          f'{os.getloadavg()[0]:.1f}')
    for name, spent in phases.items():
        print(f'  {name:<30} {1e3 * spent / runs:8.3f} ms/run'
              + ('' if name.startswith('whole') else f' {100 * spent / total:5.1f} %'))
    print(f'  {"total (without the first line)":<30} {1e3 * total / runs:8.3f} ms/run')
    print(f'  and once per worker, its first part (imports): {first:.2f} s')


def main():
    """Run the benchmark and print its figures."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    parser.add_argument('--runs', type=int, default=1000)
    parser.add_argument('--repeats', type=int, default=3)
    parser.add_argument('--scenario', choices=('hinge', 'ejectors'), default='hinge')
    parser.add_argument('--size', type=int, metavar='RUNS',
                        help='only run one sweep of RUNS runs on --workers and print what '
                        'sizes a 1,000,000-run sweep')
    parser.add_argument('--workers', type=int, default=2)
    parser.add_argument('--in-process', action='store_true',
                        help='only time the sweep in this process (no Dask) on 1 and 2 '
                        'threads, each against mujoco.rollout')
    parser.add_argument('--profile', type=int, metavar='RUNS',
                        help='only print where the time of RUNS runs goes, in this process')
    args = parser.parse_args()
    if args.profile:
        with tempfile.TemporaryDirectory() as folder:
            return profile(sweep_file(folder, args.profile, args.scenario), args.profile)
    if args.in_process:
        with tempfile.TemporaryDirectory() as folder:
            path = sweep_file(folder, args.runs, args.scenario)
            in_process(path, 1, folder)   # imports, once
            for _ in range(args.repeats):
                for threads in (1, 2):
                    load = os.getloadavg()[0]
                    wall, cpu = in_process(path, threads, folder)
                    wall_mj, cpu_mj = mujoco_rollout(args.runs, threads)
                    print(f'{args.runs} runs in this process, {threads} thread(s): {wall:.2f} s '
                          f'({args.runs * STEPS / wall:.3g} run-steps/s, CPU {cpu:.2f} s); '
                          f'mujoco.rollout {wall_mj:.2f} s (CPU {cpu_mj:.2f} s): '
                          f'{wall_mj / wall:.2f}x; load average {load:.1f}')
        return None
    if args.size:
        with tempfile.TemporaryDirectory() as folder:
            return size(sweep_file(folder, args.size, args.scenario), args.workers, folder)
    steps = args.runs * STEPS
    loads = [os.getloadavg()[0]]
    with tempfile.TemporaryDirectory() as folder:
        path = sweep_file(folder, args.runs, args.scenario)
        times = {}
        for _ in range(args.repeats):
            for workers in (1, 2):   # the sides take turns
                for with_cluster in (True, False):
                    times.setdefault(('cfem', workers, with_cluster), []).append(
                        cfem_sweep(path, workers, folder, with_cluster))
                    loads.append(os.getloadavg()[0])
                times.setdefault(('mujoco', workers, False), []).append(
                    mujoco_rollout(args.runs, workers))
                loads.append(os.getloadavg()[0])
    print(f'{args.runs} runs of {STEPS} steps ({args.scenario} store separation, dt {DT} s, '
          f'{DURATION} s), medians of {args.repeats}, {os.cpu_count()} CPUs, 1-min load '
          f'average {min(loads):.1f}-{max(loads):.1f} (median {statistics.median(loads):.1f})')
    print(f'{"":<44} {"wall s":>8} {"run-steps/s":>12} {"CPU s":>8} {"steps/CPU s":>12}')

    def median(key):
        return tuple(statistics.median(t[i] for t in times[key]) for i in (0, 1))

    for workers in (1, 2):
        for label, key in ((f'cfem_ros sweep, {workers} worker(s), cluster start incl.',
                            ('cfem', workers, True)),
                           (f'cfem_ros sweep, {workers} worker(s), warm cluster',
                            ('cfem', workers, False)),
                           (f'mujoco.rollout, {workers} thread(s)', ('mujoco', workers, False))):
            wall, cpu = median(key)
            print(f'{label:<44} {wall:8.2f} {steps / wall:12.3g} {cpu:8.2f} {steps / cpu:12.3g}')
        ours, whole, theirs = (median(('cfem', workers, False)), median(('cfem', workers, True)),
                               median(('mujoco', workers, False)))
        print(f'{"":<4}cfem_ros / MuJoCo run-steps per second, {workers}: '
              f'{theirs[0] / ours[0]:.2f}x (warm), {theirs[0] / whole[0]:.2f}x (cluster start '
              f'incl.); per CPU second {theirs[1] / ours[1]:.2f}x (warm)')
    best = min(median(('cfem', w, True))[0] for w in (1, 2))
    # like with like: 2 workers against 2 threads; and each side at its faster count
    pair = median(('mujoco', 2, False))[0] / median(('cfem', 2, False))[0]
    fastest = (min(median(('mujoco', w, False))[0] for w in (1, 2))
               / min(median(('cfem', w, False))[0] for w in (1, 2)))
    print(f'targets: 1,000 runs with the cluster start under 20 s: {best:.1f} s '
          f'({"met" if best < 20 else "not met"}); 2x rollout: {pair:.2f}x with 2 workers '
          f'against 2 threads ({"met" if pair >= 2 else "not met"}), {fastest:.2f}x each at '
          f'its faster count ({"met" if fastest >= 2 else "not met"}); on a warm cluster, on '
          'this machine at this load')


def size(path, workers, folder):
    """Run one sweep and print what sizes a 1,000,000-run sweep: time, memory, output."""
    sweep = Sweep.from_file(path)
    out = os.path.join(folder, 'out')
    load = os.getloadavg()[0]
    started = time.perf_counter()
    with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        table = sweep.run(client, out)
        spent = time.perf_counter() - started
        rss = sorted(client.run(_peak_rss_mb).values())
    parts = [os.path.join(out, 'parts', p) for p in os.listdir(os.path.join(out, 'parts'))]
    part_bytes = sum(os.path.getsize(p) for p in parts)
    result_bytes = os.path.getsize(os.path.join(out, 'results.parquet'))
    n = len(table)
    assert (table['status'] == 'ok').all() and n == sweep.total
    rate = n / spent / workers
    print(f'{n} runs on {workers} worker(s) ({len(parts)} tasks of about {n // len(parts)} '
          f'runs), {spent:.1f} s with the cluster start, load average {load:.1f}-'
          f'{os.getloadavg()[0]:.1f}: {rate:.1f} runs/s per worker')
    print(f'  peak memory per worker {", ".join(f"{r:.0f}" for r in rss)} MB; '
          f'results.parquet {result_bytes / 1e6:.2f} MB ({result_bytes / n:.0f} bytes/run, '
          f'{len(table.columns)} columns), parts {part_bytes / 1e6:.2f} MB')
    million = 1_000_000
    print(f'  1,000,000 runs: {million / rate / 3600:.1f} worker-hours at this rate; '
          f'results.parquet about {result_bytes / n * million / 1e6:.0f} MB, parts about '
          f'{part_bytes / n * million / 1e6:.0f} MB')


if __name__ == '__main__':
    main()
