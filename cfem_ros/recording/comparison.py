# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Two recorded runs compared quantity by quantity (``cfem-sim compare``).

B is interpolated onto A's times (attitudes by slerp); see ``compare_runs``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from cfem_ros.core import rotations
from cfem_ros.core.native import kernel
from cfem_ros.core.native.kernel import SAMPLE
from cfem_ros.recording.tracks import BodyTrack, Run
import numpy as np
from scipy.spatial.transform import Rotation, Slerp

NAN = float('nan')


@dataclass(frozen=True)
class Difference:
    """The largest difference of one quantity between two runs."""

    quantity: str
    unit: str
    max_abs: float
    at_time: float
    scale: float
    samples: int


def _overlap(t_a, t_b):
    """Tell which of A's times lie inside B's span (a boolean mask; all False if B is empty)."""
    if not len(t_b):
        return np.zeros(len(t_a), dtype=bool)
    return (t_a >= t_b[0] - 1e-12) & (t_a <= t_b[-1] + 1e-12)


def _resampled_difference(t_a, values_a, t_b, values_b):
    """Differences of A and B at A's times inside B's span (B linearly interpolated)."""
    inside = _overlap(t_a, t_b)
    t = t_a[inside]
    ours = values_a[inside]
    theirs = np.column_stack([np.interp(t, t_b, values_b[:, k])
                              for k in range(values_b.shape[1])])
    return t, ours - theirs, ours


def attitude_difference_deg(a: BodyTrack, b: BodyTrack):
    """
    Return A's times inside B's span and the angle from A's attitude to B's there, deg.

    The angle is that of the rotation q_A^-1 q_B, in [0, 180] deg: it has no
    singularity (Euler angles do at pitch +-90 deg). B's attitudes are
    interpolated onto A's times by spherical linear interpolation.
    """
    return _angle_difference_deg(a.time, a.quaternion, b.time, b.quaternion)


def _angle_difference_deg(t_a, q_a, t_b, q_b):
    """Return A's times inside B's span and the angle from q_A to q_B (slerped) there, deg."""
    if not len(t_a) or not len(t_b):
        return np.zeros(0), np.zeros(0)
    inside = _overlap(t_a, t_b)
    t = t_a[inside]
    theirs = np.repeat(q_b[:1], len(t), axis=0)
    if len(t_b) > 1:
        slerp = Slerp(t_b, Rotation.from_quat(q_b))
        theirs = slerp(np.clip(t, t_b[0], t_b[-1])).as_quat()
    # at B's own sample times, B's own attitudes (no interpolation rounding)
    k = np.clip(np.searchsorted(t_b, t), 0, len(t_b) - 1)
    same = t_b[k] == t
    theirs[same] = q_b[k[same]]
    return t, np.degrees(rotations.angle_between(q_a[inside], theirs))


def relative_position(body: BodyTrack, carrier: BodyTrack):
    """
    Return a body's times inside the carrier's span and its CG in the carrier's axes there.

    The carrier's pose is interpolated onto the body's times (position
    linearly, attitude by slerp).
    """
    t, position, _ = relative_pose(body, carrier)
    return t, position


def relative_pose(body: BodyTrack, carrier: BodyTrack):
    """
    Return (times, CG (n, 3) m, attitude (n, 4) x y z w) of a body in a carrier's axes.

    At the body's times inside the carrier's span, the carrier's pose
    interpolated onto them (position linearly, attitude by slerp).
    """
    inside = (body.time >= carrier.time[0] - 1e-12) & (body.time <= carrier.time[-1] + 1e-12)
    t = body.time[inside]
    origin = np.column_stack([np.interp(t, carrier.time, carrier.position[:, k])
                              for k in range(3)])
    if len(carrier.time) > 1:
        turn = Slerp(carrier.time, Rotation.from_quat(carrier.quaternion))(
            np.clip(t, carrier.time[0], carrier.time[-1]))
    else:
        turn = Rotation.from_quat(np.repeat(carrier.quaternion[:1], len(t), axis=0))
    still = np.zeros((len(t), 3))   # the pose only: the kernel's relative state
    out = kernel.relative_states(body.position[inside], still, body.quaternion[inside], still,
                                 origin, still, turn.as_quat().reshape(-1, 4), still)
    return t, out[:, SAMPLE.span('O_POSITION')], out[:, SAMPLE.span('O_QUATERNION')]


def pose_in(run: Run, name: str, reference: str):
    """
    Return (times, CG m, attitude) of body name in reference's axes in a run, or None.

    The run's own relative track when it is in that frame (a recorded
    ``relative_pose``, or a log's pose whose ``frame_id`` is the
    reference), else the two bodies' world poses composed.
    """
    track = run.relative.get(name)
    if track is not None and track.reference == reference:
        return track.time, track.position, track.quaternion
    body, carrier = run.bodies.get(name), run.bodies.get(reference)
    if body is None or carrier is None or not len(carrier.time):
        return None
    return relative_pose(body, carrier)


def compare_runs(a: Run, b: Run, relative_to: Optional[str] = None) -> tuple:
    """
    Compare the bodies and joints two runs share, quantity by quantity.

    B is interpolated linearly onto A's sample times where they differ (only
    inside B's time span: every column, ``max_abs``, ``at_time`` and
    ``scale`` (max |A|), is over these compared times only). A vector's
    difference and scale are its largest component. Quantities:
    ``<body> position`` (m, world axes), ``attitude`` (the angle of the
    rotation from A's attitude to B's, deg; B's quaternions interpolated by
    slerp; scale: A's turn from its first sample), ``rates`` (body axes,
    deg/s), ``velocity`` (CG velocity in body axes u, v, w, m/s);
    ``<joint> force`` (N), ``moment`` (N m),
    ``release`` (time, s); with a carrier in A (``Run.relative``),
    ``<body> position in <carrier> axes`` (m: B's relative track, or B's
    body and carrier poses). With ``relative_to`` a body's, every other
    body's ``position in <relative_to> axes`` (m) and ``attitude in
    <relative_to> axes`` (deg) instead, each run's pose in that frame taken
    as it is given (``pose_in``). Returns (differences, only_in_a, only_in_b), where
    the last two list body and joint names present in one run only, and a
    body's rates and velocity when only one run has its twists.
    """
    rows, missing_a, missing_b = [], [], []

    def add(quantity, unit, t_a, v_a, t_b, v_b):
        t, diff, ours = _resampled_difference(t_a, v_a, t_b, v_b)
        if not len(t):
            rows.append(Difference(quantity, unit, NAN, NAN, NAN, 0))
            return
        magnitude = np.abs(diff).max(axis=1)
        k = int(np.nanargmax(magnitude)) if np.isfinite(magnitude).any() else 0
        rows.append(Difference(quantity, unit, float(magnitude[k]), float(t[k]),
                               float(np.nanmax(np.abs(ours))), len(t)))

    for name, ta in a.bodies.items():
        tb = b.bodies.get(name)
        if tb is None:
            continue
        add(f'{name} position', 'm', ta.time, ta.position, tb.time, tb.position)
        t, angle = attitude_difference_deg(ta, tb)
        if len(t):
            k = int(np.argmax(angle))
            # A's turn from its start, at the compared times only (as every other column)
            turned = rotations.angle_between(ta.quaternion[:1],
                                             ta.quaternion[_overlap(ta.time, tb.time)])
            rows.append(Difference(f'{name} attitude', 'deg', float(angle[k]), float(t[k]),
                                   float(np.degrees(turned.max())), len(t)))
        else:
            rows.append(Difference(f'{name} attitude', 'deg', NAN, NAN, NAN, 0))
        # rates and velocity come from the twists, which a log may not have
        has_a, has_b = not np.isnan(ta.rates).all(), not np.isnan(tb.rates).all()
        if has_a and has_b:
            add(f'{name} rates', 'deg/s', ta.time, np.degrees(ta.rates), tb.time,
                np.degrees(tb.rates))
            add(f'{name} velocity', 'm/s', ta.time, ta.velocity, tb.time, tb.velocity)
        elif has_a != has_b:
            missing = missing_b if has_a else missing_a
            missing += [f'{name} rates (no twist in {"B" if has_a else "A"})',
                        f'{name} velocity (no twist in {"B" if has_a else "A"})']
    for name, ja in a.joints.items():
        jb = b.joints.get(name)
        if jb is None:
            continue
        add(f'{name} force', 'N', ja.time, ja.force, jb.time, jb.force)
        add(f'{name} moment', 'N m', ja.time, ja.moment, jb.time, jb.moment)
    if relative_to is not None:
        _relative_rows(a, b, relative_to, add, rows)
    for name, ra in (a.relative.items() if relative_to is None else ()):   # SPEC 5
        rb = b.relative.get(name)
        if rb is not None and rb.reference == ra.reference:
            add(f'{name} position in {ra.reference} axes', 'm', ra.time, ra.position,
                rb.time, rb.position)
            continue
        body, carrier = b.bodies.get(name), b.bodies.get(ra.reference)
        if body is None or carrier is None or len(carrier.time) < 1:
            continue
        t, position = relative_position(body, carrier)
        add(f'{name} position in {ra.reference} axes', 'm', ra.time, ra.position, t, position)
    releases_a = {joint: t for t, joint, _ in a.releases()}
    releases_b = {joint: t for t, joint, _ in b.releases()}
    for joint in sorted(set(releases_a) & set(releases_b)):
        gap = abs(releases_a[joint] - releases_b[joint])
        rows.append(Difference(f'{joint} release', 's', gap, releases_a[joint],
                               releases_a[joint], 1))
    names_a = (set(a.bodies) | set(a.relative) | set(a.joints)
               | {f'{j} release' for j in releases_a})
    names_b = (set(b.bodies) | set(b.relative) | set(b.joints)
               | {f'{j} release' for j in releases_b})
    return (rows, sorted(names_a - names_b) + missing_b,
            sorted(names_b - names_a) + missing_a)


def _relative_rows(a: Run, b: Run, reference: str, add, rows: list):
    """Add each shared body's position and attitude in reference's axes (``compare_runs``)."""
    names = (set(a.bodies) | set(a.relative)) & (set(b.bodies) | set(b.relative))
    for name in sorted(names - {reference}):
        ours, theirs = pose_in(a, name, reference), pose_in(b, name, reference)
        if ours is None or theirs is None:
            continue
        add(f'{name} position in {reference} axes', 'm', ours[0], ours[1], theirs[0],
            theirs[1])
        t, angle = _angle_difference_deg(ours[0], ours[2], theirs[0], theirs[2])
        if not len(t):
            rows.append(Difference(f'{name} attitude in {reference} axes', 'deg', NAN, NAN,
                                   NAN, 0))
            continue
        k = int(np.argmax(angle))
        turned = rotations.angle_between(ours[2][:1], ours[2][_overlap(ours[0], theirs[0])])
        rows.append(Difference(f'{name} attitude in {reference} axes', 'deg', float(angle[k]),
                               float(t[k]), float(np.degrees(turned.max())), len(t)))
