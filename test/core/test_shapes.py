# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The drawn box of a body without a shape: turned as scipy turns it, to the bit."""

from cfem_ros.core.model import shapes
import numpy as np
import pytest
from scipy.spatial.transform import Rotation


def bits(values):
    """Return the bytes of a sequence of float64, to compare numbers bit for bit."""
    return np.asarray(values, dtype=float).tobytes()


def scipy_quaternion(matrix):
    """Return scipy's quaternion (x, y, z, w) of a rotation matrix, as floats."""
    return tuple(float(v) for v in Rotation.from_matrix(matrix).as_quat())


def principal_axes(inertia):
    """Return the right-handed principal axes of an inertia, as equivalent_box makes them."""
    axes = np.linalg.eigh(inertia)[1]
    if np.linalg.det(axes) < 0:
        axes[:, 2] *= -1.0
    return axes


def test_principal_axes_give_scipys_quaternion_bit_for_bit():
    rng = np.random.default_rng(7)
    for trial in range(3000):
        a = rng.normal(size=(3, 3))
        inertia = (np.diag(rng.uniform(0.1, 500.0, 3)) if trial % 3 == 0
                   else a @ a.T + rng.uniform(0.0, 2.0) * np.eye(3))
        axes = principal_axes(inertia)
        assert bits(shapes._quaternion_of(axes)) == bits(scipy_quaternion(axes)), inertia


@pytest.mark.parametrize('branch', range(4))
def test_every_branch_matches_scipy(branch):
    # the formula is picked by the largest of the diagonal (0, 1, 2) and the trace (3)
    rng = np.random.default_rng(branch)
    seen = 0
    for q in rng.normal(size=(4000, 4)):
        matrix = Rotation.from_quat(q).as_matrix()
        diagonal = [matrix[0, 0], matrix[1, 1], matrix[2, 2], np.trace(matrix)]
        if int(np.argmax(diagonal)) != branch:
            continue
        seen += 1
        assert bits(shapes._quaternion_of(matrix)) == bits(scipy_quaternion(matrix))
    assert seen > 100


def test_a_matrix_scipy_orthogonalizes_goes_to_scipy():
    matrix = Rotation.from_euler('ZYX', [30.0, -20.0, 10.0], degrees=True).as_matrix()
    for scale in (1.0 + 1e-9, 1.0 + 1e-6):
        assert bits(shapes._quaternion_of(matrix * scale)) == bits(
            scipy_quaternion(matrix * scale))


def test_the_equivalent_box_of_a_store_is_its_principal_axes():
    # a slender store along x, turned 30 deg in yaw: the box's long edge follows x turned
    turned = Rotation.from_euler('z', 30.0, degrees=True).as_matrix()
    inertia = turned @ np.diag([27.1164, 488.0944, 488.0944]) @ turned.T
    box = shapes.equivalent_box(907.1848, inertia)
    long_edge = int(np.argmax(box.size))
    axis = Rotation.from_quat(box.orientation_xyzw).as_matrix()[:, long_edge]
    assert abs(abs(axis @ turned[:, 0]) - 1.0) < 1e-12
