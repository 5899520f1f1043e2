# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A recorded run as numpy arrays: a ``Run``, a ``BodyTrack`` per body, a ``JointTrack`` per load.

What ``analysis.open_run`` returns; the Euler angles made continuous
(``euler_continuous``) for plots.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from cfem_ros.core import rotations
from cfem_ros.core.engine.events import Event
import numpy as np


#: Near pitch +-90 deg roll and yaw are each undefined (only their sum or
#: difference is): a body whose roll or yaw moves more than this (deg) from
#: one sample to the next, and ten times more than the body turns, is shown
#: with a quaternion instead of Euler angles.
EULER_JUMP_DEG = 10.0


@dataclass
class BodyTrack:
    """
    One body's recorded motion; arrays have one row per pose sample.

    Attributes
    ----------
    name : str
    time : ndarray (n,)
        s from the run's start.
    stamp_ns : ndarray (n,) of int64
        The samples' stamps.
    position : ndarray (n, 3)
        CG in the world frame, m.
    quaternion : ndarray (n, 4)
        Body-to-world attitude, x, y, z, w.
    euler_deg : ndarray (n, 3)
        Roll, pitch, yaw in degrees, Z-Y-X (yaw first); pitch within +-90 deg,
        roll and yaw within +-180 deg (they flip by 180 deg when pitch passes
        +-90 deg).
    euler_continuous_deg : ndarray (n, 3)
        The same attitudes as continuous angles: pitch may go past +-90 deg
        (a tumbling store's pitch keeps growing) and no angle jumps by 360.
    rates : ndarray (n, 3)
        Body rates p, q, r, rad/s (NaN where no twist matches a pose).
    velocity : ndarray (n, 3)
        CG velocity in body axes (u, v, w), m/s, as published.
    velocity_world : ndarray (n, 3)
        CG velocity in world axes, m/s.

    """

    name: str
    time: np.ndarray
    stamp_ns: np.ndarray
    position: np.ndarray
    quaternion: np.ndarray
    euler_deg: np.ndarray
    euler_continuous_deg: np.ndarray
    rates: np.ndarray
    velocity: np.ndarray
    velocity_world: np.ndarray

    @property
    def euler_singular(self) -> bool:
        """
        Tell whether the Euler angles misrepresent the motion near pitch +-90 deg.

        True when roll or yaw moves by more than ``EULER_JUMP_DEG`` between two
        samples and by more than ten times the angle the body turned between
        them (a pure pitch through 90 deg keeps its roll and yaw and is fine).
        """
        if len(self.time) < 2:
            return False
        turned = np.degrees(rotations.angle_between(self.quaternion[:-1], self.quaternion[1:]))
        moved = np.abs(np.diff(self.euler_continuous_deg[:, [0, 2]], axis=0)).max(axis=1)
        return bool(np.any((moved > EULER_JUMP_DEG) & (moved > 10.0 * turned)))

    @property
    def quaternion_continuous(self) -> np.ndarray:
        """Return the attitudes as quaternions whose sign never jumps (q, -q: one attitude)."""
        q = np.array(self.quaternion, dtype=float, copy=True)
        if len(q) > 1:
            flips = np.einsum('ij,ij->i', q[1:], q[:-1]) < 0.0
            sign = np.concatenate([[1.0], np.where(np.cumsum(flips) % 2, -1.0, 1.0)])
            q *= sign[:, None]
        return q

    @property
    def moves(self) -> bool:
        """Tell whether the body changes position or attitude during the run."""
        return bool(np.ptp(self.position, axis=0).max(initial=0.0) > 0.0
                    or np.ptp(self.quaternion, axis=0).max(initial=0.0) > 0.0)


@dataclass
class JointTrack:
    """
    One joint's recorded load on its child, while it was active.

    Attributes
    ----------
    name : str
    time : ndarray (n,)
        s from the run's start.
    stamp_ns : ndarray (n,) of int64
    force : ndarray (n, 3)
        N, world axes.
    moment : ndarray (n, 3)
        N m about the joint point, world axes.

    """

    name: str
    time: np.ndarray
    stamp_ns: np.ndarray
    force: np.ndarray
    moment: np.ndarray


@dataclass
class RelativeTrack:
    """
    One body's recorded pose and twist in its reference's (carrier's) frame.

    Attributes
    ----------
    name, reference : str
        The body and the frame (``frame_id``) its numbers are in.
    time : ndarray (n,)
        s from the run's start.
    position : ndarray (n, 3)
        CG relative to the reference's CG, reference axes, m.
    quaternion : ndarray (n, 4)
        Attitude relative to the reference, x y z w.
    velocity, rates : ndarray (n, 3)
        CG velocity seen from the reference (m/s) and angular velocity
        relative to it (rad/s), reference axes; NaN where no twist matches.

    """

    name: str
    reference: str
    time: np.ndarray
    position: np.ndarray
    quaternion: np.ndarray
    velocity: np.ndarray
    rates: np.ndarray


@dataclass
class Run:
    """
    A recording, read.

    Attributes
    ----------
    path : str
    namespace : str
        The topics' prefix, e.g. '/cfem'.
    start_ns : int
        Stamp of t = 0.
    bodies : dict of str to BodyTrack
        In the order the recording first names them.
    joints : dict of str to JointTrack
    events : list of dict
        Decoded JSON events: releases (``{'event', 'joint', 'time', 'cause'}``,
        ``'group'`` for a release group's joints) and stroke ends
        (``stroke_ends``).
    topics : dict of str to (str, int)
        Every topic in the file: (message type, message count).
    metadata : dict of str to str
        The ``cfem_ros`` metadata record, if any.
    duration : float
        Seconds from the start to the last sample.
    applied : dict of str to JointTrack
        Scheduled loads (``bodies/<body>/applied/<source>``) by '<body>/<source>':
        force and moment about the body's CG, world axes.
    relative : dict of str to RelativeTrack
        Poses and twists in a carrier's frame (``bodies/<body>/relative_pose``).
    joint_frame : dict of str to JointTrack
        Joint loads as published on ``joints/<joint>/wrench``: in the joint's
        frame (the child's axes), moment about the joint point.

    """

    path: str
    namespace: str
    start_ns: int
    bodies: dict
    joints: dict
    events: list
    topics: dict
    metadata: dict = field(default_factory=dict)
    duration: float = 0.0
    applied: dict = field(default_factory=dict)
    relative: dict = field(default_factory=dict)
    joint_frame: dict = field(default_factory=dict)

    def releases(self) -> list:
        """Return the release events as (time, joint, cause), in time order."""
        return sorted((e['time'], e.get('joint', '?'), e.get('cause', '?'))
                      for e in self.events if e.get('event') == Event.RELEASE and 'time' in e)

    def moving_bodies(self) -> list:
        """Return the bodies that move, in order."""
        return [track for track in self.bodies.values() if track.moves]

    def stroke_ends(self) -> dict:
        """
        Return the end-of-stroke figures by wrench name (SPEC section 7).

        Each is a dict with ``time`` (s), ``velocity`` (u, v, w, m/s) and
        ``rates`` (p, q, r, rad/s) as arrays: the loaded body's CG velocity
        and body rates relative to the wrench's ``reacts_on`` body (the
        world when none), in the loaded body's axes; and ``body`` and
        ``reacts_on`` (None: the world). Wrenches whose stroke never ended
        are absent; of two wrenches of one name (on two bodies), the first.
        """
        out = {}
        for e in self.events:
            if e.get('event') != Event.STROKE_END or 'wrench' not in e:
                continue
            out.setdefault(e['wrench'], {
                'time': float(e['time']), 'body': e.get('body'),
                'reacts_on': e.get('reacts_on'),
                'velocity': np.asarray(e['velocity'], dtype=float),
                'rates': np.asarray(e['rates'], dtype=float)})
        return out


#: (roll + 180, 180 - pitch, yaw + 180) = (roll, pitch, yaw) * this + 180.
_OTHER_TRIPLE = np.array([1.0, -1.0, 1.0])


def euler_continuous(euler_deg: np.ndarray) -> np.ndarray:
    """
    Turn Z-Y-X angles (pitch within +-90 deg) into continuous ones.

    Each attitude has two Z-Y-X triples, (roll, pitch, yaw) and
    (roll + 180, 180 - pitch, yaw + 180); at each sample the one nearest the
    previous sample is kept (the first on a tie), and every angle is
    unwrapped by whole turns. ``euler_deg`` is one history (n, 3) or a
    stack of independent ones (..., n, 3), each turned as if alone.
    """
    out = np.array(euler_deg, dtype=float, copy=True)
    pair = np.empty(out.shape[:-2] + (2, 3))   # a sample's two triples, unwrapped
    for i in range(1, out.shape[-2]):
        prev = out[..., i - 1:i, :]
        pair[..., 0, :] = out[..., i, :]
        np.multiply(out[..., i, :], _OTHER_TRIPLE, out=pair[..., 1, :])
        pair[..., 1, :] += 180.0
        pair += 360.0 * np.round((prev - pair) / 360.0)
        distance = np.abs(pair - prev).sum(axis=-1)
        nearer = (distance[..., 1] < distance[..., 0])[..., None]
        out[..., i, :] = np.where(nearer, pair[..., 1, :], pair[..., 0, :])
    return out
