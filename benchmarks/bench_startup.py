# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Whole-process start-up: ``cfem-sim run`` against a MuJoCo script, and where the time goes.

Runs ``cfem-sim run config/store_separation.yaml -o <tmp>.mcap --overwrite``
(the console script next to this Python) and ``benchmarks/mujoco_store.py``
(the same store on its hinge from an inline MJCF string, 1,501 steps) as
whole processes, in turns, and prints their medians and ratio. Then the
phases of a ``cfem-sim run`` in a fresh process (imports, scenario load,
Simulator construction, the run, the recording), the slowest imports
(``python -X importtime``) and the load time of a generated 300-body
scenario. Usage: .venv/bin/python benchmarks/bench_startup.py [--repeats N]
"""

import argparse
import contextlib
import io
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCENARIO = ROOT / 'config' / 'store_separation.yaml'
CFEM_SIM = pathlib.Path(sys.executable).parent / 'cfem-sim'

PHASES = r"""
import sys, time
t0 = time.perf_counter()
from cfem_ros.cli import main
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.scenario.parse import load_scenario
from cfem_ros.recording import offline
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.recorder import run_metadata, StateRecorder
t1 = time.perf_counter()
model = load_scenario(sys.argv[1])
t2 = time.perf_counter()
sim = Simulator(model)
t3 = time.perf_counter()
assert offline.run(sim, None, rate_hz=100.0, duration=model.duration)
t4 = time.perf_counter()
sim = Simulator(model)
t5 = time.perf_counter()
metadata = run_metadata(model, sys.argv[1], 100.0, 0)
with Recorder(sys.argv[2], overwrite=True, metadata=metadata) as rec:
    assert offline.run(sim, StateRecorder(rec, sim), rate_hz=100.0, duration=model.duration)
t6 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2, t4 - t3, t6 - t5, 'numba' in sys.modules, 'scipy' in sys.modules)
"""

LOAD = r"""
import sys, time
from cfem_ros.core.scenario import parse as scenario
t0 = time.perf_counter()
model = scenario.load_scenario(sys.argv[1])
print(time.perf_counter() - t0, len(model.bodies))
"""


def whole(command):
    """Return the wall time of one whole process (s); fail loudly if it fails."""
    started = time.perf_counter()
    done = subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - started
    if done.returncode:
        sys.exit(f'{" ".join(map(str, command))} failed ({done.returncode}): {done.stderr}')
    return wall


def byte_compile():
    """
    Byte-compile the installed cfem_ros as pip does for a regular install; say so.

    Python writes a module's bytecode on its first import unless
    PYTHONDONTWRITEBYTECODE is set; an editable install has none until
    then, and without it every start compiles the package's sources again.
    The MuJoCo side's bytecode was written by pip.
    """
    import cfem_ros
    import compileall
    package = os.path.dirname(cfem_ros.__file__)
    with contextlib.redirect_stdout(io.StringIO()):
        fresh = compileall.compile_dir(package, quiet=1)
    return f'bytecode of {package}: ' + ('current' if fresh else 'FAILED to compile')


def chain_yaml(count, path):
    """Write a scenario of count bodies in a hinged chain hanging from the ground."""
    lines = ['name: chain', 'duration: 0.01', 'dt: 0.001', 'bodies:', '  ground:',
             '    fixed: true']
    for i in range(count):
        lines += [f'  b{i}:', '    mass: 1.0', '    inertia: [0.0833, 0.0833, 0.002]',
                  f'    position: [0, 0, {-0.5 - i:.1f}]', '    orientation_rpy_deg: [0, 0, 0]']
    lines.append('joints:')
    for i in range(count):
        parent = 'ground' if i == 0 else f'b{i - 1}'
        lines += [f'  j{i}:', '    type: hinge', f'    parent: {parent}', f'    child: b{i}',
                  f'    anchor: [0, 0, {-float(i):.1f}]', '    axis: [0, 1, 0]']
    path.write_text('\n'.join(lines) + '\n')


def import_times(limit):
    """Print the slowest imports of ``import cfem_ros.cli`` (cumulative, top level only)."""
    done = subprocess.run([sys.executable, '-X', 'importtime', '-c', 'import cfem_ros.cli'],
                          stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                          check=True)
    rows = []
    for line in done.stderr.splitlines():
        if not line.startswith('import time:') or 'cumulative' in line:
            continue
        _, total, name = line.split('|')
        depth = (len(name) - len(name.lstrip())) // 2
        if depth <= 2:
            rows.append((int(total) / 1e3, depth, name.strip()))
    rows.sort(reverse=True)
    print('slowest imports of `import cfem_ros.cli` (cumulative ms, nesting <= 2):')
    for ms, depth, name in rows[:limit]:
        print(f'  {ms:8.1f}  {"  " * depth}{name}')


def main():
    """Time both processes in turns and print the breakdown."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--repeats', type=int, default=15, help='processes of each kind')
    parser.add_argument('--bodies', type=int, default=300, help='bodies of the load test')
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        out = os.path.join(folder, 'run.mcap')
        ours = [str(CFEM_SIM), 'run', str(SCENARIO), '-o', out, '--overwrite']
        theirs = [sys.executable, str(ROOT / 'benchmarks' / 'mujoco_store.py')]
        print(byte_compile())
        whole(ours)
        whole(theirs)
        times = {'cfem-sim run': [], 'mujoco script': []}
        load = [os.getloadavg()[0]]
        for _ in range(args.repeats):
            times['cfem-sim run'].append(whole(ours))
            times['mujoco script'].append(whole(theirs))
        load.append(os.getloadavg()[0])
        medians = {k: statistics.median(v) for k, v in times.items()}
        print(f'whole process, median of {args.repeats} in turns (load average '
              f'{min(load):.1f} to {max(load):.1f} on {os.cpu_count()} cores):')
        for name, value in medians.items():
            print(f'  {name:<14} {value * 1e3:8.0f} ms  (min {min(times[name]) * 1e3:.0f})')
        turns = [a / b for a, b in zip(times['cfem-sim run'], times['mujoco script'])]
        print(f'  ratio cfem-sim / mujoco: {statistics.median(turns):.2f} (median of the '
              f"turns' ratios; of the medians "
              f"{medians['cfem-sim run'] / medians['mujoco script']:.2f})")

        phases = []
        for _ in range(5):
            done = subprocess.run([sys.executable, '-c', PHASES, str(SCENARIO), out],
                                  capture_output=True, text=True, check=True)
            phases.append(done.stdout.split())
        names = ('imports', 'scenario load', 'Simulator()', 'run (no recording)',
                 'run with recording')
        print('phases of a run in a fresh process (median of 5, ms):')
        for k, name in enumerate(names):
            print(f'  {name:<20} {statistics.median(float(p[k]) for p in phases) * 1e3:8.1f}')
        print(f'  numba imported: {phases[0][5]}, scipy imported: {phases[0][6]}')
        import_times(12)

        path = pathlib.Path(folder) / 'chain.yaml'
        chain_yaml(args.bodies, path)
        loads = []
        for _ in range(5):
            done = subprocess.run([sys.executable, '-c', LOAD, str(path)],
                                  capture_output=True, text=True, check=True)
            loads.append(float(done.stdout.split()[0]))
        print(f'{args.bodies}-body scenario ({path.stat().st_size / 1e3:.0f} kB): '
              f'load_scenario {statistics.median(loads) * 1e3:.1f} ms (median of 5)')


if __name__ == '__main__':
    main()
