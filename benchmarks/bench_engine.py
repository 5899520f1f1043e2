# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Microseconds per RK4 step and real-time factor of the paper's scenarios.

Runs each scenario at dt = 1 ms, without and with recording at 100 Hz,
several times, and prints medians. Usage: .venv/bin/python benchmarks/bench_engine.py
"""

import argparse
import os
import pathlib
import statistics
import tempfile
import time

from cfem_ros import load_scenario, Simulator
from cfem_ros.recording import offline
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.recorder import StateRecorder

CONFIG = pathlib.Path(__file__).resolve().parents[1] / 'config'
SCENARIOS = ('fixed_joint_spin', 'double_pendulum', 'store_separation')


def measure(name, duration, record, folder):
    model = load_scenario(str(CONFIG / f'{name}.yaml'), duration=duration, dt=0.001)
    sim = Simulator(model)
    start = time.perf_counter()
    if record:
        with Recorder(os.path.join(folder, f'{name}.mcap'), overwrite=True) as recorder:
            assert offline.run(sim, StateRecorder(recorder, sim), rate_hz=100.0,
                               duration=duration)
    else:
        assert offline.run(sim, None, rate_hz=100.0, duration=duration)
    wall = time.perf_counter() - start
    return wall / sim.steps * 1e6, duration / wall


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--duration', type=float, default=5.0, help='simulated s per run')
    parser.add_argument('--repeats', type=int, default=5)
    args = parser.parse_args()
    Simulator(load_scenario(str(CONFIG / 'double_pendulum.yaml')))  # compile (cached)
    print(f'dt = 1 ms, {args.duration:g} s simulated per run, median of {args.repeats}')
    print(f'{"scenario":<20} {"us/step":>9} {"RTF":>8} {"us/step rec":>12} {"RTF rec":>8}'
          f' {"rec cost":>9}')
    with tempfile.TemporaryDirectory() as folder:
        for name in SCENARIOS:
            plain, recorded = [], []
            for _ in range(args.repeats):
                plain.append(measure(name, args.duration, False, folder))
                recorded.append(measure(name, args.duration, True, folder))
            us = statistics.median(p[0] for p in plain)
            rtf = statistics.median(p[1] for p in plain)
            us_rec = statistics.median(r[0] for r in recorded)
            rtf_rec = statistics.median(r[1] for r in recorded)
            print(f'{name:<20} {us:9.1f} {rtf:8.1f} {us_rec:12.1f} {rtf_rec:8.1f}'
                  f' {100 * (us_rec / us - 1):8.0f}%')


if __name__ == '__main__':
    main()
