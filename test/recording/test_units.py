# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
One unit per quantity in every output (SPEC section 15, issue 45.5).

Every column of a sweep table with every kind of metric, of an export (CSV
and Parquet) and every number with a unit in the lines ``cfem-sim run`` and
``check`` print are gathered; each column must have a unit rule (its Parquet field
says it), and each quantity (angle, angular rate, length, ...) must appear
in one unit only: a rate in rad/s in one output and deg/s in another, or
an angle in deg whose column's name does not say so, fails.
"""

import os
import re

from cfem_ros import cli
from cfem_ros.recording.units import read_units
from cfem_ros.study import labels
from cfem_ros.study.runs import run_rows
from cfem_ros.study.spec import load_sweep
from cfem_ros.study.sweep import columns, frame, write_atomic
import pandas as pd
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENARIO = os.path.join(ROOT, 'config', 'store_release_near_pylon.yaml')
#: Every unit an output may use -> the quantity it measures.
QUANTITY = {'deg': 'angle', 'rad': 'angle', 'deg/s': 'angular rate', 'rad/s': 'angular rate',
            'm': 'length', 'mm': 'length', 'm/s': 'speed', 's': 'time', 'ms': 'time',
            'N': 'force', 'kN': 'force', 'N m': 'moment', 'Pa': 'pressure', 'kg': 'mass',
            'kg m^2': 'inertia', 'Hz': 'rate of samples', 'm/s^2': 'acceleration',
            '1/s': 'decay rate', 'K': 'temperature', 'g': 'load factor', '': 'number'}
#: A number (or a bracketed list of them) followed by a unit, as a log line writes it.
LOGGED = re.compile(r'(?:[-+]?\d[\d.eE+-]*|\])\s+(deg/s|rad/s|deg|rad|m/s\^2|m/s|mm|ms|m|s|kN|'
                    r'N m|N|Pa|kg|Hz|1/s)(?![\w/^])')


def _sweep(tmp_path) -> tuple:
    """Return (sweep table as read back, its Parquet units, the base document)."""
    with open(SCENARIO) as f:
        document = yaml.safe_load(f)
    document['duration'] = 0.3
    document['bodies']['store']['angular_velocity_deg'] = [0, 1, 0]
    proximity = document['aero']['store']['proximity']
    proximity['table'] = os.path.join(ROOT, 'config', proximity['table'])
    scenario = tmp_path / 'scenario.yaml'
    scenario.write_text(yaml.safe_dump(document))
    sweep = {'scenario': 'scenario.yaml', 'runs': 1, 'seed': 1, 'rate_hz': 200,
             'vary': {'bodies.store.mass': {'normal': [907.0, 5.0]},
                      'bodies.store.angular_velocity_deg[1]': {'uniform': [0.0, 2.0]},
                      'wrenches[1].force[2]': {'uniform': [40000, 45000]}},
             'metrics': {'clearance': [{'bodies': ['store', 'pylon'],
                                        'points_a': [[1.5, 0, 0]], 'points_b': [[0, 0, 0.25]]}],
                         'distance': [{'bodies': ['store', 'pylon']}],
                         'at': [{'time': 0.2, 'body': 'store', 'relative_to': 'pylon'},
                                {'time': 0.1, 'body': 'store', 'after': 'hooks'}],
                         'extremes': [{'body': 'store', 'relative_to': 'pylon'}]}}
    path = tmp_path / 'sweep.yaml'
    path.write_text(yaml.safe_dump(sweep))
    spec = load_sweep(str(path))
    table = frame(run_rows(spec, [0]), columns(spec))
    out = str(tmp_path / 'results.parquet')
    write_atomic(table, out, spec.document)
    varied = {v.path for v in spec.variables}
    return pd.read_parquet(out), read_units(out), dict(spec.document, _varied=varied)


def _run(tmp_path, capsys, scenario, name) -> tuple:
    """Return (recording path, the lines cfem-sim run printed)."""
    out = str(tmp_path / f'{name}.mcap')
    assert cli.main(['run', str(scenario), '-o', out]) == 0
    printed = capsys.readouterr()
    return out, (printed.out + printed.err).splitlines()


def test_every_output_gives_each_quantity_in_one_unit(tmp_path, capsys):
    table, sweep_units, document = _sweep(tmp_path)
    used = {}   # unit -> where it was seen first

    def seen(unit, where):
        assert unit in QUANTITY, f'{where}: unit {unit!r} has no quantity in this test'
        used.setdefault(unit, where)

    numeric = [c for c in table.columns if table[c].dtype.kind in 'fiub']
    for column in table.columns:
        rule = labels.unit_rule(column, document)
        assert rule is not None, f'sweep column {column}: no unit rule (study/labels.py)'
        if column in numeric:
            assert sweep_units.get(column) == rule, f'sweep column {column}: Parquet unit'
        if column in document['_varied']:   # a key path: the scenario key's own unit
            assert rule == ('deg/s' if column.endswith('_deg[1]') else
                            {'bodies.store.mass': 'kg'}.get(column, 'N')), column
            continue
        seen(rule, f'sweep column {column}')
    assert {'stroke_aft_ejector_q', 'store_max_q', 'store_at_0.1r_pitch_deg',
            'distance_store_pylon_point_a_x', 'aero_outside_store'} <= set(table.columns)

    recording, lines = _run(tmp_path, capsys, tmp_path / 'scenario.yaml', 'near')
    spin = {'duration': 0.01, 'dt': 0.01,
            'bodies': {'top': {'mass': 1.0, 'inertia': [1, 1, 1],
                               'angular_velocity_deg': [0, 0, 9000]}}}
    (tmp_path / 'spin.yaml').write_text(yaml.safe_dump(spin))
    lines += _run(tmp_path, capsys, tmp_path / 'spin.yaml', 'spin')[1]
    for scenario in ('spin.yaml', 'scenario.yaml'):   # check's summary and warnings too
        cli.main(['check', str(tmp_path / scenario)])
        printed = capsys.readouterr()
        lines += (printed.out + printed.err).splitlines()
    for relative in (None, 'pylon'):
        for ext in ('csv', 'parquet'):   # as cfem-sim export writes them
            path = str(tmp_path / f'export_{relative}.{ext}')
            assert cli.main(['export', recording, '-o', path]
                            + (['--relative-to', relative] if relative else [])) == 0
            capsys.readouterr()
            if ext == 'csv':
                names = list(pd.read_csv(path, nrows=1).columns)
                continue
            units = read_units(path)
            assert set(units) == set(names), 'every export column says its unit'
            for column, unit in units.items():
                seen(unit, f'export column {column}')
                if unit == 'deg':
                    assert column.endswith('_deg'), f'{column}: an angle without _deg'
    assert any('p, q, r =' in line for line in lines) and any('spins' in line for line in lines)
    for line in lines:
        for unit in LOGGED.findall(line):
            seen(unit, f'log line {line!r}')
    by_quantity = {}
    for unit, where in used.items():
        by_quantity.setdefault(QUANTITY[unit], []).append(f'{unit} ({where})')
    twice = {q: u for q, u in by_quantity.items() if len(u) > 1 and q != 'number'}
    assert not twice, f'a quantity in two units: {twice}'
    assert used.keys() >= {'deg', 'deg/s', 'm', 'm/s', 'N', 'N m', 's', 'Pa'}
