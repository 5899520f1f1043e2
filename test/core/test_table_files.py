# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Proximity tables of every column type and shape: read, or one clear refusal (issue 41.8)."""

from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.scenario.parse import parse_scenario
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

BASE = {'area': 0.2027, 'length': 0.508, 'altitude': 7925.0, 'alpha_deg': [-20, 0, 20],
        'beta_deg': [-10, 10], 'mach': [0.6, 0.9, 1.2],
        'zero': ['CX', 'CY', 'CZ', 'Cl', 'Cm', 'Cn']}
GOOD = 'dx,dCX\n0,0.1\n1,0.3\n'


def read(path):
    """Parse a scenario whose store has a proximity table at path; return the proximity."""
    doc = {'gravity': [0, 0, 9.80665],
           'bodies': {'aircraft': {'motion': {'velocity': [250.0, 0, 0]}},
                      'store': {'mass': 907.0, 'inertia': [27.0, 488.0, 488.0],
                                'position': [0.5, 0, 1.2]}},
           'aero': {'store': dict(BASE, proximity={'carrier': 'aircraft', 'table': str(path),
                                                   'outside': 'hold'})}}
    return parse_scenario(doc).aero[0].proximity


def test_a_csv_with_a_byte_order_mark_is_read_as_without(tmp_path):
    (tmp_path / 'bom.csv').write_text('\ufeff' + GOOD, encoding='utf-8')
    proximity = read(tmp_path / 'bom.csv')
    assert proximity.axes == ('dx',)
    np.testing.assert_array_equal(proximity.increments[:, 0], [0.1, 0.3])


@pytest.mark.parametrize('text, said', [
    ('dx,dCX\n', 'has a header and no data rows'),
    ('dx,dCX,dx\n0,0.1,5\n1,0.3,6\n', "has the column 'dx' twice"),
])
def test_a_csv_without_rows_or_with_a_column_twice_is_refused(tmp_path, text, said):
    (tmp_path / 't.csv').write_text(text)
    with pytest.raises(ScenarioError, match=r'aero\.store\.proximity\.table: t\.csv ' + said):
        read(tmp_path / 't.csv')


@pytest.mark.parametrize('column, said', [
    (pa.array(['a', 'b']), 'holds string'),
    (pa.array([[1.0], [2.0]]), 'holds list<'),
    (pa.array([{'x': 1.0}, {'x': 2.0}]), 'holds struct<x: double>'),
    (pa.array([b'\x00', b'\x01']), 'holds binary'),
    (pa.array([True, False]), 'holds bool'),
    (pa.array([0.1, None]), 'has 1 empty cell'),
])
def test_a_parquet_column_that_is_not_numbers_is_refused(tmp_path, column, said):
    table = pa.table({'dx': pa.array([0.0, 1.0]), 'dCX': column})
    pq.write_table(table, tmp_path / 't.parquet')
    with pytest.raises(ScenarioError, match=r"t\.parquet: column 'dCX' " + said):
        read(tmp_path / 't.parquet')


def test_a_parquet_table_of_integers_is_read_and_one_without_rows_refused(tmp_path):
    pq.write_table(pa.table({'dx': pa.array([0, 1], pa.int32()),
                             'dCX': pa.array([1, 3], pa.int64())}), tmp_path / 'i.parquet')
    np.testing.assert_array_equal(read(tmp_path / 'i.parquet').increments[:, 0], [1.0, 3.0])
    pq.write_table(pa.table({'dx': pa.array([], pa.float64()),
                             'dCX': pa.array([], pa.float64())}), tmp_path / 'e.parquet')
    with pytest.raises(ScenarioError, match=r'e\.parquet has no rows'):
        read(tmp_path / 'e.parquet')
    (tmp_path / 'cut.parquet').write_bytes((tmp_path / 'i.parquet').read_bytes()[:100])
    with pytest.raises(ScenarioError, match=r'cut\.parquet is not a readable Parquet file'):
        read(tmp_path / 'cut.parquet')
