# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The model: what a run needs (``Model``), built once from a scenario; its parts are data."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from cfem_ros.core.errors import ArgumentError
from cfem_ros.core.model.graph import carriers
import numpy as np

#: Standard gravity, m/s^2.
STANDARD_GRAVITY = 9.80665

#: Baumgarte gain times dt used when the scenario gives none (eta = 0.02 / dt).
DEFAULT_BAUMGARTE_DT = 0.02

#: RK4's stability limit for the stabilized constraint error, eta * dt.
BAUMGARTE_DT_LIMIT = 2.8


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
    start_ns : int
        The stamp of simulated time 0 in a recording of ``cfem-sim run``,
        ns since 1970-01-01T00:00:00Z (scenario ``start_time``; 0 if none).
    load_scale : float or None
        The viewers' load arrows' scale, N per m of arrow (scenario
        ``load_scale``: 1, 2 or 5 times a power of ten); None: from the
        scenario's loads at t = 0 (``recording.loadarrows``).

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
    start_ns: int = 0
    load_scale: Optional[float] = None

    def body_index(self, name: str) -> int:
        """Return the index of the body called name (ValueError if none)."""
        for i, body in enumerate(self.bodies):
            if body.name == name:
                return i
        raise ArgumentError(f'no body named {name!r}')

    def carrier(self, body: int) -> int:
        """
        Return the kinematic body that body's joints lead to (-1 if none).

        Through any number of other bodies: a store on a pylon fixed to a
        moving aircraft is carried by the aircraft. The nearest one (fewest
        joints away), the first joint's first when several are as near.
        Linear in the bodies and joints; ``graph.carriers`` gives every
        body's at the same cost.
        """
        return carriers(self.bodies, self.joints)[body]

    def joint_index(self, name: str) -> int:
        """Return the index of the joint called name (ValueError if none)."""
        for i, joint in enumerate(self.joints):
            if joint.name == name:
                return i
        raise ArgumentError(f'no joint named {name!r}')


def default_baumgarte(dt: float) -> float:
    """Return the Baumgarte gain used when a scenario gives none, 1/s."""
    return DEFAULT_BAUMGARTE_DT / dt
