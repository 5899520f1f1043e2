# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The kernel's formulas Python calls outside a step are the step's own, and right.

``kernel.relative_states``, ``dynamic_pressure``, ``shape_reach`` and
``bounding_radius`` (``cpp/recorded.cpp``) are the functions the sample, the
aerodynamic wrench and the contact rows use; Python keeps no copy of them.
Each is checked against an independent reference (scipy's rotations, the
closed forms of the shapes) and against what the kernel itself writes.
"""

import pathlib

from cfem_ros import load_scenario, Simulator
from cfem_ros.core.model.shapes import Shape
from cfem_ros.core.native import contacts, kernel
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

ROOT = pathlib.Path(__file__).resolve().parents[2]
SAMPLE = kernel.SAMPLE


def _states(rng, k):
    """Return k random (position, velocity, quaternion (any norm), rates) of a body."""
    quat = rng.normal(size=(k, 4)) * rng.uniform(0.5, 2.0, size=(k, 1))
    return (rng.normal(size=(k, 3)), rng.normal(size=(k, 3)), quat, rng.normal(size=(k, 3)))


def test_relative_states_match_scipy():
    rng = np.random.default_rng(46)
    k = 200
    body, ref = _states(rng, k), _states(rng, k)
    out = kernel.relative_states(*body, *ref)
    assert out.shape == (k, SAMPLE.BODY)
    (p, v, q, w), (pr, vr, qr, wr) = body, ref
    turn, turn_ref = Rotation.from_quat(q), Rotation.from_quat(qr)
    omega, omega_ref = turn.apply(w), turn_ref.apply(wr)   # world
    d = p - pr
    seen = v - vr - np.cross(omega_ref, d)   # the CG velocity seen from the reference
    np.testing.assert_allclose(out[:, SAMPLE.span('O_POSITION')], turn_ref.inv().apply(d),
                               rtol=0, atol=1e-13)
    np.testing.assert_allclose(out[:, SAMPLE.span('O_VELOCITY')], turn_ref.inv().apply(seen),
                               rtol=0, atol=1e-13)
    np.testing.assert_allclose(out[:, SAMPLE.span('O_RATES')],
                               turn_ref.inv().apply(omega - omega_ref), rtol=0, atol=1e-13)
    relative = out[:, SAMPLE.span('O_QUATERNION')]
    np.testing.assert_allclose(np.linalg.norm(relative, axis=1), 1.0, rtol=0, atol=1e-15)
    expected = (turn_ref.inv() * turn).as_quat()
    assert np.allclose(np.abs(np.sum(relative * expected, axis=1)), 1.0, rtol=0, atol=1e-14)


def test_relative_states_are_what_a_sample_holds():
    sim = Simulator(load_scenario(str(ROOT / 'config' / 'store_release_two_hooks.yaml')))
    assert sim.model.references
    assert sim.advance_to(0.3)
    out = sim.outputs()
    count = len(sim.model.references)
    held = out[len(out) - SAMPLE.BODY * count:].reshape(count, SAMPLE.BODY)
    # the same function: the same bits (references in body order in both)
    np.testing.assert_array_equal(held, sim.relative_states())


def test_dynamic_pressure_is_half_rho_v_squared():
    rho, v = np.array([1.225, 0.4, 0.0, 1e-3]), np.array([100.0, 250.0, 30.0, 0.0])
    np.testing.assert_allclose(kernel.dynamic_pressure(rho, v), 0.5 * rho * v * v,
                               rtol=1e-15, atol=0)
    assert float(kernel.dynamic_pressure(1.225, 100.0)) == pytest.approx(6125.0, rel=1e-15)
    grid = kernel.dynamic_pressure(rho[:, None], v[None, :])
    assert grid.shape == (4, 4)


@pytest.mark.parametrize('shape, reach', [
    (Shape('sphere', (0.3,)), 0.3),
    (Shape('capsule', (0.2, 2.0)), 1.0),
    (Shape('box', (1.0, 2.0, 2.0)), 1.5),
    (Shape('cylinder', (0.4, 0.6)), 0.5),
])
def test_a_shapes_reach_and_bounding_radius_are_the_closed_forms(shape, reach):
    packed = contacts.pack_shape(shape)
    assert kernel.shape_reach(packed) == pytest.approx(reach, rel=1e-15)
    assert kernel.bounding_radius(packed) == pytest.approx(reach, rel=1e-15)
    moved = Shape(shape.kind, shape.size, (3.0, 0.0, 4.0))   # 5 m from the CG
    assert contacts.bounding_radius(contacts.pack_shape(moved)) == pytest.approx(
        5.0 + reach, rel=1e-15)


def test_a_compounds_bounding_radius_is_its_farthest_part():
    parts = (Shape('sphere', (0.5,), (0.0, 2.0, 0.0)),
             Shape('box', (2.0, 2.0, 1.0), (-3.0, 0.0, 0.0)))
    packed = contacts.pack_shape(Shape('compound', (), parts=parts))
    assert kernel.bounding_radius(packed) == pytest.approx(3.0 + 1.5, rel=1e-15)
    hull = Shape('mesh', (), hull=((1.0, 2.0, 2.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0),
                                   (0.0, 0.0, 1.0)))
    assert kernel.shape_reach(contacts.pack_shape(hull)) == pytest.approx(3.0, rel=1e-15)


def test_the_formulas_refuse_arrays_of_the_wrong_shape():
    rng = np.random.default_rng(1)
    body = _states(rng, 3)
    with pytest.raises(ValueError, match='ref_quaternion'):
        kernel.relative_states(*body, *body[:2], np.zeros((3, 3)), body[3])
    with pytest.raises(ValueError, match='broadcast'):
        kernel.dynamic_pressure(np.ones(3), np.ones(2))
    with pytest.raises(ValueError, match='shape'):
        kernel.bounding_radius(np.zeros(5))
    compound = contacts.pack_shape(Shape('compound', (), parts=(Shape('sphere', (1.0,)),)))
    with pytest.raises(ValueError, match='convex'):
        kernel.shape_reach(compound)
