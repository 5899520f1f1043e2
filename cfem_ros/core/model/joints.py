# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The joints: the joint table (each type its constraint rows), joints, triggers, groups."""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Optional

import numpy as np


@dataclass(frozen=True)
class JointRows:
    """
    The constraint rows of one joint type (paper Table 1, CFEM.md).

    Axes are indices into the joint's triad (u1, u2, u3), u1 = the joint axis.

    Attributes
    ----------
    translation : tuple of int
        Directions u_k along which the joint point may not move (primitive 1).
        The other directions carry no force (primitive 4).
    rotation : tuple of (int, int)
        Pairs (i, k) keeping u_i on the parent perpendicular to u_k on the
        child (primitive 2 with lambda = 90 deg, which stays regular where
        lambda = 0 is singular). Rotation about the remaining directions is
        free and carries no moment (primitive 3).
    dof : (int, int)
        Translational and rotational degrees of freedom the joint leaves.

    """

    translation: tuple
    rotation: tuple
    dof: tuple


_LOCK_ALL = ((0, 1), (1, 2), (2, 0))
_KEEP_U1 = ((0, 1), (0, 2))

#: The seven joint types as data: which rows each one contributes.
JOINT_TABLE = {
    'fixed': JointRows((0, 1, 2), _LOCK_ALL, (0, 0)),
    'hinge': JointRows((0, 1, 2), _KEEP_U1, (0, 1)),
    'universal': JointRows((0, 1, 2), ((0, 1),), (0, 2)),
    'ball': JointRows((0, 1, 2), (), (0, 3)),
    'slider': JointRows((1, 2), _LOCK_ALL, (1, 0)),
    'planar': JointRows((0,), _KEEP_U1, (2, 1)),
    'cylindrical': JointRows((1, 2), _KEEP_U1, (1, 1)),
}

#: Joint types whose ``axis`` must be given.
AXIS_REQUIRED = frozenset({'hinge', 'universal', 'slider', 'planar', 'cylindrical'})


@dataclass(frozen=True)
class Release:
    """
    Release triggers of a joint; the first one reached releases it.

    ``None`` disables a trigger. Units: s, rad, m, N.
    """

    time: Optional[float] = None
    angle: Optional[float] = None
    distance: Optional[float] = None
    force: Optional[float] = None


@dataclass(frozen=True)
class Joint:
    """
    A joint between a parent body (A) and a child body (B).

    Attributes
    ----------
    name : str
    kind : str
        The joint type (the scenario's ``type``), one of ``JOINT_TABLE``.
    parent, child : int
        Body indices.
    anchor : ndarray, shape (3,)
        The joint point in world at t = 0, m.
    triad : ndarray, shape (3, 3)
        Rows u1, u2, u3: orthonormal, right-handed, world axes at t = 0;
        u1 is the joint axis; for a universal joint u2 is the child's axis.
    release : Release
        Its own triggers, or those of its release group.
    compliance : ndarray or None
        Per constrained row, in the order of the rows (translations, m/N,
        then rotations, rad/(N m)): weights the split of loads on redundant
        rows (``groups.row_weights``); None: least norm.

    """

    name: str
    kind: str
    parent: int
    child: int
    anchor: np.ndarray
    triad: np.ndarray
    release: Release = field(default_factory=Release)
    compliance: Optional[np.ndarray] = None

    @property
    def rows(self) -> JointRows:
        """Return the rows of this joint's type."""
        return JOINT_TABLE[self.kind]


@dataclass(frozen=True)
class ReleaseGroup:
    """
    Joints that let go in one instant (scenario ``release_groups``, SPEC section 7).

    Attributes
    ----------
    name : str
    joints : tuple of int
        Its joints; each one's ``release`` is the group's.
    release : Release
        The group's triggers; a condition is met when any joint meets it.

    """

    name: str
    joints: tuple
    release: Release = field(default_factory=Release)


def triad_from_axes(axis, axis2=None) -> np.ndarray:
    """
    Build the orthonormal triad (u1, u2, u3) of a joint.

    Parameters
    ----------
    axis : array_like, shape (3,)
        u1, any length > 0.
    axis2 : array_like, shape (3,), optional
        u2 (universal joints), perpendicular to axis. Without it, u2 is the
        world axis least aligned with u1, made perpendicular.

    Returns
    -------
    ndarray, shape (3, 3)
        Rows u1, u2, u3 with u3 = u1 x u2.

    """
    if (axis2 is None and type(axis) is np.ndarray and axis.dtype == np.float64
            and axis.shape == (3,) and axis.flags.c_contiguous):
        triad = _triad_of(axis)
        if triad is not None:
            return triad
    u1 = np.asarray(axis, dtype=float)
    u1 = u1 / np.linalg.norm(u1)
    if axis2 is None:
        helper = np.zeros(3)
        helper[int(np.argmin(np.abs(u1)))] = 1.0
        u2 = helper - u1 * (helper @ u1)
    else:
        u2 = np.asarray(axis2, dtype=float)
        u2 = u2 - u1 * (u2 @ u1)
    u2 = u2 / np.linalg.norm(u2)
    return np.array([u1, u2, np.cross(u1, u2)])


def _triad_of(axis: np.ndarray) -> Optional[np.ndarray]:
    """
    Return ``triad_from_axes(axis)`` of a contiguous float64 3-vector, to the bit.

    The same floating-point operations in the same order, on Python floats
    where numpy would spend longer dispatching than computing: each norm is
    the square root of the same ``ndarray.dot`` ``np.linalg.norm`` takes,
    the helper's dot product is the exact u1[j] (its other terms are zeros),
    the cross product is ``np.cross``'s a1 b2 - a2 b1, a2 b0 - a0 b2, a0 b1 - a1 b0.
    None if the axis's norm is zero or not finite (numpy's path then gives what it gives).
    """
    norm = math.sqrt(axis.dot(axis))
    if not 0.0 < norm < math.inf:
        return None
    x, y, z = axis.tolist()
    u1 = [x / norm, y / norm, z / norm]
    size = [abs(u1[0]), abs(u1[1]), abs(u1[2])]
    j = size.index(min(size))   # np.argmin: the first of equal smallest
    along = u1[j]
    u2 = [0.0 - u1[0] * along, 0.0 - u1[1] * along, 0.0 - u1[2] * along]
    u2[j] = 1.0 - u1[j] * along
    u2 = np.array(u2)
    norm = math.sqrt(u2.dot(u2))
    a0, a1, a2 = u1
    b0, b1, b2 = u2.tolist()
    b0, b1, b2 = b0 / norm, b1 / norm, b2 / norm
    return np.array([u1, [b0, b1, b2],
                     [a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0]])
