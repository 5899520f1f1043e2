# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""A sweep's ``metrics`` (SPEC sections 6, 12): what is measured on every run, checked."""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Optional

from cfem_ros.core.fileio.messages import show
from cfem_ros.core.scenario.checker import MAX_MAGNITUDE
from cfem_ros.recording.carriage import EXPECTED, parse_point
from cfem_ros.study import windowed
from cfem_ros.study.errors import number_list
from cfem_ros.study.shape_metrics import parse_distance, parse_name, parse_window, Window
import numpy as np

METRIC_KEYS = ('clearance', 'at', 'distance', 'extremes')
CLEARANCE_KEYS = ('bodies', 'points_a', 'points_b', 'from', 'to', 'name')
AT_KEYS = ('time', 'body', 'relative_to', 'after', 'point')
#: A sample time within this many samples of the grid is on it.
ON_GRID = 1e-9
#: An ``at`` entry's columns after its prefix; with ``relative_to`` also the CG's velocity
#: seen from the carrier, in its axes (SPEC section 15, m/s).
AT_QUANTITIES = ('x', 'y', 'z', 'roll_deg', 'pitch_deg', 'yaw_deg')
AT_RELATIVE = ('u_rel', 'v_rel', 'w_rel')
#: Sweep columns of a stroke end, after ``stroke_<wrench>_`` (SPEC section 7).
STROKE_COLUMNS = ('time', 'u', 'v', 'w', 'p', 'q', 'r')


@dataclass
class Clearance:
    """Minimum distance between points carried by two bodies (body axes, m)."""

    body_a: str
    body_b: str
    points_a: np.ndarray
    points_b: np.ndarray
    window: Window = field(default_factory=Window)   # ``from``/``to`` (shape_metrics.py)
    name: Optional[str] = None   # a window of its own for a pair given again

    @property
    def prefix(self) -> str:
        """Return the column prefix, the entry's ``name`` or ``clearance_<a>_<b>``."""
        return self.name or f'clearance_{self.body_a}_{self.body_b}'


@dataclass
class At:
    """
    A body's state at a sample time, optionally in another body's frame.

    With ``after`` (a joint or release group, SPEC section 12) the time is
    counted from that release (``windowed.at_after``); ``groups`` are the
    scenario's release groups, (name, joints) pairs. With ``relative_to``,
    ``point`` (SPEC section 15) measures the position from that point of the
    carrier instead of its CG: ``'carriage'`` or [x, y, z] (m, carrier axes,
    ``recording.carriage``).
    """

    time: float
    body: str
    relative_to: Optional[str] = None
    after: Optional[str] = None
    groups: tuple = ()
    point: Optional[object] = None

    @property
    def prefix(self) -> str:
        """Return the column prefix, ``<body>_at_<time>_`` (``<time>r_`` after a release)."""
        return f'{self.body}_at_{self.time:g}{"r" if self.after else ""}_'

    def columns(self) -> list:
        """Return the entry's columns: the pose, and with relative_to ``u_rel, v_rel, w_rel``."""
        quantities = AT_QUANTITIES + (AT_RELATIVE if self.relative_to is not None else ())
        return [self.prefix + q for q in quantities]


@dataclass
class Metrics:
    """What is measured on every run: clearances, states at times, joints' loads, strokes."""

    clearance: list = field(default_factory=list)
    at: list = field(default_factory=list)
    joints: list = field(default_factory=list)
    strokes: list = field(default_factory=list)
    distance: list = field(default_factory=list)   # shape_metrics.Distance
    aero: list = field(default_factory=list)   # bodies with aero tables
    extremes: list = field(default_factory=list)   # windowed.Extremes

    def columns(self) -> list:
        """Return the metric column names, in table order."""
        names = []
        for c in self.clearance:
            names += [f'{c.prefix}_min', f'{c.prefix}_min_time', f'{c.prefix}_point_a',
                      f'{c.prefix}_point_b']
        for d in self.distance:
            names += d.columns()
        for joint in self.joints:
            names += [f'release_{joint}_time', f'release_{joint}_cause']
        for joint in self.joints:
            names += [f'peak_force_{joint}', f'peak_moment_{joint}']
        for entry in self.at:
            names += entry.columns()
        for wrench in self.strokes:
            names += [f'stroke_{wrench}_{s}' for s in STROKE_COLUMNS]
        names += [f'aero_outside_{body}' for body in self.aero]
        for entry in self.extremes:
            names += entry.columns()
        return names


def parse_metrics(fail, metrics, base, rate, model=None) -> Metrics:
    if not isinstance(metrics, dict):
        fail('metrics', f'is {show(metrics)}', 'a mapping with clearance and at')
    for name in metrics:
        if name not in METRIC_KEYS:
            fail(f'metrics.{name}', 'unknown key', 'one of ' + ', '.join(METRIC_KEYS))
    bodies = list((base.get('bodies') or {}).keys())
    joints = list((base.get('joints') or {}).keys())

    def body(key, name):
        if name not in bodies:
            fail(key, f'{show(name)} is not a body of the scenario', 'one of ' +
                 ', '.join(bodies))
        return name

    wrenches = base.get('wrenches') if isinstance(base.get('wrenches'), list) else []
    strokes = [w.get('name', f'wrench{k}') for k, w in enumerate(wrenches)
               if isinstance(w, dict) and w.get('stroke') is not None]
    aero = list(base['aero']) if isinstance(base.get('aero'), dict) else []
    out = Metrics(joints=joints, strokes=list(dict.fromkeys(strokes)), aero=aero)
    clearance = metrics.get('clearance') or []
    if not isinstance(clearance, list):
        fail('metrics.clearance', f'is {show(clearance)}', 'a list of body pairs')
    seen = {}
    for i, entry in enumerate(clearance):
        key = f'metrics.clearance[{i}]'
        if not isinstance(entry, dict):
            fail(key, f'is {show(entry)}', 'a mapping with bodies, points_a, points_b')
        for name in entry:
            if name not in CLEARANCE_KEYS:
                fail(f'{key}.{name}', 'unknown key', 'one of ' + ', '.join(CLEARANCE_KEYS))
        pair = entry.get('bodies')
        if not isinstance(pair, list) or len(pair) != 2 or pair[0] == pair[1]:
            fail(f'{key}.bodies', f'is {show(pair)}', 'two different body names')
        a, b = body(f'{key}.bodies[0]', pair[0]), body(f'{key}.bodies[1]', pair[1])
        found = Clearance(a, b, _points(fail, f'{key}.points_a', entry.get('points_a')),
                          _points(fail, f'{key}.points_b', entry.get('points_b')),
                          parse_window(fail, entry, key, base), parse_name(fail, entry, key))
        _unique(fail, seen, found, key, pair)
        out.clearance.append(found)
    distance = metrics.get('distance') or []
    if not isinstance(distance, list):
        fail('metrics.distance', f'is {show(distance)}', 'a list of {bodies: [a, b], from, to}')
    for i, entry in enumerate(distance):
        found = parse_distance(fail, entry, f'metrics.distance[{i}]', base, model)
        _unique(fail, seen, found, f'metrics.distance[{i}]', entry.get('bodies'))
        out.distance.append(found)
    at = metrics.get('at') or []
    if not isinstance(at, list):
        fail('metrics.at', f'is {show(at)}', 'a list of {time, body, relative_to}')
    for i, entry in enumerate(at):
        key = f'metrics.at[{i}]'
        if not isinstance(entry, dict):
            fail(key, f'is {show(entry)}', 'a mapping {time, body, relative_to}')
        for name in entry:
            if name not in AT_KEYS:
                fail(f'{key}.{name}', 'unknown key', 'one of ' + ', '.join(AT_KEYS))
        t = entry.get('time')
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t) \
                or t < 0:
            fail(f'{key}.time', f'is {show(t)}', 'a time >= 0 s')
        _check_at_time(fail, f'{key}.time', t, rate)
        after, groups = None, ()
        if 'after' in entry:   # from a release: between samples, interpolated
            after, groups = windowed.check_after(fail, key, entry['after'], base)
        elif abs(t * rate - round(t * rate)) > ON_GRID * max(1.0, t * rate):
            fail(f'{key}.time', f'is {t!r} s, between two samples at rate_hz {rate:g}',
                 f'a multiple of 1/rate_hz = {1 / rate:g} s (or a time after a release: '
                 '`after: <joint or group>`)')
        relative = entry.get('relative_to')
        point = _point(fail, key, entry, relative)
        out.at.append(At(float(t), body(f'{key}.body', entry.get('body')),
                         None if relative is None else body(f'{key}.relative_to', relative),
                         after, groups, point))
    out.extremes = windowed.parse_extremes(fail, metrics.get('extremes') or [], base, body)
    return out


def _point(fail, key: str, entry: dict, relative):
    """Return an ``at`` entry's ``point`` ('carriage', [x, y, z] or None), checked."""
    if entry.get('point') is None:
        return None
    if relative is None:
        fail(f'{key}.point', f'is {show(entry["point"])} without relative_to',
             'relative_to: the carrier the point is on')
    try:
        point = parse_point(entry['point'])
    except ValueError:
        fail(f'{key}.point', f'is {show(entry["point"])}', EXPECTED)
    return point if isinstance(point, str) else [float(v) for v in point]


def _unique(fail, seen: dict, entry, key: str, pair):
    """Refuse a second clearance or distance entry with the same columns (seen: prefix -> key)."""
    prefix = entry.prefix
    if prefix in seen:
        fail(f'{key}.name' if entry.name else f'{key}.bodies',
             f'{show(pair)} gives the columns {prefix}_* of {seen[prefix]} again',
             "each pair once, or a `name:` for each window of a pair (its columns' prefix)")
    seen[prefix] = key


def _points(fail, key, value):
    if value is None:
        return np.zeros((1, 3))
    if not isinstance(value, list) or not value:
        fail(key, f'is {show(value)}', 'a list of points [x, y, z] in body axes, m')
    points = np.array([number_list(fail, f'{key}[{i}]', p, 3) for i, p in enumerate(value)])
    far = np.flatnonzero(np.any(np.abs(points) > MAX_MAGNITUDE, axis=1))
    if far.size:   # as every scenario position: beyond it distances lose every digit
        fail(f'{key}[{far[0]}]', f'is {points[far[0]].tolist()}',
             f'a point within {MAX_MAGNITUDE:g} m (body axes)')
    return points


def _check_at_time(fail, key: str, t: float, rate: float):
    """Refuse an ``at`` time whose sample number overflows (beyond any run's samples)."""
    from cfem_ros.recording import offline
    if t * rate > offline.MAX_SAMPLES:
        fail(key, f'is {t:g} s, sample {t * rate:.4g} at rate_hz {rate:g}',
             f'a time within a run (at most {offline.MAX_SAMPLES:.4g} samples)')


def check_unique_at(fail, metrics):
    """Refuse an ``at`` entry given twice (its columns would be duplicates)."""
    seen = {}
    for i, entry in enumerate(metrics.at):
        point = (entry.time, entry.body, entry.relative_to, entry.after)
        if point in seen:
            fail(f'metrics.at[{i}]', f'is the same as metrics.at[{seen[point]}] (time '
                 f'{entry.time:g} s, body {entry.body})', 'each entry once')
        seen[point] = i
