# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Step cost of applied loads: the store on its hinge with and without ejectors and aero.

The ejectors of config/store_separation_ejectors.yaml are added to
config/store_separation.yaml (its pivot kept, so both runs solve the same
joint) with a stroke too long to end, so that they act, and their strokes
are watched, at every step; a third run adds the aerodynamic table of
config/store_separation_aero.yaml; a fourth adds four sway braces (SPEC
section 11) between the store and the pylon, preloaded and soft enough to
keep their pads in contact all along, so that each is evaluated at every RK4
stage and its contact watched at every step; a fifth gives the aero table the
keys of SPEC section 10 (moments about a reference point off the CG, a CG
offset, increments, a hot day, and a Mach grid, so that the table's edges in
alpha, beta and Mach are watched after every step). The runs alternate in turns;
medians and their ratios are printed.
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
    """Return the scenario bare, with two ejectors, aero, sway braces, section 10's aero."""
    base = yaml.safe_load((CONFIG / 'store_separation.yaml').read_text())
    aero = yaml.safe_load((CONFIG / 'store_separation_aero.yaml').read_text())
    base['duration'] = duration
    del base['joints']['pivot']['release']   # the same joints all along in every run
    loaded = dict(base, wrenches=[dict(w, stroke=1e6) for w in aero['wrenches']])
    braces = [{'name': f'brace{k}', 'body': 'store', 'carrier': 'pylon',
               'point': [x, side * 0.1434, -0.2048], 'direction': [0, -side * 0.5736, 0.8192],
               'preload': 2000.0, 'stiffness': 100.0, 'damping': 10.0}
              for k, (x, side) in enumerate([(0.45, -1), (0.45, 1), (-0.45, -1), (-0.45, 1)])]
    full = dict(loaded, aero=aero['aero'])
    return (parse_scenario(base, source='store_separation'),
            parse_scenario(loaded, source='store_separation + 2 ejectors'),
            parse_scenario(full, source='... + aero'),
            parse_scenario(dict(full, sway_braces=braces), source='... + 4 sway braces'),
            parse_scenario(section_10(loaded, aero['aero']['store']), source='... section 10'))


def section_10(loaded, table):
    """Return the ejectors' scenario with the aero table given the keys of SPEC section 10."""
    table = {k: v for k, v in table.items() if k != 'altitude'}
    table.update(reference_point=[0.1, 0, 0], delta={'Cm': 0.02, 'CZ': -0.05},
                 atmosphere={'altitude': 7925, 'temperature_offset': 15},
                 mach=[0.6, 0.95, 1.2], outside='hold')
    store = dict(loaded['bodies']['store'], cg_offset=[0.02, 0, 0])
    return dict(loaded, bodies=dict(loaded['bodies'], store=store), aero={'store': table})


def step_cost(model, duration):
    """
    Return microseconds per RK4 step of one run, in CPU time of this process.

    CPU time, as bench_aero_contacts.py measures: on a shared machine wall
    time counts other processes' turns (a run of the ejectors' model took
    14 times the bare one's in wall time on two busy cores, 1.4 in CPU time).
    """
    sim = Simulator(model)
    start = time.process_time()
    assert sim.advance_to(duration), sim.message
    return (time.process_time() - start) / sim.steps * 1e6


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--duration', type=float, default=2.0, help='simulated s per run')
    parser.add_argument('--turns', type=int, default=7)
    args = parser.parse_args()
    runs = models(args.duration)
    for model in runs:
        step_cost(model, 0.01)   # compile (cached)
    costs = [[] for _ in runs]
    for _ in range(args.turns):
        for model, cost in zip(runs, costs):
            cost.append(step_cost(model, args.duration))
    a, b, c, d, e = (statistics.median(cost) for cost in costs)
    print(f'dt = 1 ms, {args.duration:g} s simulated per run, median of {args.turns} turns '
          '(CPU time)')
    print(f'store on its hinge:                   {a:7.2f} us/step')
    print(f'the same with two ejectors:           {b:7.2f} us/step   ratio {b / a:.2f}')
    print(f'with two ejectors and an aero table:  {c:7.2f} us/step   ratio {c / a:.2f}')
    print(f'and four sway braces:                 {d:7.2f} us/step   ratio {d / a:.2f} '
          f'({d / c:.2f} to the run before)')
    print(f'the aero table with section 10 keys:  {e:7.2f} us/step   ratio {e / a:.2f}')
    print(f'the aero table alone:                 {c - b:7.2f} us/step')
    print(f'the section 10 table alone:           {e - b:7.2f} us/step')
    print('target: ratio <= 1.3')


if __name__ == '__main__':
    main()
