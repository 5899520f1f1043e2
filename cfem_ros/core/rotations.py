# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Quaternion arithmetic on stacks of quaternions (x, y, z, w; body to world)."""

from __future__ import annotations

import warnings

import numpy as np
from scipy.spatial.transform import Rotation


def matrices(quat_xyzw: np.ndarray) -> np.ndarray:
    """
    Rotation matrices of a stack of quaternions, normalizing them.

    Parameters
    ----------
    quat_xyzw : ndarray, shape (n, 4)
        Quaternions, scalar last, of any non-zero norm.

    Returns
    -------
    ndarray, shape (n, 3, 3)
        Body-to-world matrices: v_world = R @ v_body.

    """
    q = quat_xyzw / np.sqrt(np.einsum('ij,ij->i', quat_xyzw, quat_xyzw))[:, None]
    x, y, z, w = q.T
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    out = np.empty((q.shape[0], 3, 3))
    out[:, 0, 0] = 1 - 2 * (yy + zz)
    out[:, 0, 1] = 2 * (xy - wz)
    out[:, 0, 2] = 2 * (xz + wy)
    out[:, 1, 0] = 2 * (xy + wz)
    out[:, 1, 1] = 1 - 2 * (xx + zz)
    out[:, 1, 2] = 2 * (yz - wx)
    out[:, 2, 0] = 2 * (xz - wy)
    out[:, 2, 1] = 2 * (yz + wx)
    out[:, 2, 2] = 1 - 2 * (xx + yy)
    return out


def to_body(quat_xyzw: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """World-axis vectors (n, 3) in the axes of bodies at the attitudes quat_xyzw (n, 4)."""
    return np.einsum('nji,nj->ni', matrices(quat_xyzw), vectors)


def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products a * b of two stacks of quaternions, shape (..., 4)."""
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack([
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ], axis=-1)


def conjugate(q: np.ndarray) -> np.ndarray:
    """Conjugates (inverse rotations of unit quaternions), shape (..., 4)."""
    out = np.array(q, dtype=float, copy=True)
    out[..., :3] *= -1.0
    return out


def rate_of_change(quat_xyzw: np.ndarray, rates_body: np.ndarray) -> np.ndarray:
    """Quaternion derivatives dq/dt = q * (w_body, 0) / 2, shape (n, 4)."""
    pure = np.zeros_like(quat_xyzw)
    pure[:, :3] = rates_body
    return 0.5 * multiply(quat_xyzw, pure)


def rotation_angle(q: np.ndarray) -> np.ndarray:
    """Angles of rotation of unit quaternions, rad in [0, pi], shape (...)."""
    vector = np.linalg.norm(q[..., :3], axis=-1)
    return 2.0 * np.arctan2(vector, np.abs(q[..., 3]))


def from_rpy_deg(roll_pitch_yaw_deg) -> np.ndarray:
    """Quaternion (x, y, z, w) of Z-Y-X Euler angles: yaw, then pitch, then roll."""
    roll, pitch, yaw = roll_pitch_yaw_deg
    return Rotation.from_euler('ZYX', [yaw, pitch, roll], degrees=True).as_quat()


def to_rpy_deg(quat_xyzw: np.ndarray) -> np.ndarray:
    """
    Z-Y-X Euler angles (roll, pitch, yaw), deg, of quaternions, shape (..., 3).

    At pitch = +-90 deg roll and yaw are not unique; scipy's convention then
    puts the whole rotation about the vertical into yaw (without its "gimbal
    lock" warning: callers that care test the pitch themselves).
    """
    q = np.asarray(quat_xyzw, dtype=float)
    with warnings.catch_warnings():
        warnings.filterwarnings('ignore', message='Gimbal lock detected')
        zyx = Rotation.from_quat(q.reshape(-1, 4)).as_euler('ZYX', degrees=True)
    return zyx[:, ::-1].reshape(q.shape[:-1] + (3,))


def angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles of the rotations taking attitudes a to attitudes b, rad in [0, pi], shape (...)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    return rotation_angle(multiply(conjugate(a), b))
