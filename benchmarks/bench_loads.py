# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Step cost of scheduled loads: the store on its hinge with and without two ejectors.

The ejectors of config/store_separation_ejectors.yaml are added to
config/store_separation.yaml (its pivot kept, so both runs solve the same
joint) with a stroke too long to end, so that they act, and their strokes
are watched, at every step. The two runs alternate
in turns; medians and their ratio are printed.
Usage: .venv/bin/python benchmarks/bench_loads.py
"""

import argparse
import pathlib
import statistics
import time

from cfem_ros import parse_scenario, Simulator
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[1] / 'config'


def models(duration):
    """Return the scenario without and with the two ejectors."""
    base = yaml.safe_load((CONFIG / 'store_separation.yaml').read_text())
    ejectors = yaml.safe_load((CONFIG / 'store_separation_ejectors.yaml').read_text())
    base['duration'] = duration
    del base['joints']['pivot']['release']   # the same joints all along in both runs
    loaded = dict(base, wrenches=[dict(w, stroke=1e6) for w in ejectors['wrenches']])
    return (parse_scenario(base, source='store_separation'),
            parse_scenario(loaded, source='store_separation + 2 ejectors'))


def step_cost(model, duration):
    """Return microseconds per RK4 step of one run."""
    sim = Simulator(model)
    start = time.perf_counter()
    assert sim.advance_to(duration), sim.message
    return (time.perf_counter() - start) / sim.steps * 1e6


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--duration', type=float, default=2.0, help='simulated s per run')
    parser.add_argument('--turns', type=int, default=7)
    args = parser.parse_args()
    plain, loaded = models(args.duration)
    step_cost(plain, 0.01), step_cost(loaded, 0.01)   # compile (cached)
    costs = {'plain': [], 'loaded': []}
    for _ in range(args.turns):
        costs['plain'].append(step_cost(plain, args.duration))
        costs['loaded'].append(step_cost(loaded, args.duration))
    a, b = statistics.median(costs['plain']), statistics.median(costs['loaded'])
    print(f'dt = 1 ms, {args.duration:g} s simulated per run, median of {args.turns} turns')
    print(f'store on its hinge:               {a:7.2f} us/step')
    print(f'the same with two ejectors:       {b:7.2f} us/step')
    print(f'ratio: {b / a:.2f} (target <= 1.3)')


if __name__ == '__main__':
    main()
