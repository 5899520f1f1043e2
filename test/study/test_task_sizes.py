# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""A sweep's and a study's runs split into Dask tasks: every run once, in order, none too small."""

from cfem_ros.study.evaluate import LEAST_TASK_RUNS
from cfem_ros.study.sweep import groups, TASKS_PER_WORKER


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
    assert check(groups(runs, 2, least=LEAST_TASK_RUNS), runs) == [25] * 4
    assert check(groups(list(range(30)), 2, least=25), range(30)) == [15, 15]
    assert check(groups(list(range(30)), 4, least=25), range(30)) == [8, 8, 8, 6]
    assert check(groups(list(range(20000)), 2, least=25), range(20000)) == [1250] * 16
