# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Least distances between samples (SPEC section 15), against closed forms."""

import math

from cfem_ros.study.errors import SweepError
from cfem_ros.study.runs import run_one
from cfem_ros.study.spec import load_sweep
import numpy as np
import pytest
from sweeps import write_sweep

G = 9.80665
#: A box 2 x 4 x 0.3 m at the origin: the edge x = 1, z = -0.15 runs along y.
EDGE = np.array([1.0, -0.15])
RADIUS = 0.1
#: The sphere's centre in the x-z plane at t = 0, and its velocity there (m, m/s); gravity
#: along y, the edge's direction, leaves the distance to the edge a straight-line pass.
START, VELOCITY = np.array([0.2, -0.6]), np.array([20.0, 1.0])


def pass_scenario():
    return {'gravity': [0, -G, 0], 'duration': 0.1, 'dt': 0.001,
            'bodies': {
                'pylon': {'fixed': True, 'position': [0, 0, 0], 'shape': {'box': [2, 4, 0.3]}},
                'store': {'mass': 10.0, 'inertia': [0.04, 0.04, 0.04],
                          'position': [float(START[0]), 0.0, float(START[1])],
                          'velocity': [float(VELOCITY[0]), 0.0, float(VELOCITY[1])],
                          'angular_velocity_deg': [0, 90, 0],
                          'shape': {'sphere': RADIUS}}}}


def closed_form():
    """Return the least distance of the sphere to the edge and its time (straight line)."""
    offset = START - EDGE
    when = -offset @ VELOCITY / (VELOCITY @ VELOCITY)
    closest = START + VELOCITY * when
    assert closest[0] > EDGE[0] and closest[1] < EDGE[1]   # the edge is the closest feature
    return abs(offset[0] * VELOCITY[1] - offset[1] * VELOCITY[0]) / np.linalg.norm(VELOCITY) \
        - RADIUS, when


def row_of(tmp_path, metrics, rate_hz=200):
    path = write_sweep(tmp_path, runs=1, vary={}, metrics=metrics, scenario=pass_scenario(),
                       rate_hz=rate_hz)
    row = run_one(load_sweep(path), 0)
    assert row['status'] == 'ok', row['message']
    return row


def test_a_sphere_passing_a_box_edge_is_closest_between_samples(tmp_path):
    least, when = closed_form()
    assert abs(when * 200 - round(when * 200)) > 0.1   # well between two samples
    row = row_of(tmp_path, {'distance': [{'bodies': ['store', 'pylon']}]})
    assert row['distance_store_pylon_min'] == pytest.approx(least, abs=1e-6)
    assert row['distance_store_pylon_min_time'] == pytest.approx(when, abs=1e-6)
    # the closest point on the box: on its edge, at the sphere's y there (gravity along y)
    y = -G * when ** 2 / 2
    np.testing.assert_allclose([row[f'distance_store_pylon_point_b_{c}'] for c in 'xyz'],
                               [EDGE[0], y, EDGE[1]], atol=1e-6)
    # the least sample is farther by about half a millimetre: what the search is for
    samples = np.arange(0, 0.1 + 1e-9, 0.005)
    centre = START + np.outer(samples, VELOCITY)
    sampled = (np.linalg.norm(centre - EDGE, axis=1) - RADIUS).min()
    assert sampled - least > 3e-4


def test_a_clearance_between_points_is_found_between_samples(tmp_path):
    # the sphere's centre against the point of the edge at y = 0 (it drifts along y)
    least, when = closed_form()
    row = row_of(tmp_path, {'clearance': [{'bodies': ['store', 'pylon'],
                                           'points_a': [[0, 0, 0]],
                                           'points_b': [[1.0, 0.0, -0.15], [-1, 0, -0.15]]}]})
    # the centre's distance to the point: the pass at the edge and the drift along y
    t = np.linspace(when - 1e-3, when + 1e-3, 200001)
    centre = START + np.outer(t, VELOCITY)
    gap = np.sqrt(((centre - EDGE) ** 2).sum(axis=1) + (G * t ** 2 / 2) ** 2)
    assert row['clearance_store_pylon_min'] == pytest.approx(gap.min(), abs=1e-6)
    assert row['clearance_store_pylon_min_time'] == pytest.approx(t[np.argmin(gap)], abs=1e-6)
    assert (row['clearance_store_pylon_point_a'], row['clearance_store_pylon_point_b']) == (0, 0)


def test_a_pair_may_have_several_windows(tmp_path):
    least, when = closed_form()
    row = row_of(tmp_path, {'distance': [
        {'bodies': ['store', 'pylon'], 'name': 'miss_early', 'to': 0.02},
        {'bodies': ['store', 'pylon'], 'name': 'miss_pass', 'from': 0.02, 'to': 0.0412},
        {'bodies': ['store', 'pylon']}]})
    # the first window closes before the pass: its least is at its end, on a sample
    offset = START + VELOCITY * 0.02 - EDGE
    assert row['miss_early_min_time'] == pytest.approx(0.02, abs=1e-12)
    assert row['miss_early_min'] > least + 0.01
    # the second holds the pass (it closes 0.2 ms after it, between samples)
    assert row['miss_pass_min'] == pytest.approx(least, abs=1e-6)
    assert row['miss_pass_min_time'] == pytest.approx(when, abs=1e-6)
    assert row['distance_store_pylon_min'] == pytest.approx(least, abs=1e-6)
    assert math.isnan(row['contact_miss_pass_time'])
    assert np.linalg.norm(offset) > 0   # the window's end is off the edge's quadrant


def test_a_window_that_ends_between_samples_is_measured_to_its_end(tmp_path):
    least, when = closed_form()
    end = float(when - 0.0021)   # before the pass, between samples
    row = row_of(tmp_path, {'distance': [{'bodies': ['store', 'pylon'], 'to': end}]})
    x, z = START + VELOCITY * end   # still under the box's bottom face: its distance
    assert x < EDGE[0]
    assert row['distance_store_pylon_min_time'] == pytest.approx(end, abs=1e-9)
    assert row['distance_store_pylon_min'] == pytest.approx(EDGE[1] - z - RADIUS, abs=1e-6)


def test_a_pair_given_twice_needs_a_name_for_each_window(tmp_path):
    with pytest.raises(SweepError) as err:
        row_of(tmp_path, {'distance': [{'bodies': ['store', 'pylon'], 'to': 0.02},
                                       {'bodies': ['store', 'pylon'], 'from': 0.02}]})
    assert 'metrics.distance[1].bodies' in str(err.value)
    assert 'name' in str(err.value)
    with pytest.raises(SweepError) as err:
        row_of(tmp_path, {'distance': [{'bodies': ['store', 'pylon'], 'name': '1st'}]})
    assert 'metrics.distance[0].name' in str(err.value)


def test_the_search_agrees_with_a_dense_run_for_a_tumbling_release(tmp_path):
    # the store on its hinge, released at 10 deg and tumbling near a box: the least distance
    # found from 200 Hz samples against the least sample of the same run sampled at 5 kHz
    scenario = {
        'gravity': [0, 0, 9.80665], 'duration': 0.5, 'dt': 0.0002,
        'bodies': {'pylon': {'fixed': True, 'shape': {'box': [1.0, 0.5, 0.2]},
                             'position': [1.2, 0, 0.55]},
                   'store': {'mass': 907.1848, 'inertia': [27.1164, 488.0944, 488.0944],
                             'position': [0, 0, 0], 'shape': {'box': [3.0, 0.3, 0.3]}}},
        'joints': {'pivot': {'type': 'hinge', 'parent': 'pylon', 'child': 'store',
                             'anchor': [-0.3292, 0, -0.25], 'axis': [0, 1, 0],
                             'release': {'angle_deg': 10}}}}
    metrics = {'distance': [{'bodies': ['store', 'pylon'], 'from': {'release': 'pivot'}}]}
    rows = []
    for rate in (200, 5000):
        folder = tmp_path / str(rate)
        folder.mkdir()
        path = write_sweep(folder, runs=1, vary={}, metrics=metrics,
                           scenario=scenario, rate_hz=rate)
        rows.append(run_one(load_sweep(path), 0))
        assert rows[-1]['status'] == 'ok', rows[-1]['message']
    coarse, dense = rows
    # the dense run's least sample is within (speed x 0.1 ms)^2 / distance of the true least
    assert coarse['distance_store_pylon_min'] == pytest.approx(
        dense['distance_store_pylon_min'], abs=2e-6)
    assert coarse['distance_store_pylon_min_time'] == pytest.approx(
        dense['distance_store_pylon_min_time'], abs=2e-4)


def test_the_rate_bound_holds_on_the_interpolant_and_is_not_loose():
    # random cubic Hermite data, jumps between the end rates included: the kernel's bound on
    # each interval's speed (a point at the CG of a body, the other at rest at the origin)
    # against the speed of the interpolant evaluated densely
    from cfem_ros.core import _kernel
    from cfem_ros.core.native.kernel import TRACK
    rng = np.random.default_rng(7)
    time = np.cumsum(rng.uniform(0.001, 0.01, 41))
    value, rate = rng.normal(size=(41, 3)), rng.normal(scale=50.0, size=(41, 3))
    moving, still = np.zeros((41, TRACK.WIDTH)), np.zeros((41, TRACK.WIDTH))
    moving[:, TRACK.span('T_POSITION')], moving[:, TRACK.span('T_VELOCITY')] = value, rate
    bound = _kernel.testing.interval_rates(time, moving, still, 0.0, 0.0)
    s = np.linspace(0.0, 1.0, 2001)[:, None, None]
    h = np.diff(time)[None, :, None]
    speed = (6 * s * s - 6 * s) * (value[:-1] - value[1:]) / h \
        + (3 * s * s - 4 * s + 1) * rate[:-1] + (3 * s * s - 2 * s) * rate[1:]
    most = np.linalg.norm(speed, axis=2).max(axis=0)
    assert (most <= bound * (1 + 1e-12)).all()
    assert (most >= 0.5 * bound).all()   # within a factor of 2 of the true largest speed


def test_the_rate_bound_holds_for_points_on_turning_bodies():
    # two bodies moving and turning: a point at the radius on each, the speed of their
    # distance, densely on the interpolant, within the bound
    from cfem_ros.core import _kernel, rotations
    from cfem_ros.study.between import track
    rng = np.random.default_rng(11)
    time = np.cumsum(rng.uniform(0.002, 0.005, 11))
    tracks, radius = [], (0.7, 1.6)
    for _ in range(2):
        quaternion = rng.normal(size=(11, 4))
        quaternion /= np.linalg.norm(quaternion, axis=1)[:, None]
        rates = rng.normal(scale=4.0, size=(11, 3))
        tracks.append(track(rng.normal(size=(11, 3)), quaternion, rng.normal(size=(11, 3)) * 9,
                            rates))
    bound = _kernel.testing.interval_rates(time, tracks[0], tracks[1], *radius)
    for k in range(len(time) - 1):
        t = np.linspace(time[k], time[k + 1], 401)
        gaps = []
        for direction in rng.normal(size=(4, 2, 3)):
            ends = []
            for side in range(2):
                pose = np.array([_kernel.testing.track_pose(time, tracks[side], k, float(x))
                                 for x in t])
                point = direction[side] / np.linalg.norm(direction[side]) * radius[side]
                ends.append(pose[:, :3] + rotations.matrices(pose[:, 3:]) @ point)
            gaps.append(np.linalg.norm(ends[0] - ends[1], axis=1))
        speed = np.abs(np.diff(gaps, axis=1)).max() / (t[1] - t[0])
        assert speed <= bound[k]


def test_a_dip_between_two_samples_far_from_the_least_sample_is_found():
    """A narrow dip the samples miss: the rate bound must leave its interval to search."""
    from cfem_ros.core import _kernel
    from scipy.optimize import minimize_scalar
    depth, width, centre = 0.8, 0.0008, 0.5025    # between the samples at 0.500 and 0.505

    def distance(t):
        t = np.asarray(t, dtype=float)
        return 1.0 + t - depth * np.exp(-((t - centre) / width) ** 2)

    time = np.arange(0.0, 1.0 + 1e-9, 0.005)
    sampled = distance(time)
    assert np.argmin(sampled) == 0 and sampled.min() == 1.0   # the dip is not sampled
    # a true bound on |d'| per interval: 1 + depth x the Gaussian's steepest slope within
    # the interval (sqrt(2/e) / width at its steepest; far off, its value at the nearer end)
    lo, hi = time[:-1], time[1:]
    gap = np.maximum(np.maximum(lo - centre, centre - hi), 0.0) / width
    steepest = np.where(gap < 1 / np.sqrt(2), np.sqrt(2 / np.e), 2 * gap * np.exp(-gap ** 2))
    rates = 1.0 + depth * steepest / width
    probed = set()

    def evaluate(k, t):
        probed.add(k)
        return float(distance(t))

    value, when = _kernel.testing.least_between(time, sampled, rates, 0.0, 1.0, evaluate)
    reference = minimize_scalar(distance, bounds=(0.500, 0.505), method='bounded',
                                options={'xatol': 1e-13})
    assert value == pytest.approx(reference.fun, abs=1e-9)
    assert when == pytest.approx(reference.x, abs=1e-6)
    assert value < 0.71
    assert probed <= {0, 99, 100, 101}, sorted(probed)   # the rest pruned by the bound
    # a window that closes before the dip: the least sample stands
    assert _kernel.testing.least_between(time, sampled, rates, 0.0, 0.5, evaluate) == (1.0, 0.0)
