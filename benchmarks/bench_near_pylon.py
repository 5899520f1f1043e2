# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Where a near-pylon run's time goes, against the paper's case (issue 49.4).

1. Step cost, CPU time per RK4 step (medians of --turns, the models in
   turns): the paper's case (config/store_separation.yaml: a store on its
   hinge, no aero) against config/store_release_near_pylon.yaml as shipped,
   then with one piece taken away at a time: its two watched shape pairs
   (contacts), its pylon flow-field table (proximity), all of its aero. The
   near-pylon runs are released as shipped and end at 1 s or at a contact.
2. A sweep's runs under cProfile: the first --runs runs of
   config/sweeps/store_release_near_pylon_sweep.yaml on one thread
   (``run_rows``: the model made from the draw, the Simulator, the Session
   stepping to each sample, the metrics: distances between samples), their
   own time summed by where it is spent, then the functions taking most.
3. The same runs without the profiler, CPU time a run: as shipped, and
   with the distance metrics taken at the samples only (no body's track
   between samples, as for a run whose twists were not recorded): what the
   search between samples (SPEC section 15) costs, and what it changes.

The sweep file's ``dt`` grid of two steps runs every draw twice: ``--runs
10000`` is 20,000 runs (not a tail check); 60 s for them on 2 cores is 6 ms of
CPU a run. Measured 2026-12-02 (helper B, load average 4 to 11, CPU time; the
before and after in alternating processes): a sweep run 16.1 -> 13.0 ms (load
5) and 17.3 -> 15.2 ms (load 8), the model from the draw 3.2 -> 0.35 ms (aero
scales set on the tables read once, ``aeroscale``), a run's metrics 7.6 ->
7.1 ms (a body's Motion made once). Then (helper A, load average 13 to 15 on
the 2 cores, CPU time, 300 runs a process, 4 turns alternating the search in
Python (a copy of the package before) and in the kernel (``cpp/between.hpp``)):
a sweep run 9.6 -> 7.2 ms (medians; x1.34), its metrics 4.2 -> 1.4 ms (the
searches themselves, two shape windows and one clearance, about 0.1 ms of
it); left: the stepping (Session.run) 3.8 ms, of which the kernel's advance
about 2.5 ms and the engine's Python about 1 ms, the Simulator 1.0 ms, the
model 0.4 ms. In one process at load 8 to 12: 6.0 to 6.4 ms a run.
Part 1 (helper E, 2026-12-02, load 13 to 17, CPU, medians of 5 and 7 turns): the paper's
case 0.45 to 0.50 us a step, near pylon as shipped 2.30 to 2.40 (4.6x to 5.4x the
paper's; issue 49.4 asks 3x: not met), without the contacts 2.33 to 2.36, without the
flow-field table 1.68 to 1.74, without any aero 0.86 to 1.09. Of the kernel's own time
in near-pylon runs (perf): the aero tables about half (the two multilinear reads 26 %,
the flow and wrench 11 %, the ISA pow 8 %, atan2 and asin 4 %), the carrier's
prescribed motion 10 % (motion.cpp's exp map, sin and cos per stage), the body terms,
dy/dt and RK4 sums 17 %, the scheduled loads and strokes 7 %, the contacts under 1 %.

CPU time, not wall time: on a shared machine another process's turn on the
core would count. cProfile slows the Python side (each call is counted),
not the compiled kernel: the shares of part 2 overstate Python somewhat.
Usage: .venv/bin/python benchmarks/bench_near_pylon.py [--turns 5] [--runs 10]
"""

import argparse
import copy
import cProfile
import pathlib
import pstats
import statistics
import time

from cfem_ros import parse_scenario, Simulator
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[1]
CONFIG = ROOT / 'config'

#: A run's phases: (what, file, function) whose cumulative time is the phase's.
PHASES = [
    ('model from the draw', 'study/runmodels.py', 'model'),
    ('Simulator set-up', 'core/engine/simulator.py', '__init__'),
    ('stepping and sampling (Session.run)', 'core/run/session.py', 'run'),
    ('metrics (metrics.compute)', 'study/metrics.py', 'compute'),
    ('  of which the shape distances between samples', 'core/native/kernel.py',
     'least_shape_distance'),
    ('  of which the clearances between samples', 'core/native/kernel.py',
     'least_point_distance'),
]
#: Where a function's own time is counted, by its file (first match) or, for a
#: builtin, by its name.
PLACES = [
    ('compiled kernel (stepping, aero, contacts)', ('_kernel',)),
    ('model from the draw (parse, key paths)', ('core/scenario', 'core/fileio', 'core/model',
                                                'study/runmodels', 'study/keypaths',
                                                'yaml')),
    ('Simulator set-up (Python)', ('core/engine',)),
    ('session, events, sampling (Python)', ('core/run', 'core/native')),
    ('metrics: distances between samples', ('study/metrics', 'study/between',
                                            'study/windowed', 'study/shape_metrics',
                                            'core/geometry')),
    ('numpy, scipy', ('numpy', 'scipy')),
]


def near_pylon(strip=None):
    """Return the near-pylon model, without 'contacts', 'proximity' or 'aero' if asked."""
    path = CONFIG / 'store_release_near_pylon.yaml'
    document = yaml.safe_load(path.read_text())
    document = copy.deepcopy(document)
    if strip in ('contacts', 'proximity', 'aero'):
        document.pop('contacts', None)
    if strip in ('proximity', 'aero'):
        aero = document['aero']['store']
        del aero['proximity']
        aero['scale'] = {k: v for k, v in aero['scale'].items() if not k.startswith('d')}
    if strip == 'aero':
        del document['aero']
    return parse_scenario(document, source=str(path))


def paper_case():
    """Return the paper's case (config/store_separation.yaml)."""
    path = CONFIG / 'store_separation.yaml'
    return parse_scenario(yaml.safe_load(path.read_text()), source=str(path))


def step_cost(model):
    """Return (microseconds per RK4 step in CPU time, steps) of one run to its end."""
    sim = Simulator(model)
    start = time.process_time()
    sim.advance_to(model.duration)
    return (time.process_time() - start) / max(sim.steps, 1) * 1e6, sim.steps


def step_costs(turns: int):
    """Print the step cost of each model (median of turns) and its ratio to the paper's."""
    models = [('paper case: store on its hinge, no aero', paper_case()),
              ('near pylon as shipped', near_pylon()),
              ('  without the two watched shape pairs', near_pylon('contacts')),
              ('  ... and without the flow-field table', near_pylon('proximity')),
              ('  ... and without any aero', near_pylon('aero'))]
    costs = [[] for _ in models]
    steps = [0] * len(models)
    for _ in range(turns):
        for k, (_, model) in enumerate(models):
            cost, steps[k] = step_cost(model)
            costs[k].append(cost)
    base = statistics.median(costs[0])
    print(f'1. CPU time per RK4 step, median of {turns} turns')
    for (name, _), cost, n in zip(models, costs, steps):
        median = statistics.median(cost)
        print(f'   {name:44s} {median:8.2f} us/step  {median / base:6.2f} x paper  '
              f'({n} steps)')


def place(key) -> str:
    """Return where a profile entry's own time is spent."""
    filename, _, name = key
    text = name if filename == '~' else filename
    for where, marks in PLACES:
        if any(mark in text for mark in marks):
            return where
    return 'other Python (pandas, the sweep, the interpreter)'


def profile(runs: int, top: int = 15):
    """Print where the time of a sweep's first runs goes, by place and by function."""
    from cfem_ros.study import load_sweep
    from cfem_ros.study.runs import run_rows
    # enough draws for the runs asked (each draw is a row per grid value)
    spec = load_sweep(str(CONFIG / 'sweeps' / 'store_release_near_pylon_sweep.yaml'), runs=runs)
    run_rows(spec, [0])   # imports and first-call costs out of the figures
    profiler = cProfile.Profile(time.process_time)
    start = time.process_time()
    profiler.enable()
    rows = run_rows(spec, list(range(runs)))
    profiler.disable()
    total = time.process_time() - start
    stats = pstats.Stats(profiler)
    spent = {}
    for key, (_, _, own, _, _) in stats.stats.items():
        spent[place(key)] = spent.get(place(key), 0.0) + own
    status = {}
    for row in rows:
        status[row['status']] = status.get(row['status'], 0) + 1
    print(f'\n2. {runs} runs of the near-pylon sweep under cProfile: {total:.2f} s CPU, '
          f'{total / runs * 1e3:.0f} ms a run ({status})')
    print('   by phase (cumulative time):')
    for what, filename, function in PHASES:
        held = sum(ct for (f, _, name), (_, _, _, ct, _) in stats.stats.items()
                   if f.endswith(filename) and name == function)
        print(f'   {what:52s} {held:7.2f} s  {100 * held / total:5.1f} %')
    print('   by where the own time is spent:')
    for where, own in sorted(spent.items(), key=lambda item: -item[1]):
        print(f'   {where:52s} {own:7.2f} s  {100 * own / total:5.1f} %')
    print(f'\n   the {top} functions with most own time:')
    stats.sort_stats('tottime').print_stats(top)


def run_costs(runs: int, turns: int):
    """
    Print the CPU time of a sweep run: as shipped, and with the distances at the samples only.

    With each, the largest change of a ``_min`` column from the runs as shipped (m).
    """
    from cfem_ros.study import between, load_sweep
    from cfem_ros.study.runs import run_rows
    # enough draws for the runs asked (each draw is a row per grid value)
    spec = load_sweep(str(CONFIG / 'sweeps' / 'store_release_near_pylon_sweep.yaml'), runs=runs)
    shipped = between.motion

    def no_track(samples, body):
        return None   # no interpolant: the samples alone, as for a run without twists

    ways = {'as shipped': shipped, 'distances at the samples only': no_track}
    costs = {name: [] for name in ways}
    rows = {}
    for _ in range(turns):
        for name, motion in ways.items():
            between.motion = motion
            try:
                start = time.process_time()
                rows[name] = run_rows(spec, list(range(runs)))
                costs[name].append((time.process_time() - start) / runs * 1e3)
            finally:
                between.motion = shipped
    print(f'\n3. CPU time of a sweep run (run_rows, {runs} runs, median of {turns} turns), '
          'and the largest change of a least distance from the runs as shipped')
    first = rows['as shipped']
    for name, cost in costs.items():
        change = max((abs(a[c] - b[c]) for a, b in zip(first, rows[name]) for c in a
                      if c.endswith('_min') and isinstance(a[c], float)), default=0.0)
        print(f'   {name:48s} {statistics.median(cost):8.1f} ms a run   {change:.2g} m')
    # the sweep file's dt grid (0.001, 0.0005 s) runs every draw at both steps: --runs
    # 10000 is 20,000 runs (no tail check: that is a study's, not a sweep's)
    cost = statistics.median(costs['as shipped'])
    print(f'   --runs 10000 is {2 * 10000:,} runs (the dt grid of 2 steps); on 2 idle cores '
          f'at this CPU time, {2 * 10000 * cost / 2e3:.0f} s of runs (60 s needs '
          f'{60 * 2e3 / 20000:.0f} ms a run; 10,000 runs alone, {60 * 2e3 / 10000:.0f} ms)')


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--turns', type=int, default=5, help='step-cost runs per model')
    parser.add_argument('--runs', type=int, default=10, help='sweep runs profiled')
    args = parser.parse_args()
    step_costs(args.turns)
    profile(args.runs)
    run_costs(args.runs, args.turns)


if __name__ == '__main__':
    main()
