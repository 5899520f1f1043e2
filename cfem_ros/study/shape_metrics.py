# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Shape-distance metrics and the time windows of sweep metrics (SPEC section 8).

A ``distance:`` entry measures the distance between two bodies' collision
shapes over a run's samples, within a window that opens at a time or at a
joint's (or a release group's) release plus a delay, and closes at a time
or at another release: the least distance (m), its time, the closest
points in each body's axes, and the time of the pair's first contact (the
run's ``contact`` event) within the window. ``clearance:`` entries take the
same window.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
import re
from typing import Optional

from cfem_ros.core import rotations
from cfem_ros.core.native import contacts, kernel
from cfem_ros.core.native.kernel import CLOSEST, LEAST
from cfem_ros.study import between
import numpy as np

NAN = float('nan')
#: What a metric entry's ``name`` may be: a column prefix.
NAME = re.compile(r'[A-Za-z][A-Za-z0-9_]{0,79}')
DISTANCE_KEYS = ('bodies', 'from', 'to', 'name')
WINDOW_KEYS = ('release', 'delay')
#: Columns of a distance entry after ``distance_<a>_<b>_``.
DISTANCE_SUFFIXES = ('min', 'min_time', 'point_a_x', 'point_a_y', 'point_a_z', 'point_b_x',
                     'point_b_y', 'point_b_z')


@dataclass(frozen=True)
class Edge:
    """One end of a window: a time (s), or a release (joint or group) plus a delay (s)."""

    time: float = 0.0
    release: Optional[str] = None
    delay: float = 0.0

    def at(self, releases: dict, groups: dict) -> float:
        """Return the edge's time in a run (NaN if its release never came)."""
        if self.release is None:
            return self.time
        joints = groups.get(self.release, (self.release,))
        times = [releases[j] for j in joints if j in releases]
        return min(times) + self.delay if times else NAN


@dataclass(frozen=True)
class Window:
    """The samples a metric looks at: from ``start`` to ``end``, both included."""

    start: Edge = field(default_factory=Edge)
    end: Edge = field(default_factory=lambda: Edge(time=math.inf))
    groups: tuple = ()   # (group, joints) pairs of the scenario's release_groups

    def mask(self, times: np.ndarray, releases) -> np.ndarray:
        """Return which sample times lie in the window (releases: (time, joint, cause))."""
        first = {}
        for t, joint, _ in releases:
            first.setdefault(joint, float(t))
        groups = dict(self.groups)
        start, end = self.start.at(first, groups), self.end.at(first, groups)
        if math.isnan(start) or math.isnan(end):
            return np.zeros(len(times), dtype=bool)
        return (times >= start - 0.5e-9) & (times <= end + 0.5e-9)

    def bounds(self, releases) -> tuple:
        """Return the window's (start, end) in a run, s (NaN if its release never came)."""
        first = {}
        for t, joint, _ in releases:
            first.setdefault(joint, float(t))
        groups = dict(self.groups)
        return self.start.at(first, groups), self.end.at(first, groups)

    def describe(self) -> list:
        """Return the window as plain data (what a sweep's hash is of)."""
        return [[e.time, e.release, e.delay] for e in (self.start, self.end)]


@dataclass
class Distance:
    """The distance between two bodies' collision shapes over a window."""

    body_a: str
    body_b: str
    shape_a: np.ndarray
    shape_b: np.ndarray
    window: Window = field(default_factory=Window)
    name: Optional[str] = None   # a window of its own for a pair given again

    @property
    def prefix(self) -> str:
        """Return the column prefix, the entry's ``name`` or ``distance_<a>_<b>``."""
        return self.name or f'distance_{self.body_a}_{self.body_b}'

    @property
    def contact_column(self) -> str:
        """Return the contact column, ``contact_<a>_<b>_time`` (``contact_<name>_time``)."""
        return f'contact_{self.name or self.body_a + "_" + self.body_b}_time'

    def columns(self) -> list:
        """Return the entry's columns, in table order."""
        return [f'{self.prefix}_{s}' for s in DISTANCE_SUFFIXES] + [self.contact_column]


def parse_window(fail, entry: dict, key: str, base: dict) -> Window:
    """Return the ``from``/``to`` window of a metric entry (both optional)."""
    joints = list((base.get('joints') or {}).keys())
    groups = base.get('release_groups') or {}
    group_joints = tuple((name, tuple(spec.get('joints') or ()))
                         for name, spec in groups.items() if isinstance(spec, dict))
    names = joints + [name for name, _ in group_joints]

    def edge(value, where, default):
        if value is None:
            return default
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            if not math.isfinite(value) or value < 0:
                fail(where, f'is {value!r}', 'a time >= 0 s, or {release: joint or group}')
            return Edge(time=float(value))
        if not isinstance(value, dict) or 'release' not in value:
            fail(where, f'is {value!r:.80}', 'a time (s), or {release: joint or group, '
                 'delay: s}')
        for name in value:
            if name not in WINDOW_KEYS:
                fail(f'{where}.{name}', 'unknown key', 'one of ' + ', '.join(WINDOW_KEYS))
        if value['release'] not in names:
            fail(f'{where}.release', f'{value["release"]!r:.80} is not a joint or release '
                 'group of the scenario', 'one of ' + ', '.join(names[:8]))
        delay = value.get('delay', 0.0)
        if isinstance(delay, bool) or not isinstance(delay, (int, float)) \
                or not math.isfinite(delay) or delay < 0:
            fail(f'{where}.delay', f'is {delay!r:.40}', 'a delay >= 0 s')
        return Edge(release=value['release'], delay=float(delay))

    start = edge(entry.get('from'), f'{key}.from', Edge())
    end = edge(entry.get('to'), f'{key}.to', Edge(time=math.inf))
    if start.release is None and end.release is None and end.time < start.time:
        fail(f'{key}.to', f'is {end.time:g} s, before from ({start.time:g} s)',
             'a window that ends after it starts')
    return Window(start, end, group_joints)


def parse_distance(fail, entry, key: str, base: dict, model) -> Distance:
    """Return a ``distance:`` entry: two bodies with collision shapes, and a window."""
    if not isinstance(entry, dict):
        fail(key, f'is {entry!r:.80}', 'a mapping with bodies, from, to')
    for name in entry:
        if name not in DISTANCE_KEYS:
            fail(f'{key}.{name}', 'unknown key', 'one of ' + ', '.join(DISTANCE_KEYS))
    pair = entry.get('bodies')
    if not isinstance(pair, list) or len(pair) != 2 or pair[0] == pair[1]:
        fail(f'{key}.bodies', f'is {pair!r:.80}', 'two different body names')
    names = [b.name for b in model.bodies]
    packed = []
    for i, name in enumerate(pair):
        if name not in names:
            fail(f'{key}.bodies[{i}]', f'{name!r:.80} is not a body of the scenario',
                 'one of ' + ', '.join(names[:8]))
        shape = model.bodies[names.index(name)].shape
        if shape is None or (shape.kind == 'mesh' and not shape.hull):
            fail(f'{key}.bodies[{i}]', f'{name} has no collision shape in the scenario',
                 f'bodies.{name}.shape: box, cylinder, sphere, capsule or a local mesh')
        packed.append(contacts.pack_shape(shape))
    return Distance(pair[0], pair[1], packed[0], packed[1], parse_window(fail, entry, key, base),
                    parse_name(fail, entry, key))


def parse_name(fail, entry: dict, key: str) -> Optional[str]:
    """Return a metric entry's ``name`` (its columns' prefix), None if not given."""
    name = entry.get('name')
    if name is not None and (not isinstance(name, str) or not NAME.fullmatch(name)):
        fail(f'{key}.name', f'is {name!r:.80}', 'a column prefix of letters, digits and _, '
             'starting with a letter (e.g. miss_after_release)')
    return name


def compute_distance(entry: Distance, samples) -> dict:
    """
    Return a distance entry's columns for a run's samples (``metrics.Samples``).

    The least distance over the window, between samples included (the
    kernel's search, ``between``: the first least sample if nothing between
    them is lower), its time, the closest points there in each body's axes (m),
    and the first contact of the pair in the window (NaN if none).
    """
    out = dict.fromkeys(entry.columns(), NAN)
    for name in (entry.body_a, entry.body_b):
        if name not in samples.bodies:
            raise KeyError(f'no body {name!r} in the run')
    t, pos_a, quat_a = (np.asarray(v) for v in samples.bodies[entry.body_a])
    _, pos_b, quat_b = (np.asarray(v) for v in samples.bodies[entry.body_b])
    start, end = entry.window.bounds(samples.releases)
    if len(t) and not (math.isnan(start) or math.isnan(end)):
        d, _ = contacts.distances(entry.shape_a, quat_a, pos_a, entry.shape_b, quat_b, pos_b)
        track_a, track_b = between.motion(samples, entry.body_a), \
            between.motion(samples, entry.body_b)
        if track_a is None or track_b is None:   # no twist: the samples alone
            track_a = track_b = between.NO_TRACK
        found = kernel.least_shape_distance(t, d, track_a, track_b, entry.shape_a,
                                            entry.shape_b, start, end)
        when = float(found[LEAST.L_TIME])
        if not math.isnan(found[LEAST.L_DISTANCE]):
            k = between.at_sample(t, when)
            if k is not None:   # a sample
                poses_a, poses_b = (pos_a[k:k + 1], quat_a[k:k + 1]), (pos_b[k:k + 1],
                                                                       quat_b[k:k + 1])
                when = float(t[k])
            else:
                poses_a, poses_b = between.poses(found)
            found, points = contacts.distances(entry.shape_a, poses_a[1], poses_a[0],
                                               entry.shape_b, poses_b[1], poses_b[0])
            rot_a = rotations.matrices(poses_a[1])[0]
            rot_b = rotations.matrices(poses_b[1])[0]
            point_a = rot_a.T @ (points[0, CLOSEST.span('P_A')] - poses_a[0][0])
            point_b = rot_b.T @ (points[0, CLOSEST.span('P_B')] - poses_b[0][0])
            values = [float(found[0]), when] + [float(v) for v in point_a] \
                + [float(v) for v in point_b]
            out.update(zip((f'{entry.prefix}_{s}' for s in DISTANCE_SUFFIXES), values))
    pair = {entry.body_a, entry.body_b}
    touches = [time for time, bodies in getattr(samples, 'contacts', ())
               if set(bodies) == pair and start - 0.5e-9 <= time <= end + 0.5e-9]
    if touches:
        out[entry.contact_column] = float(min(touches))
    return out
