# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Quaternion arithmetic on stacks of quaternions (x, y, z, w; body to world)."""

from __future__ import annotations

import math
import warnings

import numpy as np

#: Up to this many attitudes ``to_rpy_deg`` computes them itself (a run's summary,
#: without importing scipy); more go to scipy, vectorized. Both give the same bits.
SMALL = 64


#: The rotation matrix of a unit quaternion (x, y, z, w), entry by entry, row by row:
#: 1 - 2 (a + b) on the diagonal, 2 (a +- b) off it, a and b products of two components.
_MATRIX = ('1-2(yy+zz)', '2(xy-wz)', '2(xz+wy)',
           '2(xy+wz)', '1-2(xx+zz)', '2(yz-wx)',
           '2(xz-wy)', '2(yz+wx)', '1-2(xx+yy)')


def _matrix_terms(entries):
    """Return the flat indices (into q_i q_j, 4 x 4) of each entry's a and b, and b's signs."""
    index = {name: k for k, name in enumerate('xyzw')}
    terms = [entry.split('(')[1].rstrip(')') for entry in entries]
    first = [4 * index[term[0]] + index[term[1]] for term in terms]
    second = [4 * index[term[3]] + index[term[4]] for term in terms]
    signs = [1.0 if term[2] == '+' else -1.0 for term in terms]
    return np.array(first), np.array(second), np.array(signs)


_FIRST, _SECOND, _SIGN = _matrix_terms(_MATRIX)
_DIAGONAL = np.array([k for k, entry in enumerate(_MATRIX) if entry.startswith('1-')])


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
    # the nine entries (``_MATRIX``) in a few whole-stack operations, not nine: a run
    # computes many small stacks. The same bits as entry by entry: products commute
    # exactly, and a - b is a + (-1) b in floating point
    products = (q[:, :, None] * q[:, None, :]).reshape(-1, 16)
    # C order, as callers expect: numpy's matrix products round differently on other layouts
    out = np.ascontiguousarray(2.0 * (products[:, _FIRST] + _SIGN * products[:, _SECOND]))
    out[:, _DIAGONAL] = 1.0 - out[:, _DIAGONAL]
    return out.reshape(-1, 3, 3)


def to_body(quat_xyzw: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """World-axis vectors (n, 3) in the axes of bodies at the attitudes quat_xyzw (n, 4)."""
    return np.einsum('nji,nj->ni', matrices(quat_xyzw), vectors)


#: The Hamilton product a * b, component by component (x, y, z, w): four products
#: a_i b_j each, added and subtracted left to right.
_PRODUCT = ('wx+xw+yz-zy', 'wy-xz+yw+zx', 'wz+xy-yx+zw', 'ww-xx-yy-zz')


def _product_terms(components):
    """Return the flat indices (into a_i b_j, 4 x 4) of each component's terms, and signs."""
    index = {name: k for k, name in enumerate('xyzw')}
    terms = [('+' + c[:2], c[2:5], c[5:8], c[8:]) for c in components]
    flat = [[4 * index[t[1]] + index[t[2]] for t in row] for row in terms]
    signs = [[1.0 if t[0] == '+' else -1.0 for t in row] for row in terms]
    return np.array(flat), np.array(signs)


_TERMS, _TERM_SIGNS = _product_terms(_PRODUCT)


def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products a * b of two stacks of quaternions, shape (..., 4)."""
    a, b = np.asarray(a), np.asarray(b)
    # in a few whole-stack operations (``_PRODUCT``), with the bits of the term-by-term
    # sums: products commute exactly, and u - v is u + (-1) v in floating point
    products = a[..., :, None] * b[..., None, :]
    terms = products.reshape(products.shape[:-2] + (16,))[..., _TERMS] * _TERM_SIGNS
    # C order, as callers expect (numpy's matrix products round differently on other layouts)
    return np.ascontiguousarray(terms[..., 0] + terms[..., 1] + terms[..., 2] + terms[..., 3])


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
    # scipy's Rotation.from_euler('ZYX', [yaw, pitch, roll], degrees=True).as_quat(),
    # operation for operation (the same bits), without importing scipy
    roll, pitch, yaw = roll_pitch_yaw_deg
    angles = np.deg2rad(np.asarray([yaw, pitch, roll], dtype=float))
    q = [0.0, 0.0, math.sin(angles[0] / 2), math.cos(angles[0] / 2)]
    for axis, angle in ((1, angles[1]), (0, angles[2])):
        e = [0.0, 0.0, 0.0, math.cos(angle / 2)]
        e[axis] = math.sin(angle / 2)
        q = [q[3] * e[0] + e[3] * q[0] + (q[1] * e[2] - q[2] * e[1]),
             q[3] * e[1] + e[3] * q[1] + (q[2] * e[0] - q[0] * e[2]),
             q[3] * e[2] + e[3] * q[2] + (q[0] * e[1] - q[1] * e[0]),
             q[3] * e[3] - q[0] * e[0] - q[1] * e[1] - q[2] * e[2]]
    return np.array(q)


def to_rpy_deg(quat_xyzw: np.ndarray) -> np.ndarray:
    """
    Z-Y-X Euler angles (roll, pitch, yaw), deg, of quaternions, shape (..., 3).

    At pitch = +-90 deg roll and yaw are not unique; scipy's convention then
    puts the whole rotation about the vertical into yaw (without its "gimbal
    lock" warning: callers that care test the pitch themselves).
    """
    q = np.asarray(quat_xyzw, dtype=float)
    flat = q.reshape(-1, 4)
    if len(flat) <= SMALL:
        zyx = np.rad2deg(np.array([_zyx(*row) for row in flat.tolist()]).reshape(-1, 3))
    else:
        from scipy.spatial.transform import Rotation
        with warnings.catch_warnings():
            warnings.filterwarnings('ignore', message='Gimbal lock detected')
            zyx = Rotation.from_quat(flat).as_euler('ZYX', degrees=True)
    return zyx[:, ::-1].reshape(q.shape[:-1] + (3,))


def _zyx(x, y, z, w):
    """Z-Y-X angles (rad) of one quaternion as scipy's as_euler('ZYX') computes them."""
    # scipy's from_quat normalization and Bernardes & Viollet (2022) conversion, with
    # libm's hypot (np.hypot; math.hypot rounds differently) and atan2 (math.atan2)
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if norm == 0:
        raise ValueError('Found zero norm quaternions in `quat`.')
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    a, b, c, d = w - y, x + z, y + w, z - x
    pitch = 2 * math.atan2(float(np.hypot(c, d)), float(np.hypot(a, b)))
    half_sum, half_diff = math.atan2(b, a), math.atan2(d, c)
    if abs(pitch) <= 1e-7:
        angles = [2 * half_sum, pitch, 0.0]
    elif abs(pitch - math.pi) <= 1e-7:
        angles = [2 * half_diff, pitch, 0.0]
    else:
        angles = [half_sum + half_diff, pitch, half_sum - half_diff]
    angles[1] -= math.pi / 2
    for k in range(3):
        if angles[k] < -math.pi:
            angles[k] += 2 * math.pi
        elif angles[k] > math.pi:
            angles[k] -= 2 * math.pi
    return angles


def angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles of the rotations taking attitudes a to attitudes b, rad in [0, pi], shape (...)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    return rotation_angle(multiply(conjugate(a), b))
