# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Inputs (external wrenches, odometry, release commands): what they are, when they apply.

An ``Input`` is checked (``validate_input``) and applied (``apply_input``)
through the simulator's own input methods: ``set_wrench``, ``release`` and its
carriers' ``set_odometry``. ``InputQueue`` holds those whose time is still
ahead until it comes.
"""

from __future__ import annotations

from dataclasses import dataclass
import heapq
import itertools
from typing import Optional

from cfem_ros.core.engine.events import TextEnum
from cfem_ros.core.errors import ArgumentError
from cfem_ros.core.native.kernel import ODOMETRY
import numpy as np


class InputKind(TextEnum):
    """What an input is (``Input.kind``): its text is the topic's last word but for release."""

    WRENCH = 'wrench'
    RELEASE = 'release'
    ODOM = 'odom'


@dataclass(frozen=True)
class Input:
    """
    One input message: an external wrench or a release command.

    Attributes
    ----------
    time : float or None
        Simulated time at which it takes effect, s; None: as soon as it is
        received.
    kind : InputKind
        ``WRENCH``, ``RELEASE`` or ``ODOM``.
    target : str
        The body (wrench), or the joints and release groups (release: one
        name, or several separated by spaces or commas) it names.
    force, torque : ndarray, shape (3,), or None
        N and N m (wrench only).
    frame_id : str
        The world frame (world axes) or the body (body axes); wrench only.
        ``<frame>@x,y,z`` applies the force at the point (x, y, z), body
        axes, from the CG, m (``parse_frame_id``); without it, at the CG.
        The world frame wins if the body has the world frame's name.
    header_ns : int or None
        The message's own header stamp as received, ns (wrench and odom).
    values : ndarray, shape (``ODOMETRY.WIDTH``,), or None
        Odometry (REP-105), laid out as ``ODOMETRY`` (``odometry_parts``):
        position (world), quaternion x y z w, CG velocity and angular
        velocity (body axes); ``frame_id`` is the message's, the body its
        ``child_frame_id`` names by topic.
    at : float or None
        Odometry that came late (stamped before the simulated time it took
        effect at): its own time, s. The body then moves as the message,
        extrapolated from that time, says it is now; the message was not
        known ahead, so no cubic led to it (``InputQueue``).

    """

    time: Optional[float]
    kind: InputKind
    target: str
    force: Optional[np.ndarray] = None
    torque: Optional[np.ndarray] = None
    frame_id: str = ''
    header_ns: Optional[int] = None
    values: Optional[np.ndarray] = None
    at: Optional[float] = None


def wrench_input(body: str, force, torque, frame_id: str, *, time: Optional[float] = None,
                 header_ns: Optional[int] = None) -> Input:
    """Build an external wrench input (arrays copied as floats)."""
    return Input(time=time, kind=InputKind.WRENCH, target=body,
                 force=np.array(force, dtype=float), torque=np.array(torque, dtype=float),
                 frame_id=frame_id, header_ns=header_ns)


#: The parts of an odometry input's values (``ODOMETRY``), in the order
#: ``odometry_input`` and ``Carriers.set_odometry`` take them.
ODOMETRY_PARTS = ('D_POSITION', 'D_QUATERNION', 'D_VELOCITY', 'D_RATES')


def odometry_input(body: str, position, quaternion, velocity, rates, frame_id: str, *,
                   time: Optional[float] = None, header_ns: Optional[int] = None) -> Input:
    """Build an odometry input (nav_msgs/Odometry: twist in the body's axes)."""
    values = np.empty(ODOMETRY.WIDTH)
    for name, part in zip(ODOMETRY_PARTS, (position, quaternion, velocity, rates)):
        values[ODOMETRY.span(name)] = np.asarray(part, dtype=float)
    return Input(time=time, kind=InputKind.ODOM, target=body, frame_id=frame_id,
                 header_ns=header_ns, values=values)


def odometry_parts(values: np.ndarray) -> tuple:
    """Return an odometry input's position, quaternion, velocity and rates (views of values)."""
    return tuple(values[ODOMETRY.span(name)] for name in ODOMETRY_PARTS)


def release_input(joint: str, *, time: Optional[float] = None) -> Input:
    """Build a release command."""
    return Input(time=time, kind=InputKind.RELEASE, target=joint)


def parse_frame_id(frame_id: str):
    """
    Split a wrench's ``frame_id`` into the axes' frame and the application point.

    ``store@0.1798,0,0`` -> ('store', array([0.1798, 0, 0])); ``store`` ->
    ('store', None). ValueError if the point is not three finite numbers.
    """
    frame, at, point = frame_id.partition('@')
    if not at:
        return frame, None
    try:
        values = np.array([float(v) for v in point.split(',')])
    except ValueError:
        values = np.array([])
    if values.shape != (3,) or not np.isfinite(values).all():
        raise ArgumentError(f'frame_id {frame_id!r}: the point after @ is not three finite '
                            'numbers x,y,z (body axes, from the CG, m)')
    return frame, values


#: Largest force, torque, point or odometry number an input may carry (a scenario's bound).
MAX_INPUT_MAGNITUDE = 1e9
#: Latest header stamp, ns: a ROS Time's seconds are an int32.
MAX_STAMP_NS = (2 ** 31 - 1) * 1_000_000_000 + 999_999_999


def stamp_problem(header_ns: Optional[int]) -> Optional[str]:
    """Return why a header stamp is no ROS time (None if it is, or if there is none)."""
    if header_ns is None or 0 <= header_ns <= MAX_STAMP_NS:
        return None
    return (f'header stamp {header_ns} ns is not a ROS time (expected 0 to 2^31 - 1 s, '
            'nanoseconds below 1e9)')


def _bounded(values, what: str):
    if np.max(np.abs(values)) > MAX_INPUT_MAGNITUDE:
        raise ArgumentError(f'{what} must be at most {MAX_INPUT_MAGNITUDE:g} in magnitude, as '
                            'in a scenario')


def input_topic(item: Input) -> str:
    """Topic of an input, relative to the namespace."""
    if item.kind is InputKind.ODOM:
        return f'bodies/{item.target}/odom'
    return 'release' if item.kind is InputKind.RELEASE else f'bodies/{item.target}/wrench'


def validate_input(sim, item: Input):
    """
    Check that an input can take effect on sim now.

    Raises
    ------
    ValueError
        With the reason: unknown body, frame or joint, a fixed body,
        non-finite numbers, a joint already released.

    """
    model = sim.model
    if item.kind is InputKind.RELEASE:
        # joints or release groups, one or several (groups.command_names)
        sim.groups.check_command(item.target, sim.active)
        return
    stamp = stamp_problem(item.header_ns)
    if stamp:
        raise ArgumentError(stamp)
    names = [body.name for body in model.bodies]
    if item.target not in names:
        raise ArgumentError(f'unknown body {item.target!r} (bodies: {", ".join(names)})')
    if item.kind is InputKind.ODOM:
        if model.bodies[names.index(item.target)].motion is None:
            raise ArgumentError(f'body {item.target!r} is not kinematic (no motion): odometry '
                                'drives only kinematic bodies')
        if item.frame_id != model.frame_id:
            raise ArgumentError(f'odometry frame_id {item.frame_id!r} is not the world frame '
                                f'{model.frame_id!r}')
        if item.values is None or not np.isfinite(item.values).all():
            raise ArgumentError('odometry must be finite numbers')
        _bounded(item.values, 'odometry numbers')
        norm = np.linalg.norm(item.values[ODOMETRY.span('D_QUATERNION')])
        if abs(norm - 1.0) > 1e-3:
            raise ArgumentError(f'odometry quaternion has norm {norm:.6g}; expected a unit '
                                'quaternion (to 1e-3)')
        return
    frame, _ = parse_frame_id(item.frame_id)
    if frame not in (model.frame_id, item.target):
        raise ArgumentError(f'frame_id {item.frame_id!r} is neither the world frame '
                            f'{model.frame_id!r} nor the body {item.target!r} (optionally '
                            'followed by @x,y,z, the point in body axes)')
    if not (np.isfinite(item.force).all() and np.isfinite(item.torque).all()):
        raise ArgumentError('force and torque must be finite')
    _bounded(np.concatenate([item.force, item.torque]), 'force (N) and torque (N m)')
    _, point = parse_frame_id(item.frame_id)
    if point is not None:
        _bounded(point, 'the point after @ (m)')
    body = model.bodies[names.index(item.target)]
    if not body.dynamic:
        what = 'fixed' if body.fixed else 'kinematic'
        raise ArgumentError(f'body {item.target!r} is {what} and cannot be loaded')


def apply_input(sim, item: Input):
    """Apply one input now (ValueError with the reason if it cannot be)."""
    validate_input(sim, item)
    if item.kind is InputKind.ODOM:
        # from now: the time it takes effect (a sample's at most); a late one: its own time
        at = sim.t if item.at is None else min(item.at, sim.t)
        sim.carriers.set_odometry(item.target, at, *odometry_parts(item.values))
        return
    if item.kind is InputKind.WRENCH:
        # the world frame wins: a body named as the world frame is loaded in world axes
        frame, point = parse_frame_id(item.frame_id)
        sim.set_wrench(item.target, item.force, item.torque,
                       body_axes=(frame != sim.model.frame_id), point=point)
    else:
        sim.release(item.target, cause='command')


class InputQueue:
    """
    Inputs held until their time: taken in time order, then in the order held.

    Parameters
    ----------
    sim : Simulator
        The simulator they are for.
    interpolate_odometry : bool
        An odometry input held for a later time is made known to the
        simulator's carriers at once (``Carriers.expect_odometry``), so that
        the body moves on the cubic from its previous message to it.

    """

    def __init__(self, sim, *, interpolate_odometry: bool = True):
        self.sim = sim
        self.interpolate_odometry = bool(interpolate_odometry)
        self._heap = []
        self._order = itertools.count()

    @property
    def next_time(self) -> Optional[float]:
        """Return the time of the earliest input held, s (None: none)."""
        return self._heap[0][0] if self._heap else None

    def hold(self, item: Input, time: float):
        """Hold an input until the simulated time ``time``."""
        self._expect(item)
        heapq.heappush(self._heap, (time, next(self._order), item))

    def due(self, t: float, kind: Optional[InputKind] = None):
        """Take out the inputs held for t or before, in order (only those of ``kind`` if given)."""
        if kind is not None:
            taken = sorted(e for e in self._heap if e[0] <= t and e[2].kind is kind)
            if taken:
                self._heap = [entry for entry in self._heap if entry not in taken]
                heapq.heapify(self._heap)
            for entry in taken:
                yield entry[2]
            return
        while self._heap and self._heap[0][0] <= t:
            yield heapq.heappop(self._heap)[2]

    def _expect(self, item: Input):
        """Make an odometry input held for later known to the simulator (interpolation)."""
        if not (self.interpolate_odometry and item.kind is InputKind.ODOM and item.time is not None
                and item.time > self.sim.t and item.at is None):
            return
        try:
            validate_input(self.sim, item)
        except ValueError:
            return   # refused, with a warning, when its time comes
        self.sim.carriers.expect_odometry(item.target, item.time, *odometry_parts(item.values))
