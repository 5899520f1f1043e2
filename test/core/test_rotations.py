# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Euler angles without scipy: the same bits as scipy's Rotation, gimbal lock included."""

import warnings

from cfem_ros.core import rotations
import numpy as np
from scipy.spatial.transform import Rotation


def test_from_rpy_deg_is_scipys():
    rng = np.random.default_rng(5)
    angles = np.concatenate([rng.uniform(-400, 400, (4000, 3)),
                             rng.integers(-360, 361, (2000, 3)).astype(float),
                             [[0, 90, 0], [0, -90, 0], [0, 0, 0]]])
    for roll, pitch, yaw in angles:
        expected = Rotation.from_euler('ZYX', [yaw, pitch, roll], degrees=True).as_quat()
        assert np.array_equal(rotations.from_rpy_deg([roll, pitch, yaw]), expected)


def test_to_rpy_deg_is_scipys_small_and_large():
    rng = np.random.default_rng(6)
    quats = np.concatenate([rng.normal(size=(6000, 4)),
                            [rotations.from_rpy_deg([10, 90, 30]),      # gimbal lock
                             rotations.from_rpy_deg([10, -90, 30]),
                             [0, 0, 0, 1], [0, 0, 0, -1], [1, 0, 0, 0], [0, 0, 1, 0]]])
    with warnings.catch_warnings():
        warnings.filterwarnings('ignore', message='Gimbal lock detected')
        expected = Rotation.from_quat(quats).as_euler('ZYX', degrees=True)[:, ::-1]
    small = np.concatenate([rotations.to_rpy_deg(quats[i:i + rotations.SMALL])
                            for i in range(0, len(quats), rotations.SMALL)])
    assert np.array_equal(small, expected)                 # computed here, no scipy
    assert np.array_equal(rotations.to_rpy_deg(quats), expected)   # scipy, vectorized
    assert rotations.to_rpy_deg(quats[0]).shape == (3,)
