# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A benchmark run with two builds of cfem_ros side by side, in alternating turns.

Runs a benchmark script (``suite.py``, ``bench_sweep.py`` ...) with this build and
with a reference build (another checkout and its venv, e.g. a previous release's),
one after the other, for several turns, then prints every figure the script
printed for both, as medians over the turns, with their ratio (reference over
this build: above 1 when this build is faster, for times). A figure is a
number in a table row (its label, then columns) or a number followed by a unit
in a sentence (``us/step``, ``run-steps/s``, ``s``).

Usage:
  .venv/bin/python benchmarks/compare_builds.py --reference ../previous/.venv/bin/python \
      --reference-tree ../previous --turns 3 suite.py --quick
"""

import argparse
import os
import pathlib
import re
import statistics
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
NUMBER = r'[-+]?\d[\d,]*\.?\d*(?:e[-+]?\d+)?'
#: Units whose figures are rates (higher is better); the others are times or sizes.
RATES = ('run-steps/s', 'speed-up', 'RTF', 'runs/s')


def run(python, tree, script, arguments, env):
    """Run the script of tree's benchmarks with python; return its standard output."""
    done = subprocess.run([python, str(pathlib.Path(tree) / 'benchmarks' / script)] + arguments,
                          cwd=tree, env=env, capture_output=True, text=True, timeout=7200)
    if done.returncode != 0:
        sys.exit(f'ERROR: {script} failed with {python}: {done.stderr.strip()[-2000:]}')
    return done.stdout


def figures(text):
    """Return {(line label, column or unit): value} of the numbers in a benchmark's output."""
    found = {}
    header = ''
    for line in text.splitlines():
        cells = [(m.group(), m.end()) for m in re.finditer(r'\S+(?: \S+)*', line)]
        numeric = [re.fullmatch(f'({NUMBER})x?', c) for c, _ in cells[1:]]
        if len(cells) > 2 and not any(numeric):
            header = line   # a table's header: its columns end where their numbers end
            continue
        if len(cells) > 2 and all(m or c == '-' for m, (c, _) in zip(numeric, cells[1:])):
            start = cells[0][1]
            for match, (_, end) in zip(numeric, cells[1:]):
                name = header[start:end].strip() or f'column ending at {end}'
                start = end
                if match:
                    found[(cells[0][0], name)] = float(match.group(1).replace(',', ''))
            continue
        for k, match in enumerate(re.finditer(f'({NUMBER}) ?(us/step|run-steps/s|ms|s)\\b',
                                              line)):
            label = line.split(':')[0][:48]
            found[(label, f'{match.group(2)} #{k + 1}')] = float(
                match.group(1).replace(',', ''))
    return found


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--reference', required=True, help="the reference build's Python")
    parser.add_argument('--reference-tree', required=True, help="the reference's checkout")
    parser.add_argument('--reference-path', default='',
                        help='PYTHONPATH entries for the reference only (e.g. MuJoCo)')
    parser.add_argument('--turns', type=int, default=3)
    parser.add_argument('script', help='a script of benchmarks/, e.g. suite.py')
    parser.add_argument('arguments', nargs=argparse.REMAINDER)
    args = parser.parse_args()
    env = dict(os.environ)
    env.pop('PYTHONPATH', None)
    reference_env = dict(env, PYTHONPATH=os.pathsep.join(
        p for p in (args.reference_tree, args.reference_path) if p))
    sides = {'this': [], 'reference': []}
    for turn in range(args.turns):
        order = (('this', sys.executable, ROOT, env),
                 ('reference', args.reference, args.reference_tree, reference_env))
        for name, python, tree, side_env in (order if turn % 2 == 0 else order[::-1]):
            print(f'turn {turn + 1}/{args.turns}: {name}', file=sys.stderr, flush=True)
            sides[name].append(figures(run(python, tree, args.script, args.arguments,
                                           side_env)))
    keys = [k for k in sides['this'][0] if all(k in s for s in sides['this'] + sides['reference'])]
    print(f'{args.script} {" ".join(args.arguments)}: medians of {args.turns} alternating turns')
    print(f'{"figure":<58} {"reference":>12} {"this build":>12} {"ratio":>7}')
    for key in keys:
        ref = statistics.median(s[key] for s in sides['reference'])
        this = statistics.median(s[key] for s in sides['this'])
        ratio = ref / this if this else float('nan')
        if any(unit in key[1] for unit in RATES):
            ratio = this / ref if ref else float('nan')
        print(f'{(key[0] + " | " + key[1])[:58]:<58} {ref:12.4g} {this:12.4g} {ratio:6.2f}x')
    return 0


if __name__ == '__main__':
    sys.exit(main())
