# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The bodies at the start: their state vector, and their mass properties as the kernel reads them.

Fixed and kinematic bodies are carried with zero inverse mass and inertia, so
every formula of the kernel is the same for all bodies; a kinematic body's
trajectory follows in the same row (``motion.columns``, added by the engine).
"""

from __future__ import annotations

import math

from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.native.kernel import BODIES, state_block
import numpy as np


def initial_state(model) -> np.ndarray:
    """
    Return the state vector y at t = 0 (``engine`` module docstring: its layout).

    CG positions (world, m), CG velocities (world, m/s), quaternions (x, y,
    z, w, body to world), angular velocities (body axes, rad/s), each in one
    block of all bodies.
    """
    bodies = model.bodies
    return np.concatenate([
        np.concatenate([b.position for b in bodies]),
        np.concatenate([b.velocity_world for b in bodies]),
        np.concatenate([b.orientation_xyzw for b in bodies]),
        np.concatenate([b.rates_body for b in bodies]),
    ]).astype(float)


def state_views(y: np.ndarray, n: int):
    """Return views (position, velocity, quaternion, rates) of the state of n bodies (STATE)."""
    return tuple(state_block(y, n, name)
                 for name in ('Y_POSITION', 'Y_VELOCITY', 'Y_QUATERNION', 'Y_RATES'))


def mass_table(model):
    """
    Return which bodies move freely and their mass properties, one row per body.

    Returns
    -------
    free : ndarray of bool, shape (n,)
        The bodies that move under loads (neither fixed nor kinematic).
    table : ndarray, shape (n, 20)
        Mass (kg), inverse mass, inertia about the CG in body axes (kg m^2, 9,
        row-major) and its inverse (9); zeros for the bodies that are not free.

    Raises
    ------
    ScenarioError
        If a free body's inverse mass or inertia is not a finite number.

    """
    bodies = model.bodies
    n = len(bodies)
    free = np.array([b.dynamic for b in bodies])
    mass = np.array([b.mass if b.dynamic else 0.0 for b in bodies])
    inv_mass = np.where(free, 1.0 / np.where(free, mass, 1.0), 0.0)
    inertia_body = np.array([b.inertia if b.dynamic else np.zeros((3, 3)) for b in bodies])
    inv_inertia_body = np.array([
        np.linalg.inv(b.inertia) if b.dynamic else np.zeros((3, 3)) for b in bodies])
    _check_inverses(model, inv_mass, inv_inertia_body)
    table = np.empty((n, BODIES.BODY_COLUMNS))
    table[:, BODIES.B_MASS], table[:, BODIES.B_INV_MASS] = mass, inv_mass
    table[:, BODIES.span('B_INERTIA')] = inertia_body.reshape(n, 9)
    table[:, BODIES.span('B_INV_INERTIA')] = inv_inertia_body.reshape(n, 9)
    return free, table


def _check_inverses(model, inv_mass, inv_inertia_body):
    """Refuse a body whose inverse mass or inertia is not a finite number."""
    for i, body in enumerate(model.bodies):
        if not body.dynamic:
            continue
        if not math.isfinite(inv_mass[i]):
            raise ScenarioError(
                f'model {model.name!r}', f'bodies.{body.name}.mass',
                f'is {body.mass:g} kg, whose inverse is not a finite number',
                'a mass of at least 1e-300 kg')
        if not np.isfinite(inv_inertia_body[i]).all():
            raise ScenarioError(
                f'model {model.name!r}', f'bodies.{body.name}.inertia',
                'has an inverse that is not a finite number',
                'principal moments of at least 1e-300 kg m^2')
