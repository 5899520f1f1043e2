# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Step cost of a proximity table and two watched shape pairs, against the same store without them.

config/store_release_near_pylon.yaml (Mach tables, the pylon's flow field
over dx, dz, dtheta and Mach, store-pylon and store-wing contacts watched)
against the same scenario without ``proximity`` and ``contacts``; its hooks
are kept from letting go and its ejectors' strokes made too long to end, so
that every step of both runs computes the same loads but for the table and
the pairs (and no contact ends a run). The store falls out of the pylon's
field (its grid, 2.5 m deep, plus the 0.5 m fade) after about 0.6 s: beyond
it a step costs the fade's check, not the interpolation; and the pairs' GJK
runs only while their bounding spheres meet. ``--duration 0.3`` measures the
store inside the field throughout. A third run has the wing as a compound
of four boxes (its spanwise quarters, the same envelope; SPEC section 11): the
cost of a compound of 4 parts against 1, whose distance skips the pairs of
parts its bound proves apart. The runs alternate in turns; medians and their
ratios are printed.
Usage: .venv/bin/python benchmarks/bench_aero_contacts.py
"""

import argparse
import copy
import pathlib
import statistics
import time

from cfem_ros import parse_scenario, Simulator
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[1] / 'config'


def models(duration):
    """Return the store in free flight without, then with, the proximity table and pairs."""
    path = CONFIG / 'store_release_near_pylon.yaml'
    full = yaml.safe_load(path.read_text())
    full['duration'] = duration
    del full['joints']   # free flight from t = 0: the aero acts at every step
    full['wrenches'] = [dict(w, stroke=1e6) for w in full['wrenches']]
    bare = copy.deepcopy(full)
    del bare['aero']['store']['proximity']
    bare['aero']['store']['scale'] = {'Cm': 1.0}
    del bare['contacts']
    compound = copy.deepcopy(full)
    length, span, depth = compound['bodies']['wing']['shape']['box']
    compound['bodies']['wing']['shape'] = {'parts': [
        {'box': [length, span / 4, depth], 'at': [0.0, span * (k - 1.5) / 4, 0.0]}
        for k in range(4)]}
    return (parse_scenario(bare, source=str(path) + ' without proximity and contacts'),
            parse_scenario(full, source=str(path)),
            parse_scenario(compound, source=str(path)))   # the same folder: its table


def step_cost(model, duration):
    """
    Return microseconds per RK4 step of one run, in CPU time of this process.

    CPU time, not wall time: on a shared machine another process's turn on
    the core would otherwise count (runs of the same model varied 1.9 to
    15 us/step in wall time on two busy cores).
    """
    sim = Simulator(model)
    start = time.process_time()
    assert sim.advance_to(duration), sim.message
    return (time.process_time() - start) / sim.steps * 1e6


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--duration', type=float, default=1.0, help='simulated s per run')
    parser.add_argument('--turns', type=int, default=9)
    args = parser.parse_args()
    runs = models(args.duration)
    for model in runs:
        step_cost(model, 0.01)
    costs = [[] for _ in runs]
    for _ in range(args.turns):
        for model, cost in zip(runs, costs):
            cost.append(step_cost(model, args.duration))
    a, b, c = (statistics.median(cost) for cost in costs)
    print(f'dt = 1 ms, {args.duration:g} s simulated per run, median of {args.turns} turns '
          '(CPU time)')
    print(f'store with Mach tables, ejectors:                     {a:7.2f} us/step')
    print(f'+ proximity table and two watched shape pairs:        {b:7.2f} us/step   '
          f'ratio {b / a:.2f}')
    print(f'the same with the wing a compound of 4 parts:         {c:7.2f} us/step   '
          f'ratio {c / b:.2f} to 1 part')
    print('target: ratio <= 1.5')


if __name__ == '__main__':
    main()
