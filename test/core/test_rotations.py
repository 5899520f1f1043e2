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


def _matrices_entry_by_entry(quat_xyzw):
    """Return the rotation matrices as written out entry by entry (the reference)."""
    q = quat_xyzw / np.sqrt(np.einsum('ij,ij->i', quat_xyzw, quat_xyzw))[:, None]
    x, y, z, w = q.T
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    return np.stack([1 - 2 * (yy + zz), 2 * (xy - wz), 2 * (xz + wy),
                     2 * (xy + wz), 1 - 2 * (xx + zz), 2 * (yz - wx),
                     2 * (xz - wy), 2 * (yz + wx), 1 - 2 * (xx + yy)], axis=-1).reshape(-1, 3, 3)


def _multiply_term_by_term(a, b):
    """Return Hamilton products as written out term by term (the reference)."""
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], axis=-1)


def _quaternions(rng, n):
    """Return random quaternions, signed zeros, exact axes, huge and tiny norms among them."""
    quats = rng.normal(size=(n, 4)) * 10.0 ** rng.integers(-150, 150, (n, 1))
    quats[::7, rng.integers(0, 4)] = 0.0
    quats[::11, rng.integers(0, 4)] = -0.0
    special = [[0, 0, 0, 1], [0, 0, 0, -1], [1, 0, 0, 0], [0, -0.0, 1, 0], [-0.0, 0, 0, 1],
               [0.5, 0.5, 0.5, 0.5], [-0.0, -0.0, -0.0, -1]]
    return np.concatenate([quats, special])


def test_matrices_and_products_have_the_bits_of_the_written_out_formulas():
    rng = np.random.default_rng(12)
    quats = _quaternions(rng, 5000)
    for n in (1, 2, 3, len(quats)):
        got, want = rotations.matrices(quats[:n]), _matrices_entry_by_entry(quats[:n])
        assert got.shape == want.shape == (n, 3, 3)
        assert got.tobytes() == want.tobytes()   # signed zeros included
        assert got.flags.c_contiguous   # numpy's matrix products round by layout
    other = _quaternions(rng, 5000)
    got = rotations.multiply(quats, other)
    assert got.tobytes() == _multiply_term_by_term(quats, other).tobytes()
    assert got.flags.c_contiguous
    # broadcast stacks, one quaternion, and the shapes callers use
    stack = quats[:12].reshape(3, 4, 4)
    for a, b in ((stack, other[0]), (other[:1], stack[0]), (quats[3], other[4]),
                 (stack[:, :1], stack)):
        got, want = rotations.multiply(a, b), _multiply_term_by_term(a, b)
        assert got.shape == want.shape and got.tobytes() == want.tobytes()
        assert got.flags.c_contiguous
