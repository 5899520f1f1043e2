# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The applied loads a model describes: scheduled wrenches, aerodynamic tables, sway braces."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np


@dataclass(frozen=True)
class Wrench:
    """
    A scheduled load on a body (scenario ``wrenches``, SPEC section 5).

    Attributes
    ----------
    name : str
        The load source (``bodies/<body>/applied/<name>``).
    body : int
        The body it acts on.
    point : ndarray, shape (3,)
        Application point, body axes, from the CG, m.
    force, moment : ndarray, shape (3,)
        N and N m in ``frame``'s axes (constant loads; zero with a table).
    frame : int
        Axes of force and moment: -1 the world, else a body.
    start : float
        s; with ``start_release``, s after that release.
    end : float or None
        s; None: never; with ``end_release``, s after that release.
    stroke : float or None
        m: the load acts while the point has moved less than this.
    reacts_on : int
        The body that takes the opposite load at the same world point; -1 none.
    table : ndarray, shape (k, 7)
        Rows of abscissa, force (3) and moment (3); empty for a constant load.
    table_against : str or None
        'time' (s from start) or 'stroke' (m), None without a table.
    start_release, end_release : str or None
        A joint's or a release group's name: ``start`` (``end``) is then a
        delay after its release (SPEC section 7); None: a time.

    """

    name: str
    body: int
    point: np.ndarray
    force: np.ndarray
    moment: np.ndarray
    frame: int = -1
    start: float = 0.0
    end: Optional[float] = None
    stroke: Optional[float] = None
    reacts_on: int = -1
    table: np.ndarray = field(default_factory=lambda: np.zeros((0, 7)))
    table_against: Optional[str] = None
    start_release: Optional[str] = None
    end_release: Optional[str] = None


@dataclass(frozen=True)
class Proximity:
    """
    Interference increments near a carrier (scenario ``aero.<body>.proximity``).

    Attributes
    ----------
    carrier : int
        The body whose axes the grid is in.
    axes : tuple of str
        The grid's axes, a subset of ``dx, dy, dz`` (m, the CG in the
        carrier's axes relative to where it was at t = 0), ``dphi_deg,
        dtheta_deg, dpsi_deg`` (Z-Y-X attitude relative to the carrier's, deg)
        and ``mach``, in that order.
    grids : tuple of ndarray
        Each axis's values, increasing, in the axis's unit.
    increments : ndarray, shape (len(grid) per axis ..., 6)
        dCX, dCY, dCZ, dCl, dCm, dCn at each grid point (scale applied).
    fade : float or None
        m: beyond the grid (along the position axes) the increments fade
        linearly to zero over this distance; None: held at the grid's edge.
    source : str
        The table's file.

    """

    carrier: int
    axes: tuple
    grids: tuple
    increments: np.ndarray
    fade: Optional[float]
    source: str = ''


@dataclass(frozen=True)
class Aero:
    """
    Aerodynamic loads on a body from coefficient tables (scenario ``aero``).

    Attributes
    ----------
    body : int
    area, length : float
        Reference area (m^2) and length (m).
    density : float
        Air density, kg/m^3: given, or ISA at ``altitude``.
    freestream : ndarray, shape (3,)
        Velocity of the air (``wind`` or ``freestream``), world axes, m/s.
    alpha, beta : ndarray
        Grid of angles of attack and sideslip, rad, increasing.
    coefficients : ndarray, shape (len(alpha), len(beta), len(mach), 6)
        CX, CY, CZ (body axes forces) and Cl, Cm, Cn (moments about the CG).
    damping : ndarray, shape (3,)
        Clp, Cmq, Cnr, per unit of p L / (2 V), q L / (2 V), r L / (2 V).
    mach : ndarray
        Grid of Mach numbers, increasing (one node: no Mach dependence).
    altitude : float or None
        ISA altitude of the world origin, m; a body's altitude adds its
        height above the origin along -gravity. None: ``density`` is fixed.
    proximity : Proximity or None
        Interference increments near a carrier.
    temperature_offset : float
        K added to the ISA temperature (a hot or cold day); pressure ISA.
    reference_point : ndarray, shape (3,)
        The point the moment coefficients are about, body axes, from the
        nominal CG, m (as given).
    reference_from_cg : ndarray, shape (3,)
        The same from the actual CG (``reference_point - cg_offset``).
    delta : ndarray, shape (6,)
        Added to CX .. Cn after interpolation (and after ``scale``).
    stop_outside : bool
        True: the run stops where the body leaves a table's range
        (``outside: stop``); False: the tables are held at their edges.
    zero : tuple of str
        The coefficients the scenario says are zero (``zero``), as given.

    """

    body: int
    area: float
    length: float
    density: float
    freestream: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    coefficients: np.ndarray
    damping: np.ndarray
    mach: np.ndarray = field(default_factory=lambda: np.zeros(1))
    altitude: Optional[float] = None
    proximity: Optional[Proximity] = None
    temperature_offset: float = 0.0
    reference_point: np.ndarray = field(default_factory=lambda: np.zeros(3))
    reference_from_cg: np.ndarray = field(default_factory=lambda: np.zeros(3))
    delta: np.ndarray = field(default_factory=lambda: np.zeros(6))
    stop_outside: bool = False
    zero: tuple = ()


@dataclass(frozen=True)
class SwayBrace:
    """
    A one-sided preloaded spring-damper between a body and its carrier.

    Attributes
    ----------
    name : str
        The load's source name (``bodies/<body>/applied/<name>``).
    body, carrier : int
        The body the pad pushes, the body it is mounted on.
    point : ndarray, shape (3,)
        The contact point at t = 0, body axes from the CG, m.
    direction : ndarray, shape (3,)
        Unit vector, body axes at t = 0: the pad pushes the body along it;
        from then on the pad's axis is fixed in the carrier's axes.
    preload, stiffness, damping : float
        N at t = 0, N/m, N s/m.
    pad_radius : float
        m: the pad touches only where the body's point lies within this
        distance of its axis.

    """

    name: str
    body: int
    carrier: int
    point: np.ndarray
    direction: np.ndarray
    preload: float
    stiffness: float
    damping: float = 0.0
    pad_radius: float = 0.05
