# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
``cfem-sim fit`` timed: the two-hook release, 3 parameters, one flight and two flights.

The "flights" are runs of config/store_release_two_hooks.yaml (the station
released at 0.05 s, 0.45 s simulated) at known values (ejectors 11,500 N
and 40,000 N, a Cm increment of +0.02), the store's pose relative to the
pylon taken at 200 Hz with seeded noise of 5 mm and 0.2 deg; the second
flight is the same store released at 3,000 m instead of 7,925 m (its own
``set:``). Each fit starts from the prediction (10,676 N, 42,703 N, 0) and
fits the two ejector forces and the Cm increment over 0.4 s from the
release. Printed per fit: the whole command's wall time and CPU time
(medians of --repeats, a fresh process each; the CPU time, user and
system, does not grow with the machine's load as the wall time does), the
runs it made, and the values with
their scaled standard errors against the truth.

Measured on 2026-12-02 at a load average of 13 to 15 on the 2 cores (other
work running: the wall times are several times an idle machine's), the
fit of 864468d and of bba888c run alternately in one script, 3 turns
each, medians: one flight 3.17 -> 2.83 s CPU (10.6 -> 7.2 s wall),
two flights 4.18 -> 3.81 s CPU (12.2 -> 12.4 s wall: load noise); this
script on the new code alone: 2.90 and 3.93 s CPU (22.0 and 18.5 s wall,
load 15 to 18). The CPU falls less than the wall an idle machine would
show: the figures (4 for two flights, ~0.25 s CPU each) are drawn in 2
forked processes beside the recording of fitted.mcap, each importing
matplotlib (~0.35 s CPU) for itself. Timed by phase in one process, the
critical path on 2 idle cores (serial CPU, plus the parallel CPU over 1.7)
falls from 2.62 to 1.57 s (one flight) and from 3.55 to 2.20 s (two), ratios
0.60 and 0.62: from the 3.6 s and 5.04 s measured idle on 864468d, about
2.2 s and 3.1 s idle (an estimate, not measured: the machine was never idle).
What is left on that path, two flights: the imports 0.5 s, the solve 0.5 s
(86 runs of ~11 ms CPU, 2 threads), the outputs 1.1 s (the figures).

Usage: .venv/bin/python benchmarks/bench_fit.py [--repeats N] [--threads N]
"""

import argparse
import json
import os
import pathlib
import resource
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[1]
CFEM_SIM = pathlib.Path(sys.executable).parent / 'cfem-sim'
TRUTH = {'wrenches[0].force[2]': 11500.0, 'wrenches[1].force[2]': 40000.0,
         'aero.store.delta.Cm': 0.02}
PARAMETERS = {
    'wrenches[0].force[2]': {'start': 10676, 'bounds': [5000, 20000],
                             'name': 'forward ejector', 'unit': 'N'},
    'wrenches[1].force[2]': {'start': 42703, 'bounds': [30000, 55000],
                             'name': 'aft ejector', 'unit': 'N'},
    'aero.store.delta.Cm': {'start': 0.0, 'bounds': [-0.2, 0.2], 'name': 'delta Cm'}}
SIGMA = {'position': 0.005, 'attitude_deg': 0.2}
LOW = {'aero.store.altitude': 3000.0}


def scenario() -> dict:
    """Return the two-hook release, released at 0.05 s, 0.45 s long, a Cm increment key."""
    document = yaml.safe_load((ROOT / 'config' / 'store_release_two_hooks.yaml').read_text())
    document['duration'] = 0.45
    document['release_groups']['station_1']['release'] = {'time': 0.05}
    document['aero']['store']['delta'] = {'Cm': 0.0}
    return document


def _set(document: dict, values: dict) -> dict:
    out = yaml.safe_load(yaml.safe_dump(document))
    for key, value in values.items():
        node = out
        path = key.replace(']', '').replace('[', '.').split('.')
        for name in path[:-1]:
            node = node[int(name)] if name.isdigit() else node[name]
        last = path[-1]
        node[int(last) if last.isdigit() else last] = value
    return out


def flight(folder: pathlib.Path, name: str, settings: dict, seed: int) -> str:
    """Run a flight at the truth and write its noisy measured poses as a CSV; return it."""
    path = folder / f'{name}.yaml'
    path.write_text(yaml.safe_dump(_set(scenario(), {**TRUTH, **settings})))
    recording = folder / f'{name}.mcap'
    subprocess.run([str(CFEM_SIM), 'run', str(path), '-o', str(recording), '--rate', '200',
                    '--overwrite'], check=True, capture_output=True)
    from cfem_ros.recording.analysis import open_run
    run = open_run(str(recording))
    store, pylon = run.bodies['store'], run.bodies['pylon']
    turn = Rotation.from_quat(pylon.quaternion).inv()
    rng = np.random.default_rng(seed)
    position = turn.apply(store.position - pylon.position)
    position = position + rng.normal(0.0, SIGMA['position'], position.shape)
    noise = Rotation.from_rotvec(np.radians(rng.normal(0.0, SIGMA['attitude_deg'],
                                                       position.shape)))
    euler = (noise * turn * Rotation.from_quat(store.quaternion)).as_euler('ZYX', degrees=True)
    columns = {'time': store.time}
    columns.update({f'store_{q}': position[:, i] for i, q in enumerate('xyz')})
    columns.update({f'store_{q}_deg': euler[:, ::-1][:, i]
                    for i, q in enumerate(('roll', 'pitch', 'yaw'))})
    csv = folder / f'{name}.csv'
    pd.DataFrame(columns).to_csv(csv, index=False)
    return str(csv)


def entry(csv: str, settings=None) -> dict:
    """Return one flight's measured: mapping."""
    out = {'file': csv, 'body': 'store', 'relative_to': 'pylon', 'sigma': SIGMA,
           'window': {'from': {'release': 'station_1'},
                      'to': {'release': 'station_1', 'delay': 0.4}}}
    if settings:
        out['set'] = settings
    return out


def timed_fit(folder: pathlib.Path, name: str, measured, threads: int, repeats: int):
    """Return (median wall time s, fit.json) of cfem-sim fit, a fresh process per repeat."""
    (folder / 'predicted.yaml').write_text(yaml.safe_dump(scenario()))
    fit = folder / f'{name}.yaml'
    fit.write_text(yaml.safe_dump({'scenario': 'predicted.yaml', 'measured': measured,
                                   'parameters': PARAMETERS}, sort_keys=False))
    times, cpu = [], []
    for _ in range(repeats):
        used = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        subprocess.run([str(CFEM_SIM), 'fit', str(fit), '-o', str(folder / name),
                        '--threads', str(threads), '--overwrite'], check=True,
                       capture_output=True)
        times.append(time.perf_counter() - start)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(after.ru_utime + after.ru_stime - used.ru_utime - used.ru_stime)
    return (statistics.median(times), statistics.median(cpu),
            json.loads((folder / name / 'fit.json').read_text()))


def report(label: str, wall: float, cpu: float, found: dict):
    """Print one fit's line: time, runs, and each value against the truth."""
    print(f'{label}: {wall:.2f} s wall, {cpu:.2f} s CPU, {found["runs"]} runs '
          f'({1000 * wall / found["runs"]:.0f} ms per run, outputs included), '
          f'reduced chi-square {found["reduced_chi2"]:.3g}, status {found["status"]}')
    for key, truth in TRUTH.items():
        p = found['parameters'][key]
        error = p['standard_error_scaled']
        off = (p['value'] - truth) / error if error else float('nan')
        print(f'  {p["name"]:>16}: {p["value"]:.6g} ± {error:.3g} (truth {truth:g}, '
              f'{off:+.2f} standard errors)')


def main():
    """Print the one-flight and the two-flight fit's time and result."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--repeats', type=int, default=3)
    parser.add_argument('--threads', type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as name:
        folder = pathlib.Path(name)
        high = flight(folder, 'flight_1', {}, 1)
        low = flight(folder, 'flight_2', LOW, 2)
        load = os.getloadavg()[0]
        print(f'cfem-sim fit of the two-hook release, 3 parameters, --threads {args.threads}, '
              f'median of {args.repeats} (load average {load:.1f} on {os.cpu_count()} cores)')
        report('one flight ', *timed_fit(folder, 'one', entry(high), args.threads,
                                         args.repeats))
        report('two flights', *timed_fit(folder, 'two', [entry(high), entry(low, LOW)],
                                         args.threads, args.repeats))


if __name__ == '__main__':
    main()
