# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Where FORM's runs go: the guide's example study, counted by phase (issue 49.4).

``--method form`` of config/sweeps/store_separation_decision.yaml, run in
this process (no Dask: the runs' cost alone): the runs and batches of the
design point search, of the importance sampling around it, and of the tail
check's search and sampling on the heavier-tailed inputs, with the CPU time
of the whole study. On a cluster every batch is a round trip to the
workers: the batches, not only the runs, are what a study waits for.

Usage: .venv/bin/python benchmarks/bench_form.py [--turns 3]
"""

import argparse
import collections
import pathlib
import statistics
import tempfile
import time

from cfem_ros.study import load_sweep
from cfem_ros.study.methods import run_study

ROOT = pathlib.Path(__file__).resolve().parents[1]
SWEEP = ROOT / 'config' / 'sweeps' / 'store_separation_decision.yaml'


def one_study() -> tuple:
    """Return (runs by phase, batches by phase, CPU seconds, the estimate's line)."""
    phase = ['design point search']
    runs, batches = collections.Counter(), collections.Counter()

    def log(line):
        if line.startswith('design point'):
            phase[0] = phase[0].replace('design point search', 'importance sampling')
        elif line.startswith('tail check'):
            phase[0] = 'tail check: design point search'
        elif 'runs asked' in line:
            runs[phase[0]] += int(line.split()[0])
            batches[phase[0]] += 1

    with tempfile.TemporaryDirectory(prefix='cfem-bench-form-') as folder:
        start = time.process_time()
        found = run_study(load_sweep(str(SWEEP)), folder, method='form', log=log)
        spent = time.process_time() - start
    return runs, batches, spent, found['estimate'].sentence()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--turns', type=int, default=3, help='studies run (median CPU)')
    args = parser.parse_args()
    spent = []
    for _ in range(args.turns):
        runs, batches, cpu, line = one_study()
        spent.append(cpu)
    print(f'{SWEEP.relative_to(ROOT)}, --method form, in this process')
    for name in runs:
        print(f'   {name:44s} {runs[name]:5d} runs in {batches[name]:3d} batches')
    print(f'   {"all":44s} {sum(runs.values()):5d} runs in {sum(batches.values()):3d} '
          f'batches; {statistics.median(spent):.2f} s CPU (median of {args.turns})')
    print(line)


if __name__ == '__main__':
    main()
