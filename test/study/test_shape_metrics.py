# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Sweep metrics over a window: shape distances, contacts and windowed clearances."""

import math

from cfem_ros.study.errors import SweepError
from cfem_ros.study.runs import run_one
from cfem_ros.study.spec import load_sweep
import numpy as np
import pytest
from sweeps import write_sweep

G = 9.80665
#: The pylon: a box 2 x 0.4 x 0.3 m, its bottom face at z = -0.15 (gravity along -z).
PYLON = {'fixed': True, 'position': [0, 0, 0], 'shape': {'box': [2.0, 0.4, 0.3]}}
#: The store: a sphere of 0.2 m, its top 0.05 m below the pylon, held by a hook
#: released at 0.1 s.
STORE = {'mass': 10.0, 'inertia': [0.16, 0.16, 0.16], 'position': [0.3, 0.05, -0.4],
         'shape': {'sphere': 0.2}}
SCENARIO = {'gravity': [0, 0, -G], 'duration': 0.4, 'dt': 0.001,
            'bodies': {'pylon': PYLON, 'store': STORE,
                       'floor': {'fixed': True, 'position': [0, 0, -1.0],
                                 'shape': {'box': [4, 4, 0.2]}}},
            'joints': {'hook': {'type': 'fixed', 'parent': 'pylon', 'child': 'store',
                                'anchor': [0.3, 0.05, -0.4], 'release': {'time': 0.1}}},
            'contacts': [{'bodies': ['store', 'floor'], 'on_contact': 'continue'}]}
GAP = 0.05


def sweep(tmp_path, metrics):
    path = write_sweep(tmp_path, runs=1, vary={}, metrics=metrics, scenario=SCENARIO)
    spec = load_sweep(path)
    return spec, run_one(spec, 0)


def test_the_shape_distance_after_release_plus_a_delay(tmp_path):
    spec, row = sweep(tmp_path, {'distance': [
        {'bodies': ['store', 'pylon'], 'from': {'release': 'hook', 'delay': 0.05}},
        {'bodies': ['pylon', 'store']}]})
    assert row['status'] == 'ok'
    # from 0.15 s the store has fallen g (0.05 s)^2 / 2 from rest, and then only farther
    assert row['distance_store_pylon_min_time'] == pytest.approx(0.15, abs=1e-12)
    assert row['distance_store_pylon_min'] == pytest.approx(GAP + G * 0.05 ** 2 / 2, abs=1e-9)
    # the closest points in each body's axes: the sphere's top, the pylon's bottom face
    np.testing.assert_allclose([row[f'distance_store_pylon_point_a_{c}'] for c in 'xyz'],
                               [0, 0, 0.2], atol=1e-9)
    np.testing.assert_allclose([row[f'distance_store_pylon_point_b_{c}'] for c in 'xyz'],
                               [0.3, 0.05, -0.15], atol=1e-9)
    # without a window: the store held at its gap, first at t = 0
    assert row['distance_pylon_store_min'] == pytest.approx(GAP, abs=1e-12)
    assert row['distance_pylon_store_min_time'] == 0.0
    assert math.isnan(row['contact_store_pylon_time'])


def test_the_contact_column_is_the_first_contact_in_the_window(tmp_path):
    spec, row = sweep(tmp_path, {'distance': [
        {'bodies': ['store', 'floor'], 'from': {'release': 'hook'}},
        {'bodies': ['floor', 'store'], 'to': 0.2}]})
    # the sphere's bottom (-0.6) falls to the floor's top (-0.9) from t = 0.1 s
    touch = 0.1 + math.sqrt(2 * 0.3 / G)
    assert row['contact_store_floor_time'] == pytest.approx(touch, abs=1e-9)
    assert math.isnan(row['contact_floor_store_time'])   # after its window closed
    # it goes on into the floor (continue): at the end, 0.3 s after release, it is as deep
    # as it fell beyond the 0.3 m to the floor's top (the sphere's bottom below that face)
    assert row['distance_store_floor_min'] == pytest.approx(-(G * 0.3 ** 2 / 2 - 0.3),
                                                            abs=1e-9)
    assert row['distance_store_floor_min_time'] == pytest.approx(0.4, abs=1e-12)


def test_a_clearance_takes_the_same_window(tmp_path):
    points = {'bodies': ['store', 'pylon'], 'points_a': [[0, 0, 0.2]],
              'points_b': [[0.3, 0.05, -0.15]]}
    spec, row = sweep(tmp_path, {'clearance': [dict(points, **{'from': 0.25, 'to': 0.3})]})
    assert row['clearance_store_pylon_min_time'] == pytest.approx(0.25, abs=1e-12)
    assert row['clearance_store_pylon_min'] == pytest.approx(GAP + G * 0.15 ** 2 / 2, abs=1e-9)


@pytest.mark.parametrize('entry, key', [
    ({'bodies': ['store', 'pylon'], 'from': {'release': 'nothing'}},
     'metrics.distance[0].from.release'),
    ({'bodies': ['store', 'pylon'], 'to': -1}, 'metrics.distance[0].to'),
    ({'bodies': ['store', 'pylon'], 'from': 0.3, 'to': 0.2}, 'metrics.distance[0].to'),
    ({'bodies': ['store', 'hook']}, 'metrics.distance[0].bodies[1]'),
    ({'bodies': ['store', 'pylon'], 'from': {'release': 'hook', 'after': 1}},
     'metrics.distance[0].from.after'),
])
def test_bad_distance_entries_are_refused_with_the_key_path(tmp_path, entry, key):
    with pytest.raises(SweepError) as err:
        sweep(tmp_path, {'distance': [entry]})
    assert key in str(err.value)


def test_summarize_gives_the_sweeps_numbers_from_a_recording(tmp_path):
    from cfem_ros import cli
    from cfem_ros.study.summarize import summarize_file
    metrics = {'distance': [{'bodies': ['store', 'pylon'], 'from': {'release': 'hook'}},
                            {'bodies': ['store', 'floor']}]}
    spec, row = sweep(tmp_path, metrics)
    out = tmp_path / 'run.mcap'
    assert cli.main(['run', str(tmp_path / 'scenario.yaml'), '-o', str(out)]) == 0
    summary = summarize_file(str(out), spec.metrics)
    assert summary['status'] == 'ok'
    for column in spec.metrics.columns():
        assert summary[column] == pytest.approx(row[column], abs=1e-12, nan_ok=True), column
    assert summary['contact_store_floor_time'] > 0.1   # from the recorded contact event


def test_the_distance_to_a_compound_is_the_least_over_its_parts(tmp_path):
    # the pylon in two parts: the box above the store, and a block 2.7 m aft reaching
    # 0.35 m lower than the store's top; their hull would cut through the store
    scenario = dict(SCENARIO, bodies=dict(SCENARIO['bodies'], pylon=dict(PYLON, shape={
        'parts': [{'box': [0.4, 0.4, 0.3], 'at': [3.0, 0.0, -0.35]},
                  {'box': [2.0, 0.4, 0.3]}]})))
    path = write_sweep(tmp_path, runs=1, vary={}, scenario=scenario, metrics={
        'distance': [{'bodies': ['store', 'pylon'], 'from': {'release': 'hook', 'delay': 0.05}}]})
    row = run_one(load_sweep(path), 0)
    assert row['status'] == 'ok', row['message']
    assert row['distance_store_pylon_min_time'] == pytest.approx(0.15, abs=1e-12)
    assert row['distance_store_pylon_min'] == pytest.approx(GAP + G * 0.05 ** 2 / 2, abs=1e-9)
    np.testing.assert_allclose([row[f'distance_store_pylon_point_b_{c}'] for c in 'xyz'],
                               [0.3, 0.05, -0.15], atol=1e-9)
