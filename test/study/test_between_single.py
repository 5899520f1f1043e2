# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The search's one-time evaluations in plain floats agree with the vectorized ones."""

from cfem_ros.core import rotations
from cfem_ros.core.model.shapes import Shape
from cfem_ros.core.native import contacts
from cfem_ros.study import between
import numpy as np


def tumbling_motion(seed=3):
    """Return a Motion of a body moving and turning fast, sampled at 100 Hz, and its samples."""
    rng = np.random.default_rng(seed)
    time = np.linspace(0.0, 0.05, 6)
    position = rng.normal(size=(6, 3)) * 2.0
    quaternion = rng.normal(size=(6, 4))
    quaternion /= np.linalg.norm(quaternion, axis=1)[:, None]
    velocity, rates = rng.normal(size=(6, 3)) * 30.0, rng.normal(size=(6, 3)) * 5.0
    return between.Motion(time, position, quaternion, velocity, rates), time


def test_pose_is_the_interpolant_at_one_time():
    motion, time = tumbling_motion()
    for k in range(len(time) - 1):
        for t in np.linspace(time[k], time[k + 1], 7):
            position, quaternion = motion.pose(k, float(t))
            p, q = motion.at(k, [t])
            # the same formulas without numpy's fused products: a few ulp
            np.testing.assert_allclose(position, p[0], rtol=0, atol=1e-13)
            np.testing.assert_allclose(quaternion, q[0], rtol=0, atol=1e-15)
            assert abs(np.linalg.norm(quaternion) - 1.0) < 1e-15


def test_rotation_is_the_matrix_of_the_quaternion():
    rng = np.random.default_rng(7)
    for q in rng.normal(size=(20, 4)):
        q /= np.linalg.norm(q)
        np.testing.assert_allclose(np.reshape(between.rotation(q), (3, 3)),
                                   rotations.matrices(q[None])[0], rtol=0, atol=1e-15)


def test_distance_at_one_pose_is_that_of_distances():
    box = contacts.pack_shape(Shape('box', (3.0, 0.4, 0.4)))
    capsule = contacts.pack_shape(Shape('capsule', (0.2, 2.0), offset=(0.1, 0.0, 0.0)))
    motion, time = tumbling_motion()
    for t in np.linspace(time[0], time[1], 5):
        position, quaternion = motion.pose(0, float(t))
        found = contacts.distance_at(box, between.rotation(quaternion), position,
                                     capsule, np.eye(3).ravel().tolist(), [0.0, 0.0, 0.0])
        expected = contacts.distances(box, np.array([quaternion]), np.array([position]),
                                      capsule, np.array([[0.0, 0.0, 0.0, 1.0]]),
                                      np.zeros((1, 3)))[0][0]
        assert abs(found - expected) < 1e-12


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
