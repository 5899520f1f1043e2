# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The model: bodies, joints and the joint table, built once from a scenario."""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Optional

from cfem_ros.core.model.shapes import Shape
import numpy as np

#: Standard gravity, m/s^2.
STANDARD_GRAVITY = 9.80665

#: Baumgarte gain times dt used when the scenario gives none (eta = 0.02 / dt).
DEFAULT_BAUMGARTE_DT = 0.02

#: RK4's stability limit for the stabilized constraint error, eta * dt.
BAUMGARTE_DT_LIMIT = 2.8


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
class Motion:
    """
    The prescribed trajectory of a kinematic body (scenario ``motion``).

    Attributes
    ----------
    velocity : ndarray, shape (3,)
        Constant CG velocity, world axes, m/s (without a table).
    rates : ndarray, shape (3,)
        Constant angular velocity, body axes, rad/s (without a table).
    times : ndarray, shape (k,)
        Table times, s, increasing; empty for constant motion.
    positions : ndarray, shape (k, 3)
        Table CG positions, world, m.
    quaternions : ndarray, shape (k, 4)
        Table attitudes, x y z w, body to world.

    """

    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rates: np.ndarray = field(default_factory=lambda: np.zeros(3))
    times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    positions: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    quaternions: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))


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


@dataclass(frozen=True)
class Contact:
    """
    A pair of bodies whose shapes are watched for contact (scenario ``contacts``).

    Attributes
    ----------
    bodies : tuple of int
        The two bodies (a, b), as the scenario lists them.
    stop : bool
        True: a run ends at the first contact (status ``contact``); False:
        it goes on and the event and the penetration are recorded.

    """

    bodies: tuple
    stop: bool = True


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
        Unit vector, body axes: the pad pushes the body along it.
    preload, stiffness, damping : float
        N at t = 0, N/m, N s/m.

    """

    name: str
    body: int
    carrier: int
    point: np.ndarray
    direction: np.ndarray
    preload: float
    stiffness: float
    damping: float = 0.0


@dataclass(frozen=True)
class Model:
    """
    Everything needed to simulate a scenario; built once, never mutated.

    Attributes
    ----------
    name : str
    frame_id : str
        Name of the world frame.
    gravity : ndarray, shape (3,)
        World axes, m/s^2.
    duration : float
        Run length of ``cfem-sim run``, s.
    dt : float
        RK4 step, s.
    baumgarte : float
        Baumgarte gain eta, 1/s.
    bodies : tuple of Body
    joints : tuple of Joint
    wrenches : tuple of Wrench
        Scheduled loads (SPEC section 5), none by default.
    aero : tuple of Aero
        Aerodynamic loads from coefficient tables, none by default.
    contacts : tuple of Contact
        Pairs of bodies whose shapes are watched, none by default.
    references : tuple of (int, int)
        (body, reference body) pairs whose relative pose and twist are
        sampled: bodies joined to a kinematic one, or given ``reference``.
    release_groups : tuple of ReleaseGroup
        Joints released together, none by default.
    braces : tuple of SwayBrace
        One-sided preloaded pads (``SwayBrace``), none by default.

    """

    name: str
    frame_id: str
    gravity: np.ndarray
    duration: float
    dt: float
    baumgarte: float
    bodies: tuple
    joints: tuple
    wrenches: tuple = ()
    aero: tuple = ()
    references: tuple = ()
    release_groups: tuple = ()
    contacts: tuple = ()
    braces: tuple = ()

    def body_index(self, name: str) -> int:
        """Return the index of the body called name (ValueError if none)."""
        for i, body in enumerate(self.bodies):
            if body.name == name:
                return i
        raise ValueError(f'no body named {name!r}')

    def carrier(self, body: int) -> int:
        """
        Return the kinematic body that body's joints lead to (-1 if none).

        Through any number of other bodies: a store on a pylon fixed to a
        moving aircraft is carried by the aircraft. The nearest one (fewest
        joints away), the first joint's first when several are as near.
        """
        seen, front = {body}, [body]
        while front:
            after = []
            for here in front:
                for joint in self.joints:
                    if here not in (joint.parent, joint.child):
                        continue
                    other = joint.child if joint.parent == here else joint.parent
                    if other in seen:
                        continue
                    if self.bodies[other].motion is not None:
                        return other
                    seen.add(other)
                    after.append(other)
            front = after
        return -1

    def joint_index(self, name: str) -> int:
        """Return the index of the joint called name (ValueError if none)."""
        for i, joint in enumerate(self.joints):
            if joint.name == name:
                return i
        raise ValueError(f'no joint named {name!r}')


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


def default_baumgarte(dt: float) -> float:
    """Return the Baumgarte gain used when a scenario gives none, 1/s."""
    return DEFAULT_BAUMGARTE_DT / dt
