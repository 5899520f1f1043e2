# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
cfem_ros against MuJoCo on the same models: microseconds per RK4 step and error.

Both engines run in this one process, at the same dt with RK4 (MuJoCo as a
Python loop of mj_step, as a user would drive it). Times are medians over
repeats; the error is the largest CG position difference (m) at the end of
a short run from a reference: cfem_ros itself at dt / 16. Also: the cost of
recording at 100 Hz, 1,000 store separations in one batch call against
1,000 sequential runs, and the scale figure (runs/bench/scale.png unless --figure says).

Usage: .venv/bin/python benchmarks/suite.py [--quick] [--cpu-time]
(MuJoCo comes with the ``bench`` extra: pip install -e .[bench]).
"""

import argparse
import dataclasses
import logging
import math
import os
import pathlib
import statistics
import sys
import tempfile
import time

from cfem_ros import load_scenario, parse_scenario, Simulator
from cfem_ros.core.run import batch
from cfem_ros.recording import offline
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.recorder import StateRecorder
import mujoco
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import models  # noqa: E402, I100

ROOT = pathlib.Path(__file__).resolve().parents[1]
CONFIG = ROOT / 'config'
DT = 0.001


def cfem_run(model, steps):
    """Return a run of the engine over `steps` steps from the start (set-up untimed)."""
    sims = []

    def run():
        assert sims.pop().advance_to(steps * model.dt)

    run.prepare = lambda: sims.append(Simulator(model))
    return run


def mujoco_run(model, data0, steps):
    """Return a Python loop of `steps` mj_step calls from the same start (set-up untimed)."""
    datas = []

    def run():
        data = datas.pop()
        for _ in range(steps):
            mujoco.mj_step(model, data)

    def prepare():
        data = mujoco.MjData(model)
        data.qpos[:] = data0.qpos
        data.qvel[:] = data0.qvel
        datas.append(data)
    run.prepare = prepare
    return run


#: The clock of the timed runs: the wall clock, or with --cpu-time this process's CPU
#: time (on a machine shared with other work, the wall clock also counts the waits for a
#: core; the batch of threads is timed on the wall clock either way).
CLOCK = time.perf_counter


def timed_turns(runs, repeats):
    """Seconds of each prepared run in each turn, the runs taking turns; prepare() is not timed."""
    times = [[] for _ in runs]
    for _ in range(repeats):
        for run, spent in zip(runs, times):
            run.prepare()
            start = CLOCK()
            run()
            spent.append(CLOCK() - start)
    return times


def timed_pair(runs, repeats):
    """Median s of each prepared run, taking turns."""
    return [statistics.median(spent) for spent in timed_turns(runs, repeats)]


def turn_ratio(runs, repeats):
    """
    Median s of two prepared runs taking turns, and the median of the turns' ratios second/first.

    A turn's two runs are next to each other in time, so its ratio sees one
    state of a machine whose speed drifts; the median of those ratios moves
    far less between suite runs than the ratio of the two medians.
    """
    first, second = (np.array(t) for t in timed_turns(runs, repeats))
    return statistics.median(first), statistics.median(second), statistics.median(second / first)


def cfem_end(model, duration, dt):
    """Free bodies' CGs after `duration` at step dt."""
    sim = Simulator(dataclasses.replace(model, dt=dt))
    assert sim.advance_to(duration), sim.message
    return sim.position[sim.free]


def mujoco_end(model, data0, duration):
    data = mujoco.MjData(model)
    data.qpos[:] = data0.qpos
    data.qvel[:] = data0.qvel
    for _ in range(int(round(duration / model.opt.timestep))):
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    return models.cg_positions(model, data)


def compare(label, cfem_model, mj_model, mj_data, steps, repeats, accuracy_time, rows):
    """Time both, measure both errors against cfem_ros at dt / 16; print one row."""
    runs = [cfem_run(cfem_model, steps)]
    if mj_model is not None:
        runs.append(mujoco_run(mj_model, mj_data, steps))
    for run in runs:   # warm up: compilation, caches
        run.prepare()
        run()
    if mj_model is not None:
        ours, theirs, speed_up = turn_ratio(runs, repeats)
        ours, theirs = ours / steps * 1e6, theirs / steps * 1e6
    else:
        ours, theirs, speed_up = timed_pair(runs, repeats)[0] / steps * 1e6, math.nan, math.nan
    reference = cfem_end(cfem_model, accuracy_time, cfem_model.dt / 16)
    err_ours = np.abs(cfem_end(cfem_model, accuracy_time, cfem_model.dt) - reference).max()
    err_theirs = (np.abs(mujoco_end(mj_model, mj_data, accuracy_time) - reference).max()
                  if mj_model is not None else math.nan)
    row = (label, ours, theirs, speed_up, err_ours, err_theirs, accuracy_time)
    rows.append(row)
    print(f'{label:<22} {ours:10.1f} {theirs:10.1f} {speed_up:8.2f}x'
          f' {err_ours:10.2e} {err_theirs:10.2e} {accuracy_time:6.2f}', flush=True)
    return row


def chain_model(n, spatial):
    """Return the MuJoCo model and data of a hinge chain, and the same chain in cfem_ros."""
    spec, tilt = models.chain(n, spatial, DT)
    mj_model, mj_data = models.compile_tilted(spec, tilt)
    return mj_model, mj_data, parse_scenario(models.scenario(mj_model, mj_data, f'chain{n}', 1.0))


def chain_steps(n):
    return max(20, min(2000, 20000 // n))


def growth(small, large, repeats):
    """Cost per step of chains of `large` links over `small` links, the two timed in turns."""
    for spatial in (False, True):
        sizes = (small, large)
        runs = [cfem_run(chain_model(n, spatial)[2], chain_steps(n)) for n in sizes]
        for run in runs:
            run.prepare()
            run()
        small_s, large_s, ratio = turn_ratio(runs, repeats)
        ratio *= chain_steps(small) / chain_steps(large)   # per step
        print(f'{"spatial" if spatial else "planar"} chains: cost N = {small} -> {large} grows '
              f'{ratio:.1f}x (median of {repeats} turns; {small_s / chain_steps(small) * 1e6:.1f}'
              f' -> {large_s / chain_steps(large) * 1e6:.1f} us)',
              flush=True)


def chains(sizes, repeats, rows):
    results = {}
    for spatial in (False, True):
        kind = 'spatial' if spatial else 'planar'
        for n in sizes:
            mj_model, mj_data, cfem_model = chain_model(n, spatial)
            steps = chain_steps(n)
            accuracy_time = 0.2 if n <= 100 else 0.05
            results[(kind, n)] = compare(f'{kind} chain N={n}', cfem_model, mj_model, mj_data,
                                         steps, repeats, accuracy_time, rows)
    return results


def paper_cases(repeats, rows):
    dp = load_scenario(str(CONFIG / 'double_pendulum.yaml'))
    mj_model, mj_data = models.double_pendulum(DT)
    compare('double pendulum', dp, mj_model, mj_data, 5000, repeats, 1.0, rows)
    # store separation: MuJoCo has no releasable hinge, so the store changes
    # model (hinge, then free joint) at the first step past 10 deg
    store = load_scenario(str(CONFIG / 'store_separation.yaml'))
    ended = []

    def theirs_run():
        ended.append(store_in_mujoco(1.5))
    theirs_run.prepare = lambda: None
    runs = [cfem_run(store, 1500), theirs_run]
    for run in runs:   # warm up, as compare does
        run.prepare()
        run()
    ours, theirs, speed_up = turn_ratio(runs, repeats)
    ours, theirs = ours / 1500 * 1e6, theirs / 1500 * 1e6
    end = ended[-1]
    reference = cfem_end(store, 1.5, DT / 16)
    err_ours = np.abs(cfem_end(store, 1.5, DT) - reference).max()
    err_theirs = np.abs(end - reference).max()
    rows.append(('store separation', ours, theirs, speed_up, err_ours, err_theirs, 1.5))
    print(f'{"store separation":<22} {ours:10.1f} {theirs:10.1f} {speed_up:8.2f}x'
          f' {err_ours:10.2e} {err_theirs:10.2e} {1.5:6.2f}', flush=True)
    spin = load_scenario(str(CONFIG / 'fixed_joint_spin.yaml'))
    ours = timed_pair([cfem_run(spin, 5000)], repeats)[0] / 5000 * 1e6
    reference = cfem_end(spin, 1.0, DT / 16)
    err_ours = np.abs(cfem_end(spin, 1.0, DT) - reference).max()
    rows.append(('fixed joint spin', ours, math.nan, math.nan, err_ours, math.nan, 1.0))
    print(f'{"fixed joint spin":<22} {ours:10.1f} {"-":>10} {"-":>9} {err_ours:10.2e}'
          f' {"-":>10} {1.0:6.2f}', flush=True)


def store_in_mujoco(duration):
    hinge = models.store(DT)
    data = mujoco.MjData(hinge)
    steps = int(round(duration / DT))
    k = 0
    while k < steps and abs(data.qpos[0]) < math.radians(10.0):
        mujoco.mj_step(hinge, data)
        k += 1
    mujoco.mj_forward(hinge, data)
    omega = data.qvel[0] * data.xaxis[0]
    rot = data.xmat[1].reshape(3, 3)
    free = models.store(DT, free=True)
    data2 = mujoco.MjData(free)
    data2.qpos[:3] = data.xipos[1]
    data2.qpos[3:7] = data.xquat[1]
    data2.qvel[:3] = np.cross(omega, data.xipos[1] - data.xanchor[0])
    data2.qvel[3:6] = rot.T @ omega
    for _ in range(steps - k):
        mujoco.mj_step(free, data2)
    mujoco.mj_forward(free, data2)
    return models.cg_positions(free, data2)


def recording_cost(repeats):
    """Double pendulum, 5 s at dt = 1 ms: wall time with a 100 Hz recording and without."""
    model = load_scenario(str(CONFIG / 'double_pendulum.yaml'), duration=5.0)
    with tempfile.TemporaryDirectory() as folder:
        def plain():
            assert offline.run(Simulator(model), None, rate_hz=100.0, duration=5.0)

        def recorded():
            sim = Simulator(model)
            with Recorder(os.path.join(folder, 'dp.mcap'), overwrite=True) as recorder:
                assert offline.run(sim, StateRecorder(recorder, sim), rate_hz=100.0,
                                   duration=5.0)
        plain.prepare = recorded.prepare = lambda: None
        plain()
        recorded()
        turns = max(repeats, 25)
        a, b, ratio = turn_ratio([plain, recorded], turns)
    print(f'double pendulum, 5 s: {a / 5000 * 1e6:.2f} us/step unrecorded, '
          f'{b / 5000 * 1e6:.2f} us/step with a 100 Hz recording: {100 * (ratio - 1):+.0f} % '
          f'(median of {turns} turns)')
    return a, b


def batch_rate(count, workers):
    """Store separation copies: one batch call against a loop of single runs."""
    model = load_scenario(str(CONFIG / 'store_separation.yaml'))
    pushes = np.linspace(0.0, 2e4, count)
    copies = [{'loads': {'store': ([0.0, 0.0, f], [0.0, 0.0, 0.0])}} for f in pushes]
    start = time.perf_counter()
    results = batch.run(model, copies, workers=workers)
    batched = time.perf_counter() - start
    start = time.perf_counter()
    for f in pushes:
        sim = Simulator(model)
        sim.set_wrench('store', [0.0, 0.0, f], [0.0, 0.0, 0.0])
        sim.advance_to(model.duration)
    sequential = time.perf_counter() - start
    steps = sum(r.steps for r in results)
    print(f'{count} store separations ({steps / count:.0f} steps each): batch of {workers} '
          f'threads {steps / batched:,.0f} run-steps/s, sequential {steps / sequential:,.0f} '
          f'run-steps/s ({sequential / batched:.2f}x)')
    return steps / batched, steps / sequential


def scale_figure(results, sizes, path):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for kind, marker in (('planar', 'o'), ('spatial', 's')):
        ours = [results[(kind, n)][1] for n in sizes]
        theirs = [results[(kind, n)][2] for n in sizes]
        ax.loglog(sizes, ours, marker + '-', color='C0', label=f'cfem_ros, {kind}')
        ax.loglog(sizes, theirs, marker + '--', color='C3', label=f'MuJoCo, {kind}')
    ax.loglog(sizes, [results[('planar', sizes[0])][1] * n / sizes[0] for n in sizes], ':',
              color='grey', label='linear in N')
    ax.set_xlabel('links N (hinge chain)')
    ax.set_ylabel('microseconds per RK4 step (dt = 1 ms)')
    ax.set_title('Cost of a step against chain length')
    ax.grid(True, which='both', alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    fig.savefig(path, dpi=110)
    print(f'wrote {path}')


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--quick', action='store_true', help='fewer sizes and repeats')
    parser.add_argument('--repeats', type=int, default=5)
    parser.add_argument('--cpu-time', action='store_true',
                        help="time the runs in this process's CPU time, not on the wall clock")
    parser.add_argument('--figure', default=str(ROOT / 'runs' / 'bench' / 'scale.png'),
                        help='where to write the scale figure (docs/scale.png to refresh '
                             "the README's)")
    args = parser.parse_args()
    if args.cpu_time:
        global CLOCK
        CLOCK = time.process_time
    logging.getLogger('cfem_ros').setLevel(logging.ERROR)
    repeats = 2 if args.quick else args.repeats
    sizes = (2, 10, 100) if args.quick else (2, 10, 100, 300, 1000)
    print(f'mujoco {mujoco.__version__}, numpy {np.__version__}, dt = {DT * 1e3:g} ms, RK4, '
          f"medians of {repeats} turns, speed-up: median of the turns' ratios; "
          f'error: largest CG difference from cfem_ros at dt/16 (m)')
    print(f'{"model":<22} {"cfem us":>10} {"MuJoCo us":>10} {"speed-up":>9} {"cfem err":>10}'
          f' {"MuJoCo err":>10} {"err t":>6}')
    rows = []
    paper_cases(repeats, rows)
    results = chains(sizes, repeats, rows)
    spec, tilt = models.tree(4, 25, DT)
    mj_model, mj_data = models.compile_tilted(spec, tilt)
    compare('tree 4 x 25 + hub', parse_scenario(models.scenario(mj_model, mj_data, 'tree', 1.0)),
            mj_model, mj_data, 200, repeats, 0.2, rows)
    if sizes[-1] > 100:
        growth(100, sizes[-1], max(repeats, 25))
    recording_cost(repeats)
    batch_rate(100 if args.quick else 1000, os.cpu_count() or 1)
    if not args.quick:
        scale_figure(results, sizes, args.figure)


if __name__ == '__main__':
    main()
