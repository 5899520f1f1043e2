# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The envelope figures and the report of a 1,000-run study, timed (issue 49.4 d).

The study: config/sweeps/store_release_near_pylon_envelope.yaml at --runs
(default 1000), every run recorded (``--record all``, 2 workers; not timed
here, only made). Then, each as a whole process, in turns over --repeats:
``cfem-sim plot DIR --relative-to pylon`` (the sweep's scatter figures and
the separation envelope over its recordings: trajectory sheet and outline
snapshots in the pylon's axes) and ``cfem-sim report DIR`` (the HTML page
with its figures). Wall time with the load average, and CPU time of the
process (``RUSAGE_CHILDREN``); medians. The target of issue 49.4 d: under
10 s each.

Both read each recording's body poses and events alone, through its message
index (``recording.poses``, the same numbers as the whole read, to the bit),
once per process for the two envelopes, and draw the runs of a panel as one
LineCollection; the figures are pixel-identical to those of the whole reads.

Measured 2026-12-02 (helper B) on the same study of 1,000 runs (826
recorded, 394 MB of MCAP; the others drew an Iyy the scenario refuses),
made once and given with ``--study``; CPU of the command's process:

- reading whole (864468d) against poses by index, one turn each in turns,
  load average 1.7 to 3.1: ``plot --relative-to pylon`` 58.9 s wall, 58.9 s
  CPU -> 7.0 s wall, 6.2 s CPU; ``report`` 61.2 s wall, 55.6 s CPU -> 7.7 s
  wall, 6.4 s CPU.
- this benchmark, medians of 3, load average 2.8 to 4.1: plot 6.35 s wall
  (6.54 s CPU), report 6.70 s wall (6.89 s CPU): under 10 s each.

Each command runs serially in one process. What is left is mostly
matplotlib's (24 figures drawn and written), the imports (about 1.5 s) and
the reading (about 2 ms of CPU a recording, 1.7 s).

Usage: .venv/bin/python benchmarks/bench_study_figures.py [--runs 1000] [--repeats 3]
[--keep DIR | --study DIR]
"""

import argparse
import os
import pathlib
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
CLI = str(ROOT / '.venv' / 'bin' / 'cfem-sim')
SWEEP = ROOT / 'config' / 'sweeps' / 'store_release_near_pylon_envelope.yaml'


def timed(command) -> tuple:
    """Run a command; return (wall s, CPU s of it, load average before)."""
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        sys.exit(f'{" ".join(command)} exited {done.returncode}: {done.stderr[-2000:]}')
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), load


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--runs', type=int, default=1000)
    parser.add_argument('--repeats', type=int, default=3)
    parser.add_argument('--study', metavar='DIR',
                        help='time the figures of this recorded study folder instead of making '
                        'one (e.g. one made by an earlier turn with --keep)')
    parser.add_argument('--keep', metavar='DIR',
                        help='make the study in this folder and keep it')
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix='cfem-bench-figures-') as folder:
        study = args.study or args.keep or os.path.join(folder, 'study')
        if not args.study:
            made = timed([CLI, 'sweep', str(SWEEP), '-o', study, '--runs', str(args.runs),
                          '--record', 'all', '--workers', '2'])
            print(f'the study: {args.runs} runs recorded, {made[0]:.1f} s wall, '
                  f'{made[1]:.1f} s CPU (load average {made[2]:.1f})')
        found = {'plot --relative-to pylon': [], 'report': []}
        for turn in range(args.repeats):
            names = list(found) if turn % 2 == 0 else list(found)[::-1]
            for name in names:
                out = os.path.join(folder, f'{name.split()[0]}_{turn}')
                command = ([CLI, 'plot', study, '-o', out, '--relative-to', 'pylon']
                           if name.startswith('plot') else
                           [CLI, 'report', study, '-o', out + '.html'])
                found[name].append(timed(command))
                shutil.rmtree(out, ignore_errors=True)
        for name, times in found.items():
            print(f'cfem-sim {name:<26} {statistics.median(t[0] for t in times):6.2f} s wall '
                  f'{statistics.median(t[1] for t in times):6.2f} s CPU (medians of '
                  f'{len(times)}; load average {min(t[2] for t in times):.1f} to '
                  f'{max(t[2] for t in times):.1f})')
    print('target of issue 49.4 d: under 10 s each')


if __name__ == '__main__':
    main()
