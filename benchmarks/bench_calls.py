# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Microseconds per call of the kernel on small models, where a call's fixed cost shows.

A node or a paced session calls the kernel once a sample or once a step; on a
small model what a call costs besides its steps (checking its arrays, finding
its arguments) is a large part of the whole. Measured through the public API
only (``Simulator.advance_to`` one step a call, ``Simulator.outputs``,
``Simulator.joint_wrenches``), so that any two builds compare
(``compare_builds.py``). Medians of --repeats turns of --calls calls each, in
the process's CPU time (``time.process_time``): on a machine shared with other
work, the wall clock counts the time the process waits for a core.

Usage: .venv/bin/python benchmarks/bench_calls.py [--calls 2000] [--repeats 7]
"""

import argparse
import pathlib
import statistics
import time

from cfem_ros import load_scenario, Simulator
import numpy as np

CONFIG = pathlib.Path(__file__).resolve().parents[1] / 'config'
SCENARIOS = ('double_pendulum', 'store_separation', 'fixed_joint_spin', 'joints/hinge')


def per_call(sim, calls, what):
    """Return microseconds per call of one of the measured calls."""
    dt = sim.dt
    out = np.empty_like(sim.outputs())
    start = time.process_time()
    if what == 'step':
        t = sim.t
        for k in range(1, calls + 1):
            sim.advance_to(t + k * dt)
    elif what == 'outputs':
        for _ in range(calls):
            sim.outputs(out)
    else:
        for _ in range(calls):
            sim.joint_wrenches()
    return (time.process_time() - start) / calls * 1e6


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--calls', type=int, default=2000)
    parser.add_argument('--repeats', type=int, default=7)
    args = parser.parse_args()
    print(f'us per call (CPU time), median of {args.repeats} turns of {args.calls} calls; '
          'dt = 1 ms')
    print(f'{"scenario":<20} {"one step":>10} {"outputs":>10} {"joint loads":>12}')
    for name in SCENARIOS:
        model = load_scenario(str(CONFIG / f'{name}.yaml'), duration=1000.0, dt=0.001)
        found = {what: [] for what in ('step', 'outputs', 'loads')}
        for _ in range(args.repeats):
            for what in found:
                sim = Simulator(model)
                sim.advance_to(0.01)
                found[what].append(per_call(sim, args.calls, what))
        step, outputs, loads = (statistics.median(found[w]) for w in ('step', 'outputs', 'loads'))
        print(f'{name:<20} {step:10.2f} {outputs:10.2f} {loads:12.2f}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
