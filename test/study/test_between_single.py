# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The kernel's search between samples against references written here (SPEC section 15)."""

from cfem_ros.core import _kernel, rotations
from cfem_ros.core.model.shapes import Shape
from cfem_ros.core.native import contacts, kernel
from cfem_ros.core.native.kernel import LEAST, TRACK
from cfem_ros.study import between
import numpy as np
import pytest
from scipy.optimize import minimize_scalar

BOX = contacts.pack_shape(Shape('box', (3.0, 0.4, 0.4)))
CAPSULE = contacts.pack_shape(Shape('capsule', (0.2, 2.0), offset=(0.1, 0.0, 0.0)))


def tumbling_track(seed=3, speed=30.0, turn=5.0, spread=2.0):
    """Return the track of a body moving and turning fast, sampled at 100 Hz, and its times."""
    rng = np.random.default_rng(seed)
    time = np.linspace(0.0, 0.05, 6)
    position = rng.normal(size=(6, 3)) * spread
    quaternion = rng.normal(size=(6, 4))
    quaternion /= np.linalg.norm(quaternion, axis=1)[:, None]
    velocity, rates = rng.normal(size=(6, 3)) * speed, rng.normal(size=(6, 3)) * turn
    return between.track(position, quaternion, velocity, rates), time


def hermite(track, time, k, t):
    """Return the pose (7,) at times t of interval k: the cubic Hermite, written here."""
    h = time[k + 1] - time[k]
    s = ((np.atleast_1d(t) - time[k]) / h)[:, None]
    values, rates = track[:, :TRACK.VALUES], track[:, TRACK.RATES:]
    pose = (2 * s ** 3 - 3 * s ** 2 + 1) * values[k] + (s ** 3 - 2 * s ** 2 + s) * h * rates[k] \
        + (-2 * s ** 3 + 3 * s ** 2) * values[k + 1] + (s ** 3 - s ** 2) * h * rates[k + 1]
    pose[:, 3:] /= np.linalg.norm(pose[:, 3:], axis=1)[:, None]
    return pose


def test_the_track_is_the_sample_s_state_and_the_pose_its_hermite_interpolant():
    rng = np.random.default_rng(3)
    position, velocity, rates = rng.normal(size=(2, 3)), rng.normal(size=(2, 3)), \
        rng.normal(size=(2, 3))
    quaternion = np.array([[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, -0.6, -0.8]])
    track = between.track(position, quaternion, velocity, rates)
    # the second quaternion put on the first's side; the velocity turned into world axes
    np.testing.assert_array_equal(track[1, TRACK.span('T_QUATERNION')], [0.0, 0.0, 0.6, 0.8])
    turn = rotations.matrices(np.array([[0.0, 0.0, 0.6, 0.8]]))[0]
    np.testing.assert_allclose(track[1, TRACK.span('T_VELOCITY')], turn @ velocity[1],
                               rtol=0, atol=1e-15)
    # dq/dt = q (w, 0) / 2 at the identity: (w / 2, 0)
    np.testing.assert_allclose(track[0, TRACK.span('T_QUATERNION_RATE')], [*rates[0] / 2, 0.0])
    track, time = tumbling_track()
    for k in range(len(time) - 1):
        for t in np.linspace(time[k], time[k + 1], 7):
            found = _kernel.testing.track_pose(time, track, k, float(t))
            np.testing.assert_allclose(found, hermite(track, time, k, t)[0], rtol=0, atol=1e-13)
            assert abs(np.linalg.norm(found[3:]) - 1.0) < 1e-15


def test_distance_at_one_pose_is_that_of_distances():
    track, time = tumbling_track()
    for t in np.linspace(time[0], time[1], 5):
        pose = hermite(track, time, 0, t)[0]
        found = contacts.distance_at(BOX, rotations.matrices(pose[None, 3:])[0].ravel(),
                                     pose[:3], CAPSULE, np.eye(3).ravel().tolist(),
                                     [0.0, 0.0, 0.0])
        expected = contacts.distances(BOX, pose[None, 3:], pose[None, :3], CAPSULE,
                                      np.array([[0.0, 0.0, 0.0, 1.0]]), np.zeros((1, 3)))[0][0]
        assert abs(found - expected) < 1e-12


def reference_least(distance, time, start, end):
    """Return the least of distance(k, times) over [start, end]: a dense grid, then scipy."""
    best = (np.inf, np.nan)
    for k in range(len(time) - 1):
        lo, hi = max(time[k], start), min(time[k + 1], end)
        if hi <= lo:
            continue
        grid = np.linspace(lo, hi, 401)
        values = distance(k, grid)
        j = int(np.argmin(values))
        if values[j] < best[0]:
            best = (values[j], grid[j])
        a, b = grid[max(j - 1, 0)], grid[min(j + 1, len(grid) - 1)]
        found = minimize_scalar(lambda x: distance(k, a + x)[0], bounds=(0.0, b - a),
                                method='bounded', options={'xatol': 1e-13})
        if found.fun < best[0]:
            best = (found.fun, a + found.x)
    return best


@pytest.mark.parametrize('seed, apart', [(7, 1.2), (22, 2.0), (25, 2.0)])
def test_the_least_of_two_tumbling_shapes_is_the_interpolant_s(seed, apart):
    # two bodies moving and turning fast near each other, apart (a search finds a local
    # least: two shapes overlapping between samples may have several): the kernel's least
    # against a dense grid refined by scipy on the same interpolant (written here)
    track_a, time = tumbling_track(seed, speed=10.0, turn=3.0, spread=0.5)
    track_b, _ = tumbling_track(seed + 10, speed=10.0, turn=3.0, spread=0.5)
    track_b[:, TRACK.T_POSITION + 2] += apart

    def distance(k, t):
        a, b = hermite(track_a, time, k, t), hermite(track_b, time, k, t)
        return contacts.distances(BOX, a[:, 3:], a[:, :3], CAPSULE, b[:, 3:], b[:, :3])[0]

    sampled = np.array([distance(min(k, len(time) - 2), t)[0] for k, t in enumerate(time)])
    start, end = 0.004, 0.05
    found = kernel.least_shape_distance(time, sampled, track_a, track_b, BOX, CAPSULE, start,
                                        end)
    value, when = reference_least(distance, time, start, end)
    assert value > 0.05
    # within the search's tolerance of the interpolant's least, and not below it
    assert found[LEAST.L_DISTANCE] == pytest.approx(value, abs=between.DISTANCE_TOLERANCE)
    assert found[LEAST.L_DISTANCE] >= value - 1e-12
    assert value < sampled[(time >= start) & (time <= end)].min() - 0.01   # between samples
    assert start <= found[LEAST.L_TIME] <= end
    # the poses returned are the interpolant's at that time, and the distance theirs
    k = int(np.searchsorted(time, found[LEAST.L_TIME])) - 1
    pose_a = hermite(track_a, time, k, found[LEAST.L_TIME])[0]
    np.testing.assert_allclose(found[LEAST.span('L_POSE_A')], pose_a, rtol=0, atol=1e-12)
    assert distance(k, found[LEAST.L_TIME])[0] == pytest.approx(found[LEAST.L_DISTANCE],
                                                                abs=1e-12)


def test_the_least_clearance_between_points_is_the_interpolant_s():
    track_a, time = tumbling_track(6, spread=0.3)
    track_b, _ = tumbling_track(7, spread=0.3)
    points_a = np.array([[1.5, 0.0, 0.0], [-1.5, 0.0, 0.0]])
    points_b = np.array([[0.0, 0.0, 0.25], [0.3, -0.2, 0.0]])

    def distance(k, t):
        a, b = hermite(track_a, time, k, t), hermite(track_b, time, k, t)
        world_a = a[:, None, :3] + np.einsum('nij,pj->npi', rotations.matrices(a[:, 3:]),
                                             points_a)
        world_b = b[:, None, :3] + np.einsum('nij,pj->npi', rotations.matrices(b[:, 3:]),
                                             points_b)
        gaps = np.linalg.norm(world_a[:, :, None] - world_b[:, None], axis=3)
        return gaps.reshape(len(gaps), -1).min(axis=1)

    found = kernel.least_point_distance(time, track_a, track_b, points_a, points_b, 0.0, 0.05)
    value, when = reference_least(distance, time, 0.0, 0.05)
    assert found[LEAST.L_DISTANCE] == pytest.approx(value, abs=between.DISTANCE_TOLERANCE)
    assert found[LEAST.L_DISTANCE] >= value - 1e-12
    k = int(np.searchsorted(time, found[LEAST.L_TIME])) - 1
    a = hermite(track_a, time, k, found[LEAST.L_TIME])[0]
    b = hermite(track_b, time, k, found[LEAST.L_TIME])[0]
    i, j = int(found[LEAST.L_POINT_A]), int(found[LEAST.L_POINT_B])
    pair = a[:3] + rotations.matrices(a[None, 3:])[0] @ points_a[i] \
        - b[:3] - rotations.matrices(b[None, 3:])[0] @ points_b[j]
    assert np.linalg.norm(pair) == pytest.approx(found[LEAST.L_DISTANCE], abs=1e-12)


def test_bodies_at_rest_give_their_sample_s_number_to_the_bit():
    time = np.linspace(0.0, 0.05, 6)
    quaternion = np.tile(rotations.from_rpy_deg([10.0, -20.0, 30.0]), (6, 1))
    zero = np.zeros((6, 3))
    track_a = between.track(np.tile([0.1, 0.2, 0.3], (6, 1)), quaternion, zero, zero)
    track_b = between.track(np.tile([0.4, 0.1, 1.2], (6, 1)), quaternion[:, [1, 2, 3, 0]],
                            zero, zero)
    sampled = contacts.distances(BOX, track_a[:, 3:7], track_a[:, :3], CAPSULE,
                                 track_b[:, 3:7], track_b[:, :3])[0]
    assert np.all(sampled == sampled[0]) and sampled[0] > 0.1
    found = kernel.least_shape_distance(time, sampled, track_a, track_b, BOX, CAPSULE, 0.0,
                                        0.05)
    assert (found[LEAST.L_DISTANCE], found[LEAST.L_TIME]) == (sampled[0], 0.0)
    # no tracks: the samples alone, the first least in the window
    found = kernel.least_shape_distance(time, sampled, between.NO_TRACK, between.NO_TRACK,
                                        BOX, CAPSULE, 0.015, 0.05)
    assert (found[LEAST.L_DISTANCE], found[LEAST.L_TIME]) == (sampled[0], time[2])
    assert np.isnan(found[LEAST.span('L_POSE_A')]).all()


def test_a_body_s_motion_is_made_once_per_run_and_the_metrics_are_those_made_afresh():
    from cfem_ros.study import Sweep
    from cfem_ros.study import runs
    from cfem_ros.study.metrics import compute
    import os
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    spec = Sweep.from_file(os.path.join(root, 'config', 'sweeps',
                                        'store_release_near_pylon_sweep.yaml'), runs=3).spec
    kept = []
    compute_run = runs.compute
    runs.compute = lambda samples, metrics: kept.append(samples) or compute_run(samples, metrics)
    try:
        rows = runs.run_rows(spec, range(spec.total))
    finally:
        runs.compute = compute_run
    for samples, row in zip(kept, rows):
        assert set(samples.motions) == {'store', 'pylon', 'wing'}   # its three, once each
        assert between.motion(samples, 'store') is samples.motions['store']
        samples.motions = None   # no cache: every metric makes its own
        afresh = compute(samples, spec.metrics)
        assert afresh.keys() <= row.keys()
        for key, value in afresh.items():
            assert np.array_equal(value, row[key], equal_nan=True) if isinstance(value, float) \
                else value == row[key], key
