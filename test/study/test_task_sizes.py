# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A sweep's and a study's runs split into Dask tasks: every run once, in order, none too small.

And a task's part read back as the rows pandas' ``to_dict('records')`` gives.
"""

import math

from cfem_ros.study.evaluate import LEAST_TASK_RUNS, records
from cfem_ros.study.sweep import groups, TASKS_PER_WORKER
import numpy as np
import pytest


def check(chunks, runs):
    assert [k for chunk in chunks for k in chunk] == list(runs)   # each once, in order
    return [len(chunk) for chunk in chunks]


def test_a_sweep_s_runs_make_tasks_per_worker_as_before():
    assert check(groups(list(range(20000)), 2), range(20000)) == [1250] * 16
    assert check(groups(list(range(100)), 2), range(100)) == [7] * 14 + [2]
    assert len(groups(list(range(5)), 2)) == 5
    assert groups([], 2) == [] and check(groups([3], 0), [3]) == [1]
    assert TASKS_PER_WORKER * 2 == 16


def test_a_study_s_batch_makes_tasks_of_the_least_size_while_each_worker_has_one():
    runs = list(range(1000, 1100))   # a subset step of 100 runs on 2 workers
    assert check(groups(runs, 2, least=LEAST_TASK_RUNS), runs) == [50] * 2
    assert check(groups(runs[:20], 2, least=LEAST_TASK_RUNS), runs[:20]) == [10] * 2
    assert check(groups(list(range(30)), 2, least=25), range(30)) == [15, 15]
    assert check(groups(list(range(30)), 4, least=25), range(30)) == [8, 8, 8, 6]
    assert check(groups(list(range(20000)), 2, least=25), range(20000)) == [1250] * 16


def same(a, b) -> bool:
    """Tell whether two cells are the same value of the same type (NaN the same as NaN)."""
    if type(a) is not type(b):
        return False
    if isinstance(a, float) and math.isnan(a):
        return math.isnan(b)
    return a == b


def test_a_part_s_rows_are_pandas_records_value_and_type(tmp_path):
    pd = pytest.importorskip('pandas')
    pytest.importorskip('pyarrow')
    table = pd.DataFrame({
        'run': [7, 8, 9],
        'wrenches[0].force[2]': [10676.5, np.nan, -1e-300],
        'status': ['ok', 'failed', 'invalid'],
        'message': ['', 'the run failed at 0.2 s', 'bodies.store.mass: is -1'],
        'store_at_0.2_z': [0.96, np.nan, np.inf],
        'pass': [True, False, False],
        'count': pd.array([1, None, 3], dtype='Int64'),   # masked: NA
        'text': pd.array(['a', None, 'c'], dtype='str'),   # NaN
        'nothing': [None, None, None]})
    path = tmp_path / 'part.parquet'
    table.to_parquet(path)
    read = pd.read_parquet(path)
    want = read.to_dict('records')
    found = records(read)
    assert [list(row) for row in found] == [list(row) for row in want]
    assert all(same(a[k], b[k]) for a, b in zip(found, want) for k in a), (found, want)
    assert found[1]['count'] is None and found[0]['count'] == 1 and found[1]['pass'] is False
