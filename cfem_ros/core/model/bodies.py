# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The bodies: mass properties, initial state, shape, and a kinematic body's motion."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

from cfem_ros.core.model.shapes import Shape
import numpy as np


@dataclass(frozen=True)
class Motion:
    """
    The prescribed trajectory of a kinematic body (scenario ``motion``).

    Attributes
    ----------
    velocity : ndarray, shape (3,)
        Constant CG velocity, world axes, m/s (without a table); with
        ``velocity_body``, the velocity at t = 0.
    rates : ndarray, shape (3,)
        Constant angular velocity, body axes, rad/s (without a table).
    times : ndarray, shape (k,)
        Table times, s, increasing; empty for constant motion.
    positions : ndarray, shape (k, 3)
        Table CG positions, world, m.
    quaternions : ndarray, shape (k, 4)
        Table attitudes, x y z w, body to world.
    velocity_body : ndarray, shape (3,), or None
        A steady manoeuvre (scenario ``flight``): the CG velocity constant in
        the body's axes, m/s, turning with the body at its constant ``rates``.

    """

    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rates: np.ndarray = field(default_factory=lambda: np.zeros(3))
    times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    positions: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    quaternions: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    velocity_body: Optional[np.ndarray] = None


@dataclass(frozen=True)
class Body:
    """
    A rigid body and its state at t = 0.

    Attributes
    ----------
    name : str
    fixed : bool
        A ground body: never moves, mass and inertia unused.
    mass : float
        kg.
    inertia : ndarray, shape (3, 3)
        kg m^2 about the CG, body axes.
    position : ndarray, shape (3,)
        CG in world, m.
    orientation_xyzw : ndarray, shape (4,)
        Unit quaternion, body to world, scalar last.
    velocity_world : ndarray, shape (3,)
        CG velocity, world axes, m/s.
    rates_body : ndarray, shape (3,)
        Angular velocity (P, Q, R), body axes, rad/s.
    shape : Shape or None
        What viewers draw (``shapes.Shape``); None: ``shapes.default_shape``.
    motion : Motion or None
        A kinematic body: follows this trajectory, forces ignored (its
        mass and inertia unused; position and attitude at t = 0 from it).
    velocity_given : bool
        False when the scenario gave this body no velocity: joined to a
        kinematic body, it then starts moving rigidly with it.
    cg_offset : ndarray, shape (3,)
        Where the CG is relative to the nominal CG, body axes, m (SPEC
        section 10). ``position`` is the actual CG; everything given in the
        body's axes from the CG (wrench points, the shape, the aero reference
        point) is held here from the actual CG (moved by -cg_offset).

    """

    name: str
    fixed: bool
    mass: float
    inertia: np.ndarray
    position: np.ndarray
    orientation_xyzw: np.ndarray
    velocity_world: np.ndarray
    rates_body: np.ndarray
    shape: Optional[Shape] = None
    motion: Optional[Motion] = None
    velocity_given: bool = True
    cg_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def dynamic(self) -> bool:
        """Return True for a body moved by forces (neither fixed nor kinematic)."""
        return not self.fixed and self.motion is None
