# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Reading a large scenario: ``cfem-sim check`` on a chain of N bodies, and its phases.

A chain of N hinged bodies hangs from a moving aircraft (every body's
carrier is the aircraft, N joints away for the last one). For each N, in a
fresh process: the scenario's YAML load and parse, the Simulator's
construction and the start check (``start_problems``: the first step on a
copy); then ``cfem-sim check`` as a whole process. Medians of --repeats
runs, s. Usage: .venv/bin/python benchmarks/bench_parse.py [--sizes 200 800 10000]
[--repeats N]
"""

import argparse
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

import yaml

CFEM_SIM = pathlib.Path(sys.executable).parent / 'cfem-sim'

PHASES = r"""
import sys, time
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.run.startcheck import start_problems
from cfem_ros.core.scenario.parse import load_scenario
t0 = time.perf_counter()
model = load_scenario(sys.argv[1])
t1 = time.perf_counter()
sim = Simulator(model)
t2 = time.perf_counter()
errors, _ = start_problems(sim)
t3 = time.perf_counter()
assert not errors, errors
print(t1 - t0, t2 - t1, t3 - t2)
"""


def chain(count: int) -> dict:
    """Return a scenario: count bodies hinged one below the other from a moving aircraft."""
    bodies = {'aircraft': {'motion': {'velocity': [200.0, 0.0, 0.0]}}}
    joints = {}
    for i in range(count):
        bodies[f'b{i}'] = {'mass': 1.0, 'inertia': [0.1, 0.1, 0.1],
                           'position': [0.0, 0.0, -(i + 1.0)]}
        joints[f'j{i}'] = {'type': 'hinge', 'axis': [0, 1, 0],
                           'parent': 'aircraft' if i == 0 else f'b{i - 1}',
                           'child': f'b{i}', 'anchor': [0.0, 0.0, -(i + 0.5)]}
    return {'name': f'chain{count}', 'duration': 0.01, 'dt': 0.001,
            'gravity': [0.0, 0.0, 9.80665], 'bodies': bodies, 'joints': joints}


def main():
    """Print, per chain size, the phases' and the whole command's medians."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--sizes', type=int, nargs='+', default=[200, 800, 10000])
    parser.add_argument('--repeats', type=int, default=3)
    args = parser.parse_args()
    print(f'{"bodies":>7} {"load+parse":>11} {"Simulator":>10} {"start check":>12} '
          f'{"cfem-sim check":>15}  (medians of {args.repeats}, s)')
    with tempfile.TemporaryDirectory() as tmp:
        for count in args.sizes:
            path = pathlib.Path(tmp) / f'chain{count}.yaml'
            path.write_text(yaml.safe_dump(chain(count), sort_keys=False))
            phases, whole = [], []
            for _ in range(args.repeats):
                done = subprocess.run([sys.executable, '-c', PHASES, str(path)],
                                      capture_output=True, text=True)
                if done.returncode:
                    sys.exit(f'{count} bodies: {done.stderr[-2000:]}')
                phases.append([float(x) for x in done.stdout.split()])
                started = time.perf_counter()
                subprocess.run([str(CFEM_SIM), 'check', str(path)], capture_output=True,
                               check=True)
                whole.append(time.perf_counter() - started)
            med = [statistics.median(p[k] for p in phases) for k in range(3)]
            print(f'{count:>7} {med[0]:>11.3f} {med[1]:>10.3f} {med[2]:>12.3f} '
                  f'{statistics.median(whole):>15.3f}')


if __name__ == '__main__':
    main()
