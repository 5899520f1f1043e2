# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
One unit per quantity in every output (SPEC section 15, issue 45.5).

Every column of a sweep table with every kind of metric, of an export (CSV
and Parquet), of an envelope's ``envelope.parquet``, of predict's
``band.parquet`` and ``draws.parquet``, of a ``summarize`` table (Parquet
and CSV), and every number with a unit in the lines ``cfem-sim run`` and
``check`` print are gathered; each numeric column must say its unit (its
Parquet field metadata, or ``name [unit]`` in a CSV header), and each
quantity (angle, angular rate, length, ...) must appear in one unit only: a
rate in rad/s in one output and deg/s in another, an angle in deg whose
column's name does not say so, or one column name with two units in two
outputs fails.
"""

import json
import os
import re

from cfem_ros import cli
from cfem_ros.recording.units import HEADER, read_units
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
            '1/s': 'decay rate', 'K': 'temperature', 'g': 'load factor', '': 'number',
            'ns': 'clock stamp'}
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


def _table(path) -> tuple:
    """
    Return ({column: unit} of a table's numeric columns, [its text columns]) as written.

    A Parquet file: its fields' metadata; a CSV: ``name [unit]`` in its
    header (``[1]``: no unit), its text columns those of the Parquet file
    written beside it (a CSV's empty text column reads as numbers). A numeric
    column that says no unit fails.
    """
    path = str(path)
    if path.endswith('.csv'):
        with open(path) as stream:
            header = stream.readline().rstrip('\n').split(',')
        twin = pd.read_parquet(path[:-len('.csv')] + '.parquet')
        found, text = {}, []
        for name in header:
            match = HEADER.match(name)
            if twin[match['name'] if match else name].dtype.kind not in 'fiub':
                assert match is None, f'{path}: text column {name} with a unit'
                text.append(name)
                continue
            assert match is not None, f'{path}: column {name} says no unit in its header'
            found[match['name']] = '' if match['unit'] == '1' else match['unit']
        return found, text
    table = pd.read_parquet(path)
    units = read_units(path)
    text = [c for c in table.columns if table[c].dtype.kind not in 'fiub']
    numeric = [c for c in table.columns if c not in text]
    assert set(units) >= set(numeric), f'{path}: no unit for {set(numeric) - set(units)}'
    return {c: units[c] for c in numeric}, text


def _envelope(tmp_path) -> str:
    """Run a 2-point envelope of one run each; return its envelope.parquet."""
    scenario = {'duration': 0.05, 'dt': 0.005,
                'flight': {'carrier': 'aircraft', 'mach': 0.8, 'altitude': 3000.0},
                'bodies': {'aircraft': {'position': [0.0, 0.0, 0.0]},
                           'store': {'mass': 900.0, 'inertia': [27, 488, 488],
                                     'position': [0.0, 0.0, 1.0]}},
                'joints': {'hook': {'type': 'fixed', 'parent': 'aircraft', 'child': 'store',
                                    'anchor': [0.0, 0.0, 0.8], 'release': {'time': 0.01}}}}
    (tmp_path / 'flight.yaml').write_text(yaml.safe_dump(scenario))
    sweep = {'scenario': 'flight.yaml', 'runs': 1, 'seed': 1, 'rate_hz': 100,
             'vary': {'flight.mach': {'grid': [0.6, 0.9]},
                      'flight.altitude': {'grid': [1000.0]},
                      'bodies.store.mass': {'uniform': [890.0, 910.0]}},
             'metrics': {'at': [{'time': 0.05, 'body': 'store', 'relative_to': 'aircraft'}]},
             'criteria': {'drop': 'store_at_0.05_z >= 1.0'}}
    (tmp_path / 'envelope.yaml').write_text(yaml.safe_dump(sweep))
    out = tmp_path / 'envelope'
    assert cli.main(['envelope', str(tmp_path / 'envelope.yaml'), '-o', str(out), '--x',
                     'flight.mach', '--y', 'flight.altitude']) == 0
    return str(out / 'envelope.parquet')


def _predict(tmp_path) -> list:
    """Predict 3 draws of a fit's force (a fit.json written here); return its tables."""
    fit = tmp_path / 'fit'
    fit.mkdir()
    key = 'wrenches[1].force[2]'
    (fit / 'fit.json').write_text(json.dumps({
        'parameters': {key: {'value': 42000.0, 'determined': True, 'bounds': [3e4, 5e4],
                             'unit': 'N', 'name': 'aft ejector force'}},
        'covariance_scaled': [[1e6]], 'status': 'ok',
        'measured': {'body': 'store', 'relative_to': 'pylon'}}))
    nxt = {'scenario': 'scenario.yaml', 'seed': 3, 'rate_hz': 200,
           'metrics': {'at': [{'time': 0.2, 'body': 'store', 'relative_to': 'pylon'}],
                       'distance': [{'bodies': ['store', 'pylon']}]},
           'criteria': {'clear': 'distance_store_pylon_min >= 0.0'}}
    (tmp_path / 'next.yaml').write_text(yaml.safe_dump(nxt))
    out = tmp_path / 'predicted'
    assert cli.main(['predict', str(fit), str(tmp_path / 'next.yaml'), '-o', str(out),
                     '--draws', '3']) == 0
    return [str(out / 'band.parquet'), str(out / 'draws.parquet')]


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
        for ext in ('parquet', 'csv'):   # as cfem-sim export writes them
            path = str(tmp_path / f'export_{relative}.{ext}')
            assert cli.main(['export', recording, '-o', path]
                            + (['--relative-to', relative] if relative else [])) == 0
            capsys.readouterr()
            if ext == 'parquet':
                units = read_units(path)
                continue
            assert _table(path) == (units, []), 'every export column says its unit'
            for column, unit in units.items():
                seen(unit, f'export column {column}')
                if unit == 'deg':
                    assert column.endswith('_deg'), f'{column}: an angle without _deg'
    tables = [_envelope(tmp_path)] + _predict(tmp_path)
    (tmp_path / 'metrics.yaml').write_text(yaml.safe_dump(
        {'scenario': 'scenario.yaml', 'metrics': {'at': [{'time': 0.2, 'body': 'store',
                                                          'relative_to': 'pylon'}],
                                                  'extremes': [{'body': 'store'}]}}))
    assert cli.main(['summarize', recording, '--metrics', str(tmp_path / 'metrics.yaml'),
                     '-o', str(tmp_path / 'summary.parquet'), '--csv']) == 0
    tables += [str(tmp_path / 'summary.parquet'), str(tmp_path / 'summary.csv')]
    for relative in (None, 'pylon'):
        tables += [str(tmp_path / f'export_{relative}.{ext}') for ext in ('csv', 'parquet')]
    assert cli.main(['sweep', str(tmp_path / 'sweep.yaml'), '-o', str(tmp_path / 'swept'),
                     '--csv']) == 0
    tables += [str(tmp_path / 'swept' / 'results.csv')]   # beside results.parquet
    capsys.readouterr()
    named = {}   # column -> (unit, where): one unit per name in every table
    for path in tables:
        found, _ = _table(path)
        where = os.path.relpath(path, tmp_path)
        for column, unit in found.items():
            if column in document['_varied'] or column.startswith(('flight.', 'wrenches[')):
                continue   # a key path: its scenario key's unit (checked above)
            seen(unit, f'{where} column {column}')
            first = named.setdefault(column, (unit, where))
            assert first[0] == unit, f'{column}: {unit!r} in {where}, {first[0]!r} in {first[1]}'
            if unit == 'deg':
                assert '_deg' in column, f'{where}: {column}: an angle without _deg'
    assert {'store_q', 'store_at_0.2_pitch_deg', 'store_pitch_deg_p05', 'probability',
            'start_stamp_ns', 'time'} <= set(named)
    for column, unit in sweep_units.items():   # the sweep's table and its CSV agree
        assert named.get(column, (unit,))[0] == unit, column
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
