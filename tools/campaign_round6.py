# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The reliability campaign's families of the sixth round (issues 45, 46 and 48 to 49).

Exports from a point of the carrier (``--point``) with their units in the
CSV headers, a fit's measured CSV whose headers say other units, sweep
metrics taken from a point of the carrier (``at: ... point:``), and a
scenario that only its first step refuses, through every entry point.

Each family takes the campaign's ``call`` (a cfem-sim command in this process, judged
by the campaign's rules), ``defect`` (a broken rule of its own) and a random generator.
"""

import json
import math
import pathlib

import yaml

ROOT = pathlib.Path(__file__).resolve().parents[1]
CONFIG = ROOT / 'config'
#: Points a user might type for --point, good and bad.
POINTS = ['carriage', ' carriage ', 'Carriage', '[0, 0, 0]', '[-0.3, 0, 0.25]', '0,0,0.3',
          '[1e9, 0, 0]', '[1e300, 0, 0]', '[nan, 0, 0]', '[inf, 0, 0]', '[1, 2]',
          '[1, 2, 3, 4]', 'x', '', '[]', '[1,,2]', '1e-300,0,0', '[True, 0, 0]']
#: Units a header might say instead of the right one.
WRONG_UNITS = {'m': ['mm', 'ft', 'deg', ''], 'deg': ['rad', 'deg/s', 'm'], 's': ['ms', 'min']}


def _recordings(folder, call):
    """Record the two-hook release (command log) and the pull-up; return their paths."""
    runs = []
    two_hooks = CONFIG / 'inputs' / 'store_release_two_hooks.mcap'
    for name, scenario, extra in (
            ('two_hooks', 'store_release_two_hooks.yaml', ['--inputs', two_hooks]),
            ('pullup', 'store_release_two_hooks_pullup.yaml', [])):
        out = folder / f'{name}.mcap'
        call('export point', ['run', CONFIG / scenario, '-o', out, '--overwrite',
                              '--duration', '0.6', *extra], allowed={0, 3})
        runs.append(out)
    return runs


def _numeric_headers_without_unit(path):
    import pandas as pd
    table = pd.read_csv(path, encoding='utf-8-sig')
    return [c for c in table.columns if pd.api.types.is_numeric_dtype(table[c])
            and not c.rstrip().endswith(']')]


def export_point(folder, call, defect, rng, count):
    """Export relative to a body from a point, as CSV and Parquet: one table, every unit."""
    import numpy as np
    from cfem_ros.recording.units import read_csv, read_units
    import pandas as pd
    runs = _recordings(folder, call)
    bodies = ['pylon', 'aircraft', 'store', 'nobody']
    for k in range(count):
        run = rng.choice(runs)
        argv = ['export', run, '--overwrite']
        body = rng.choice(bodies + [None])
        if body is not None:
            argv += ['--relative-to', body]
        point = rng.choice(POINTS + [None])
        if point is not None:
            argv += ['--point', point]
        if rng.random() < 0.3:
            argv += ['--rate', rng.choice([50, 100, 1e-3, 7, 1e9])]
        tables = {}
        for suffix in ('csv', 'parquet'):
            out = folder / f'export_{k}.{suffix}'
            status, _, err = call('export point', argv[:2] + ['-o', out] + argv[2:])
            if status == 0:
                tables[suffix] = out
            elif point is not None and body is None and 'ERROR' not in err:
                defect('export point', ' '.join(map(str, argv)), '--point without '
                       '--relative-to neither refused nor said')
        if point is not None and body is None and tables:
            defect('export point', ' '.join(map(str, argv)),
                   '--point without --relative-to accepted')
        if len(tables) == 1:
            defect('export point', ' '.join(map(str, argv)),
                   f'written as {next(iter(tables))} only: CSV and Parquet differ in what '
                   'they accept')
        if len(tables) != 2:
            continue
        bare = _numeric_headers_without_unit(tables['csv'])
        if bare:
            defect('export point', ' '.join(map(str, argv)), f'CSV columns without a unit: '
                   f'{bare[:5]}')
        names = pd.read_parquet(tables['parquet']).columns
        units = read_units(str(tables['parquet']))
        if set(names) != set(units):
            defect('export point', ' '.join(map(str, argv)),
                   f'Parquet columns without a unit: {sorted(set(names) - set(units))[:5]}')
        csv, parquet = read_csv(str(tables['csv'])), pd.read_parquet(tables['parquet'])
        if list(csv.columns) != list(parquet.columns):
            defect('export point', ' '.join(map(str, argv)), 'CSV and Parquet name their '
                   'columns differently')
        else:
            a, b = csv.to_numpy(dtype=float), parquet.to_numpy(dtype=float)
            if a.shape != b.shape or not np.array_equal(a, b, equal_nan=True):
                defect('export point', ' '.join(map(str, argv)),
                       'the CSV does not read back as the Parquet table')
        if body is not None and point is not None and not any(
                c.endswith('_u_rel') for c in parquet.columns):
            defect('export point', ' '.join(map(str, argv)),
                   'relative to a carrier without _u_rel')


def _measured_csv(folder, call):
    """Run the pull-up with ejectors, export the store relative to the aircraft as CSV."""
    scenario = CONFIG / 'fit' / 'pullup_ejectors.yaml'
    run, table = folder / 'flight.mcap', folder / 'measured.csv'
    call('csv units', ['run', scenario, '-o', run, '--overwrite', '--duration', '0.5'],
         allowed={0})
    call('csv units', ['export', run, '-o', table, '--relative-to', 'aircraft', '--rate',
                       '100', '--overwrite'])
    return scenario, run, table


def csv_units(folder, call, defect, rng, count):
    """Fits of a measured CSV whose headers say other units, lose them or repeat a column."""
    scenario, run, table = _measured_csv(folder, call)
    if not table.exists():
        return
    lines = table.read_text(encoding='utf-8').splitlines()
    header = lines[0].split(',')
    read = ['time'] + [f'store_{q}' for q in ('x', 'y', 'z', 'roll_deg', 'pitch_deg',
                                              'yaw_deg')]
    for k in range(count):
        cells = list(header)
        what = 'none' if k == 0 else rng.choice(['unit', 'unit', 'bare', 'garbage', 'twice',
                                                 'bom', 'order'])
        wrong = None
        index = rng.randrange(len(cells))
        name, _, unit = cells[index].partition(' [')
        unit = unit.rstrip(']')
        if what == 'unit' and unit in WRONG_UNITS and name in read:
            cells[index] = f'{name} [{rng.choice(WRONG_UNITS[unit])}]'
            wrong = name
        elif what == 'bare':
            cells = [c.partition(' [')[0] for c in cells]
        elif what == 'garbage':
            cells[index] = name + rng.choice([' [', ' []', ' [m', ' [[m]]', ' [m] [m]', '[m]'])
        elif what == 'twice':
            cells[index] = cells[(index + 1) % len(cells)]
        text_lines = [','.join(cells)] + lines[1:]
        if what == 'order':
            columns = [line.split(',') for line in text_lines]
            order = list(range(len(cells)))
            rng.shuffle(order)
            text_lines = [','.join(row[i] for i in order) for row in columns]
        path = folder / f'measured_{k}.csv'
        text = '\n'.join(text_lines) + '\n'
        path.write_text(('\ufeff' if what == 'bom' else '') + text, encoding='utf-8')
        fit = {'scenario': str(scenario),
               'measured': {'file': str(path), 'body': 'store', 'relative_to': 'aircraft',
                            'window': {'from': 0.05, 'to': 0.45},
                            'sigma': {'position': 0.005, 'attitude_deg': 0.3}},
               'parameters': {'wrenches[0].force[2]': {'start': 10000,
                                                       'bounds': [2000, 30000]}}}
        fit_path = folder / f'fit_{k}.yaml'
        fit_path.write_text(yaml.safe_dump(fit, sort_keys=False))
        argv = ['fit', fit_path, '-o', folder / f'fit_{k}', '--overwrite', '--threads', '1']
        status, _, err = call('csv units', argv, timeout=300, allowed={0, 1, 2})
        if wrong is not None and status == 0:
            defect('csv units', f'{" ".join(map(str, argv))} ({cells[index]})',
                   'a measured column in another unit was fitted as if in the right one')
        if wrong is not None and status == 2 and wrong not in err:
            defect('csv units', f'{" ".join(map(str, argv))} ({cells[index]})',
                   f'the refusal does not name the column {wrong}: {err.strip()[:200]}')
        if what in ('none', 'bare', 'order', 'bom') and status != 0:
            defect('csv units', f'{" ".join(map(str, argv))} ({what})',
                   f'a good CSV refused: {err.strip()[:200]}')


def metric_point(folder, call, defect, rng, count):
    """Sweep metrics at a point of the carrier: accepted ones have units, bad ones refused."""
    from cfem_ros.recording.units import read_units
    import pandas as pd
    for k in range(count):
        point = rng.choice(POINTS + [[0, 0, 0], [-0.3, 0, 0.25], [math.inf, 0, 0], [1, 2],
                                     {'x': 1}, None, 5])
        entry = {'time': rng.choice([0.1, 0.3, 0.0, -1, 1e9]), 'body': 'store',
                 'relative_to': rng.choice(['pylon', 'aircraft', 'store', 'nobody'])}
        if point is not None:
            entry['point'] = point
        sweep = {'scenario': str(CONFIG / 'store_release_two_hooks.yaml'), 'runs': 2,
                 'seed': k, 'vary': {'bodies.store.mass': {'uniform': [900.0, 910.0]}},
                 'metrics': {'at': [entry]}}
        path = folder / f'sweep_{k}.yaml'
        path.write_text(yaml.safe_dump(json.loads(json.dumps(sweep)), sort_keys=False))
        outdir = folder / f'sweep_{k}'
        argv = ['sweep', path, '-o', outdir, '--workers', '1', '--runs', '1']
        status, _, _ = call('metric point', argv, timeout=300, allowed={0, 1, 2})
        if status != 0:
            continue
        results = outdir / 'results.parquet'
        names = [c for c, kind in pd.read_parquet(results).dtypes.items()
                 if kind.kind in 'fiu']
        units = read_units(str(results))
        missing = [n for n in names if n not in units]
        if missing:
            defect('metric point', ' '.join(map(str, argv)),
                   f'numeric columns without a unit: {missing[:5]}')


FAMILIES = {
    'exportpoint': lambda f, c, d, r, n: export_point(f, c, d, r, n(40)),
    'csvunits': lambda f, c, d, r, n: csv_units(f, c, d, r, n(20)),
    'metricpoint': lambda f, c, d, r, n: metric_point(f, c, d, r, n(10)),
}

__all__ = ['FAMILIES']
