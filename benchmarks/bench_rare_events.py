# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Runs needed for a 10 % coefficient of variation at P(fail) = 1e-4, by method.

The failure is a threshold of one normal parameter (the release angle; a
second, uniform parameter is ignored), the exact probability 1e-4, and
every point goes through the study pipeline (``run_study``: the
Evaluator, its Parquet parts, the criteria, OpenTURNS), the runs computed
from the values instead of simulated (the scenario-free path of the
tests). Each method runs with several seeds, in turns; its coefficient of
variation is the spread of its estimates over the seeds (not the one the
method reports, which for subset sampling is optimistic), and the runs it
needs for 10 % are its median runs x (CoV / 0.1)^2. Plain Monte Carlo
needs (1 - p) / (p 0.1^2) = 999,900 runs.

Usage: .venv/bin/python benchmarks/bench_rare_events.py [--seeds 10] [--runs 1000]
(needs the study extra: pip install -e '.[study]').
"""

import argparse
import os
import statistics
import sys
import tempfile
import time

from cfem_ros.study import load_sweep
from cfem_ros.study.methods import run_study
from cfem_ros.study.sweep import columns
import numpy as np
from scipy.stats import norm
import yaml

P, TARGET = 1e-4, 0.1
ANGLE = 'joints.pivot.release.angle_deg'
SCENARIO = {'name': 'bench', 'duration': 0.1, 'dt': 0.01, 'bodies': {
    'pylon': {'fixed': True}, 'store': {'mass': 907.0, 'inertia': [27.0, 488.0, 488.0]}},
    'joints': {'pivot': {'type': 'hinge', 'parent': 'pylon', 'child': 'store',
                         'anchor': [-0.33, 0, -0.25], 'axis': [0, 1, 0],
                         'release': {'angle_deg': 10}}}}


def rows(spec, runs):
    """Return the rows of a batch: clearance 0.1 - 0.01 (angle - 10) m, angle ~ N(10, 1)."""
    names = columns(spec)
    out = []
    for k in runs:
        values = spec.run_values(k)
        row = dict.fromkeys(names, float('nan'))
        row.update(run=k, status='ok', message='', **values)
        row['clearance_store_pylon_min'] = 0.1 - 0.01 * (values[ANGLE] - 10.0)
        out.append(row)
    return out


def sweep_file(folder, seed, runs):
    """Write the sweep whose criterion fails with probability P; return its path."""
    with open(os.path.join(folder, 'scenario.yaml'), 'w') as stream:
        yaml.safe_dump(SCENARIO, stream)
    threshold = float(0.1 - 0.01 * norm.isf(P))
    path = os.path.join(folder, f'sweep_{seed}.yaml')
    with open(path, 'w') as stream:
        yaml.safe_dump({'scenario': 'scenario.yaml', 'runs': runs, 'seed': seed,
                        'vary': {ANGLE: {'normal': [10.0, 1.0]},
                                 'bodies.store.mass': {'uniform': [900.0, 910.0]}},
                        'metrics': {'clearance': [{'bodies': ['store', 'pylon']}]},
                        'criteria': {'miss': f'clearance_store_pylon_min >= {threshold!r}'}},
                       stream)
    return path


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--seeds', type=int, default=10)
    parser.add_argument('--runs', type=int, default=1000,
                        help='points per subset level, NAIS step, FORM batch')
    args = parser.parse_args(argv)
    methods = ('subset', 'nais', 'form')
    found = {m: [] for m in methods}
    with tempfile.TemporaryDirectory(prefix='cfem-bench-rare-') as folder:
        for seed in range(args.seeds):
            path = sweep_file(folder, seed, args.runs)
            for method in (methods if seed % 2 == 0 else methods[::-1]):   # turns
                started = time.perf_counter()
                result = run_study(load_sweep(path), os.path.join(folder, f'{method}_{seed}'),
                                   method=method, rows=rows, log=lambda line: None)
                wall = time.perf_counter() - started
                estimate = result['estimate']
                found[method].append((estimate.probability, estimate.runs, estimate.cov,
                                      estimate.ci_low <= P <= estimate.ci_high, wall,
                                      estimate.p_upper >= P))
                print(f'seed {seed} {method}: {estimate.sentence()}, {wall:.2f} s',
                      file=sys.stderr)
    mc = (1 - P) / (P * TARGET ** 2)
    print(f'P(fail) = {P:g} (exact), target coefficient of variation {TARGET:g}, '
          f'{args.seeds} seeds, {args.runs} points per level/step/batch')
    print(f'{"method":<8} {"median p":>10} {"CoV (seeds)":>11} {"CoV (own)":>9} '
          f'{"runs":>7} {"runs for 10%":>12} {"vs MC":>8} {"CI holds p":>10} '
          f'{"p_upper >= p":>12} {"s/study":>8}')
    for method, rows_ in found.items():
        p = np.array([r[0] for r in rows_])
        runs = statistics.median(r[1] for r in rows_)
        spread = float(np.std(p, ddof=1) / np.mean(p)) if len(p) > 1 else float('nan')
        needed = runs * (spread / TARGET) ** 2
        covered = sum(r[3] for r in rows_)
        print(f'{method:<8} {np.median(p):>10.3g} {spread:>11.3f} '
              f'{statistics.median(r[2] for r in rows_):>9.3f} {runs:>7.0f} {needed:>12.0f} '
              f'{mc / needed:>7.0f}x {covered:>4}/{len(rows_):<5} '
              f'{sum(r[5] for r in rows_):>6}/{len(rows_):<5} '
              f'{statistics.median(r[4] for r in rows_):>8.2f}')
    print(f'{"mc":<8} {P:>10.3g} {TARGET:>11.3f} {"":>9} {"":>7} {mc:>12.0f} {1:>7.0f}x')


if __name__ == '__main__':
    main()
