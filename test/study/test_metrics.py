# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""A run's metrics against the same quantities computed independently (scipy, brute force)."""

import math

from cfem_ros.study.metrics import compute, Samples
from cfem_ros.study.metricspec import At, Clearance, Metrics
import numpy as np
import pytest
from scipy.spatial.transform import Rotation


def _samples(rng, n):
    """Two bodies tumbling at random (attitudes of any norm), n samples 0.01 s apart."""
    t = np.arange(n) * 0.01
    bodies = {}
    for name in ('store', 'pylon'):
        quat = rng.normal(size=(n, 4)) * rng.uniform(0.5, 2.0, size=(n, 1))
        bodies[name] = (t, rng.normal(scale=0.5, size=(n, 3)), quat)
    return Samples(bodies=bodies)


def _brute_clearance(samples, points_a, points_b):
    """Every sample and point pair, scipy's rotations, numpy's first minimum."""
    t, pos_a, quat_a = samples.bodies['store']
    _, pos_b, quat_b = samples.bodies['pylon']
    world_a = np.stack([pos_a + Rotation.from_quat(quat_a).apply(p) for p in points_a], 1)
    world_b = np.stack([pos_b + Rotation.from_quat(quat_b).apply(p) for p in points_b], 1)
    dist = np.linalg.norm(world_a[:, :, None, :] - world_b[:, None, :, :], axis=-1)
    k, i, j = np.unravel_index(int(np.argmin(dist)), dist.shape)
    return dist[k, i, j], t[k], i, j


@pytest.mark.parametrize('seed', range(5))
def test_clearance_is_the_least_distance_over_samples_and_point_pairs(seed):
    rng = np.random.default_rng(seed)
    samples = _samples(rng, 40)
    points_a = rng.normal(size=(3, 3))
    points_b = rng.normal(size=(2, 3))
    metrics = Metrics(clearance=[Clearance('store', 'pylon', points_a, points_b)])
    row = compute(samples, metrics)
    distance, time, i, j = _brute_clearance(samples, points_a, points_b)
    assert row['clearance_store_pylon_min'] == pytest.approx(distance, rel=1e-13)
    assert (row['clearance_store_pylon_min_time'], row['clearance_store_pylon_point_a'],
            row['clearance_store_pylon_point_b']) == (time, i, j)


def test_clearance_ties_go_to_the_first_sample_then_points():
    # a body at rest: every sample ties; two points of a at the same distance from b's
    n = 4
    still = (np.arange(n) * 0.1, np.zeros((n, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)))
    away = (still[0], np.tile([0.0, 0.0, 2.0], (n, 1)), still[2])
    samples = Samples(bodies={'store': still, 'pylon': away})
    points = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    row = compute(samples, Metrics(clearance=[Clearance('store', 'pylon', points,
                                                        np.zeros((1, 3)))]))
    assert row['clearance_store_pylon_min'] == pytest.approx(math.sqrt(5.0), rel=1e-15)
    assert (row['clearance_store_pylon_min_time'], row['clearance_store_pylon_point_a'],
            row['clearance_store_pylon_point_b']) == (0.0, 0, 0)


def test_clearance_of_a_run_without_samples_is_nan():
    empty = (np.empty(0), np.empty((0, 3)), np.empty((0, 4)))
    samples = Samples(bodies={'store': empty, 'pylon': empty})
    row = compute(samples, Metrics(clearance=[Clearance('store', 'pylon', np.zeros((1, 3)),
                                                        np.zeros((1, 3)))]))
    assert math.isnan(row['clearance_store_pylon_min'])
    assert row['clearance_store_pylon_point_a'] == -1


@pytest.mark.parametrize('seed', range(5))
def test_state_at_a_time_relative_to_a_body_is_scipys(seed):
    rng = np.random.default_rng(seed)
    samples = _samples(rng, 30)
    row = compute(samples, Metrics(at=[At(0.17, 'store', 'pylon')]))
    k = 17
    _, pos, quat = samples.bodies['store']
    _, pos_r, quat_r = samples.bodies['pylon']
    reference = Rotation.from_quat(quat_r[k])
    position = reference.inv().apply(pos[k] - pos_r[k])
    angles = (reference.inv() * Rotation.from_quat(quat[k])).as_euler('ZYX', degrees=True)
    prefix = 'store_at_0.17_'
    assert [row[prefix + c] for c in 'xyz'] == pytest.approx(position, rel=1e-12, abs=1e-14)
    assert [row[prefix + c] for c in ('yaw_deg', 'pitch_deg', 'roll_deg')] == pytest.approx(
        angles, abs=1e-10)
