# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Fingerprints of every shipped scenario, compared between two builds of the core.

A fingerprint is, at 8 times evenly spread over a scenario's run (its own
duration, or --duration if shorter), the state y, every joint's load (force and
moment) and the outputs a sample publishes. ``--dump FILE`` writes this
interpreter's fingerprints as JSON (floats written exactly); ``--reference
PYTHON --reference-tree DIR`` dumps them with this build and with another
(e.g. a previous release's checkout and its venv) and prints, per scenario, the
largest difference relative to the size of the quantity (the largest
magnitude of that state, load or output vector at that time), the place where
it occurs, and whether it is within --tolerance. ``--chains`` adds the long
models of ``suite.py`` (hinge chains of 100 bodies, planar and spatial, and the
tree 4 x 25 + hub; built with MuJoCo, the ``bench`` extra), over 0.2 s: their
step is the articulated recursion, which the shipped scenarios barely exercise.

Besides the shipped scenarios, both builds run variants written here for them
(``VARIANTS``): a scenario whose physics changed on purpose since the
reference build, rewritten to the physics both builds share, so that the builds
are still compared there.

Usage:
  .venv/bin/python benchmarks/fingerprint.py --reference ../previous/.venv/bin/python \
      --reference-tree ../previous
"""

import argparse
import json
import math
import os
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
TIMES = 8
#: How long the --chains models are run, s.
CHAIN_DURATION = 0.2


def scenarios(root: pathlib.Path) -> list:
    """Return the shipped scenario files (config/*.yaml and config/joints/*.yaml)."""
    found = sorted((root / 'config').glob('*.yaml')) + sorted(
        (root / 'config' / 'joints').glob('*.yaml'))
    return [p for p in found if not p.name.endswith('.params.yaml')]


def fixed_density(text: str) -> str:
    """Return the scenario with its aero density held at the reference altitude's ISA value."""
    from cfem_ros.core.native.atmosphere import isa_density

    line = next(x for x in text.splitlines() if x.strip().startswith('altitude:'))
    altitude = float(line.split(':')[1].split('#')[0])
    indent = line[:len(line) - len(line.lstrip())]
    return text.replace(line, f'{indent}density: {isa_density(altitude)!r}')


#: Variants: (name, shipped scenario, rewrite of its text).
VARIANTS = [('store_separation_aero@fixed_density', 'store_separation_aero.yaml',
             fixed_density)]


def write_variants(folder: str) -> list:
    """Write the variants' scenario files into folder; return their paths."""
    paths = []
    for name, source, rewrite in VARIANTS:
        path = pathlib.Path(folder) / f'{name}.yaml'
        path.write_text(rewrite((ROOT / 'config' / source).read_text()))
        paths.append(path)
    return paths


def chain_scenarios() -> dict:
    """Return {name: scenario dict} of the --chains models (suite.py's, through MuJoCo)."""
    sys.path.insert(0, str(ROOT / 'benchmarks'))
    import models

    found = {}
    for n, spatial in ((100, False), (100, True)):
        spec, tilt = models.chain(n, spatial)
        name = f'{"spatial" if spatial else "planar"} chain N={n}'
        found[name] = models.scenario(*models.compile_tilted(spec, tilt), name, CHAIN_DURATION)
    spec, tilt = models.tree(4, 25)
    found['tree 4 x 25 + hub'] = models.scenario(*models.compile_tilted(spec, tilt), 'tree',
                                                 CHAIN_DURATION)
    return found


def fingerprint(path, duration: float, ulp: bool = False) -> dict:
    """
    Return {'times', 'state', 'loads', 'outputs'}: lists of 8 vectors each.

    path is a scenario file or a scenario dict. With ulp, the largest CG coordinate of
    a free body in the initial state is moved by one unit in the last place: how far
    one rounding carries in this scenario.
    """
    import numpy as np

    from cfem_ros import load_scenario, parse_scenario, Simulator

    model = parse_scenario(path) if isinstance(path, dict) else load_scenario(str(path))
    end = min(model.duration, duration)
    sim = Simulator(model)
    if ulp:
        coordinates = np.flatnonzero(np.repeat(sim.free, 3))
        if coordinates.size:
            k = coordinates[np.argmax(np.abs(sim.y[coordinates]))]
            sim.y[k] = np.nextafter(sim.y[k], np.inf)
    out = {'times': [], 'state': [], 'loads': [], 'outputs': []}
    for k in range(1, TIMES + 1):
        t = end * k / TIMES
        sim.advance_to(t)
        sim.release_due()
        force, moment = sim.joint_wrenches()
        out['times'].append(sim.t)
        out['state'].append(sim.y.tolist())
        out['loads'].append(np.concatenate([force.ravel(), moment.ravel()]).tolist())
        out['outputs'].append(sim.outputs().tolist())
    return out


def dump(target: str, duration: float, ulp: bool = False, chains: bool = False, also=()):
    """Write this build's fingerprints of the shipped scenarios (chains, also) to target."""
    result = {}
    named = [(path.stem, path) for path in scenarios(ROOT) + [pathlib.Path(p) for p in also]]
    if chains:
        named += list(chain_scenarios().items())
    for name, path in named:
        try:
            result[name] = fingerprint(path, duration, ulp)
        except Exception as err:   # a scenario this build cannot run: reported, not fatal
            result[name] = {'error': f'{type(err).__name__}: {err}'}
    with open(target, 'w', encoding='utf-8') as handle:
        json.dump(result, handle)


def largest_difference(a: dict, b: dict):
    """Return (relative difference, where) over the quantities of two fingerprints."""
    worst, where = 0.0, ''
    for key in ('state', 'loads', 'outputs'):
        for k, (va, vb) in enumerate(zip(a[key], b[key])):
            if len(va) != len(vb):
                return math.inf, f'{key} at sample {k}: lengths {len(va)} and {len(vb)}'
            scale = max([abs(x) for x in va + vb] + [1e-300])
            for i, (x, y) in enumerate(zip(va, vb)):
                if math.isnan(x) and math.isnan(y):
                    continue
                diff = abs(x - y) / scale
                if not diff <= worst:
                    worst, where = diff, f'{key}[{i}] at t = {a["times"][k]:.6g} s'
    return worst, where


def run(python: str, tree: pathlib.Path, duration: float, folder: str, name: str,
        ulp: bool = False, chains: bool = False, also=()) -> dict:
    """Dump the fingerprints with python in tree (its own checkout); return them."""
    target = os.path.join(folder, f'{name}.json')
    env = dict(os.environ, PYTHONPATH=str(tree))
    subprocess.run([python, str(pathlib.Path(__file__).resolve()), '--dump', target,
                    '--duration', str(duration)] + (['--ulp'] if ulp else [])
                   + (['--chains'] if chains else [])
                   + [a for path in also for a in ('--also', str(path))],
                   cwd=tree, env=env, check=True)
    with open(target, encoding='utf-8') as handle:
        return json.load(handle)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--dump', help="write this build's fingerprints to this JSON file")
    parser.add_argument('--reference', help="the other build's Python interpreter")
    parser.add_argument('--reference-tree', help="the other build's checkout")
    parser.add_argument('--duration', type=float, default=math.inf,
                        help='simulate at most this long, s')
    parser.add_argument('--tolerance', type=float, default=1e-12)
    parser.add_argument('--ulp', action='store_true',
                        help='move one initial CG coordinate by one unit in the last place')
    parser.add_argument('--chains', action='store_true',
                        help="add suite.py's chains of 100 bodies and its tree (needs MuJoCo)")
    parser.add_argument('--also', action='append', default=[],
                        help='a further scenario file to dump (with --dump)')
    args = parser.parse_args()
    if args.dump:
        dump(args.dump, args.duration, args.ulp, args.chains, args.also)
        return 0
    if not (args.reference and args.reference_tree):
        parser.error('give --dump, or --reference and --reference-tree')
    with tempfile.TemporaryDirectory() as folder:
        also = write_variants(folder)
        mine = run(sys.executable, ROOT, args.duration, folder, 'this', chains=args.chains,
                   also=also)
        theirs = run(args.reference, pathlib.Path(args.reference_tree).resolve(),
                     args.duration, folder, 'reference', chains=args.chains, also=also)
        # the reference against itself with one initial coordinate moved by one ulp: how
        # far a single rounding difference carries in each scenario
        nudged = run(args.reference, pathlib.Path(args.reference_tree).resolve(),
                     args.duration, folder, 'nudged', ulp=True, chains=args.chains,
                     also=also)
    failed = 0
    print(f'{"scenario":<36} {"this vs reference":>18} {"reference, 1 ulp":>17}  where')
    for name in sorted(set(mine) | set(theirs)):
        a, b = mine.get(name), theirs.get(name)
        if a is None or b is None or 'error' in a or 'error' in b:
            print(f'{name:<36} {"(not in both)":>18}  {a and a.get("error")} / '
                  f'{b and b.get("error")}')
            continue
        worst, where = largest_difference(a, b)
        own = largest_difference(b, nudged[name])[0] if 'error' not in nudged[name] else math.nan
        ok = worst <= args.tolerance
        failed += not ok
        print(f'{name:<36} {worst:18.3g} {own:17.3g}  {where}'
              f'{"" if ok else "  ABOVE TOLERANCE"}')
    print(f'tolerance {args.tolerance:g}: {"all within" if not failed else f"{failed} above"}')
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
