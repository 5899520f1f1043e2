# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Metrics lined up on a release (SPEC section 12): ``at`` after a release, ``extremes``.

An ``at`` entry with ``after`` (a joint or a release group) takes the
state ``time`` s after that release: between two samples, the relative
position is interpolated linearly and the relative attitude by slerp (the
poses composed first, sample by sample, ``recording.relative``), so the
value is what the run's exported histories give at that time from release.
An ``extremes`` entry gives the least and largest of x, y, z (m), roll,
pitch, yaw (deg, Z-Y-X; relative to ``relative_to`` when given) and of
the body rates p, q, r (deg/s, body axes, as recorded) over the samples
of its ``from``/``to`` window.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Optional

from cfem_ros.core import rotations
from cfem_ros.recording.relative import relative_pose
from cfem_ros.study.shape_metrics import Edge, parse_window, Window
import numpy as np

NAN = float('nan')
EXTREMES_KEYS = ('body', 'relative_to', 'from', 'to')
#: The quantities of an extremes entry, after ``<body>_min_`` and ``<body>_max_``.
EXTREME_QUANTITIES = ('x', 'y', 'z', 'roll_deg', 'pitch_deg', 'yaw_deg', 'p', 'q', 'r')
AT_QUANTITIES = ('x', 'y', 'z', 'roll_deg', 'pitch_deg', 'yaw_deg')


@dataclass
class Extremes:
    """Least and largest values of a body's state over a window."""

    body: str
    relative_to: Optional[str] = None
    window: Window = field(default_factory=Window)

    def columns(self) -> list:
        """Return the entry's columns, ``<body>_min_<q>`` and ``<body>_max_<q>`` per q."""
        return [f'{self.body}_{which}_{q}' for q in EXTREME_QUANTITIES
                for which in ('min', 'max')]

    def describe(self) -> list:
        """Return the entry as plain data (what a sweep's hash is of)."""
        return [self.body, self.relative_to, self.window.describe()]


def parse_extremes(fail, entries, base: dict, body) -> list:
    """Check ``metrics.extremes``; body(key, name) checks a body name. Return Extremes."""
    if not isinstance(entries, list):
        fail('metrics.extremes', f'is {entries!r:.80}', 'a list of {body, relative_to, from, '
             'to}')
    out, seen = [], {}
    for i, entry in enumerate(entries):
        key = f'metrics.extremes[{i}]'
        if not isinstance(entry, dict):
            fail(key, f'is {entry!r:.80}', 'a mapping {body, relative_to, from, to}')
        for name in entry:
            if name not in EXTREMES_KEYS:
                fail(f'{key}.{name}', 'unknown key', 'one of ' + ', '.join(EXTREMES_KEYS))
        name = body(f'{key}.body', entry.get('body'))
        if name in seen:   # the columns are named by the body alone
            fail(f'{key}.body', f'{name} has an extremes entry already (metrics.extremes'
                 f'[{seen[name]}])', 'one extremes entry per body')
        seen[name] = i
        relative = entry.get('relative_to')
        if relative is not None:
            relative = body(f'{key}.relative_to', relative)
            if relative == name:
                fail(f'{key}.relative_to', f'is {name}, the body itself', 'another body')
        out.append(Extremes(name, relative, parse_window(fail, entry, key, base)))
    return out


def check_after(fail, key: str, after, base: dict) -> tuple:
    """Check an ``at`` entry's ``after``; return (name, the scenario's groups)."""
    joints = list((base.get('joints') or {}).keys())
    groups = base.get('release_groups') or {}
    group_joints = tuple((name, tuple(spec.get('joints') or ()))
                         for name, spec in groups.items() if isinstance(spec, dict))
    names = joints + [name for name, _ in group_joints]
    if not isinstance(after, str) or after not in names:
        fail(f'{key}.after', f'{after!r:.80} is not a joint or release group of the scenario',
             'one of ' + ', '.join(names[:8]))
    return after, group_joints


def _pose(samples, body: str, relative_to: Optional[str], rows) -> tuple:
    """Return a body's (times, positions, quaternions) at sample rows, relative if asked."""
    t, position, quaternion = (np.asarray(a) for a in samples.bodies[body])
    position, quaternion = position[rows], quaternion[rows]
    if relative_to is not None:
        _, ref_position, ref_quaternion = (np.asarray(a) for a in samples.bodies[relative_to])
        position, quaternion = relative_pose(position, quaternion, ref_position[rows],
                                             ref_quaternion[rows])
    return t[rows], position, quaternion


def _slerp(q0: np.ndarray, q1: np.ndarray, fraction: float) -> np.ndarray:
    """Return the attitude a fraction of the way from q0 to q1 (unit quaternions, shortest)."""
    q0 = q0 / np.linalg.norm(q0)
    q1 = q1 / np.linalg.norm(q1)
    cosine = float(q0 @ q1)
    if cosine < 0.0:
        q1, cosine = -q1, -cosine
    angle = math.acos(min(1.0, cosine))
    if angle < 1e-12:
        return q0
    return (math.sin((1 - fraction) * angle) * q0 + math.sin(fraction * angle) * q1) \
        / math.sin(angle)


def release_edge_time(name: str, delay: float, releases, groups) -> float:
    """Return the time of a joint's or group's first release plus delay (NaN if none)."""
    first = {}
    for t, joint, _ in releases:
        first.setdefault(joint, float(t))
    return Edge(release=name, delay=delay).at(first, dict(groups))


def at_after(entry, samples) -> list:
    """Return an ``at`` entry's x, y, z, roll, pitch, yaw ``time`` s after its release."""
    when = release_edge_time(entry.after, entry.time, samples.releases, entry.groups)
    t = np.asarray(samples.bodies[entry.body][0])
    if math.isnan(when) or not len(t) or not t[0] - 0.5e-9 <= when <= t[-1] + 0.5e-9:
        return [NAN] * 6
    k = int(np.searchsorted(t, when - 0.5e-9))
    if abs(t[min(k, len(t) - 1)] - when) <= 0.5e-9:
        _, position, quaternion = _pose(samples, entry.body, entry.relative_to, [k])
        p, q = position[0], quaternion[0]
    else:   # between samples k - 1 and k
        times, position, quaternion = _pose(samples, entry.body, entry.relative_to,
                                            [k - 1, k])
        fraction = (when - times[0]) / (times[1] - times[0])
        p = position[0] + fraction * (position[1] - position[0])
        q = _slerp(quaternion[0], quaternion[1], fraction)
    rpy = rotations.to_rpy_deg(np.asarray(q, dtype=float))
    return [float(v) for v in p] + [float(a) for a in rpy]


def compute_extremes(entry: Extremes, samples) -> dict:
    """Return an extremes entry's columns for a run's samples (NaN if its window is empty)."""
    out = dict.fromkeys(entry.columns(), NAN)
    for name in (entry.body, entry.relative_to):
        if name is not None and name not in samples.bodies:
            raise KeyError(f'no body {name!r} in the run')
    t = np.asarray(samples.bodies[entry.body][0])
    inside = np.flatnonzero(entry.window.mask(t, samples.releases))
    if not len(inside):
        return out
    _, position, quaternion = _pose(samples, entry.body, entry.relative_to, inside)
    rates = np.asarray(samples.rates.get(entry.body, np.full((len(t), 3), np.nan)))[inside]
    values = np.column_stack([position, rotations.to_rpy_deg(quaternion), np.degrees(rates)])
    for k, q in enumerate(EXTREME_QUANTITIES):
        column = values[:, k]
        if np.isfinite(column).any():
            out[f'{entry.body}_min_{q}'] = float(np.nanmin(column))
            out[f'{entry.body}_max_{q}'] = float(np.nanmax(column))
    return out
