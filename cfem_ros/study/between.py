# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Least distances between samples (SPEC section 15): the trajectory within a step, searched.

A run's samples hold each body's whole state: CG position and velocity,
attitude and body rates. Between two samples a body moves on the cubic
Hermite interpolant of that state (position from position and velocity;
the quaternion from the quaternion and its rate of change, normalized):
the integrated state and its derivative at both ends, exact for a body
moving at constant acceleration (a store in free fall, a steady carrier),
otherwise within h^4 / 384 times the fourth derivative of the motion over
a sample interval h (with an acceleration that jumps inside the interval,
a release or an end of stroke, within h^2 / 16 times the jump).

``least`` finds the least of a distance over a window from its sampled
values: each sample interval whose distance could go below the best found
(its ends less the interval times a bound on how fast the distance can
change, from the bodies' velocities, rates and sizes) is searched, first
on a few points, then by a bounded scalar minimisation (Brent) to
``TIME_TOLERANCE``. A value within ``GAIN`` of the best sample keeps the
sample (so that a body at rest gives its sample's number to the bit).
"""

from __future__ import annotations

import math

from cfem_ros.core import rotations
import numpy as np

#: How close in time the search comes to the least distance, s.
TIME_TOLERANCE = 1e-11
#: A distance between samples replaces the least sample only below it by more than this, m.
GAIN = 1e-12
#: Points tried in a sample interval before the bounded minimisation.
PROBES = 8
#: Margin on the rate of change of a distance read from the interval's ends.
RATE_MARGIN = 2.0


def motion(samples, body: str):
    """Return a body's ``Motion`` from a run's samples, or None without its whole twist."""
    t, position, quaternion = samples.bodies[body]
    velocity, rates = samples.velocities.get(body), samples.rates.get(body)
    if velocity is None or rates is None or len(t) < 2 \
            or not (np.isfinite(velocity).all() and np.isfinite(rates).all()):
        return None
    return Motion(t, position, quaternion, velocity, rates)


class Motion:
    """
    One body's state between its samples (cubic Hermite interpolation).

    Parameters
    ----------
    time : ndarray (n,)
        Sample times, s, increasing.
    position, quaternion, velocity, rates : ndarray (n, 3), (n, 4), (n, 3), (n, 3)
        CG position (world, m), attitude (x y z w, body to world), CG
        velocity (body axes, m/s) and body rates (rad/s), as sampled.

    """

    def __init__(self, time, position, quaternion, velocity, rates):
        self.time = np.asarray(time, dtype=float)
        self.position = np.asarray(position, dtype=float)
        quaternion = np.array(quaternion, dtype=float)
        # one sign along the track: each quaternion on the side of the one before
        turned = np.einsum('ij,ij->i', quaternion[1:], quaternion[:-1]) < 0
        flips = np.cumsum(np.r_[False, turned]) % 2 == 1
        quaternion[flips] *= -1.0
        self.quaternion = quaternion
        rates = np.asarray(rates, dtype=float)
        velocity = np.asarray(velocity, dtype=float)
        self.velocity_world = np.einsum('nij,nj->ni', rotations.matrices(quaternion), velocity)
        self.quaternion_rate = rotations.rate_of_change(quaternion, rates)
        self.speed = np.linalg.norm(velocity, axis=1)
        self.turn_rate = np.linalg.norm(rates, axis=1)
        self._intervals = {}

    def at(self, k: int, times) -> tuple:
        """Return (positions (m, 3), quaternions (m, 4)) at times in [time[k], time[k + 1]]."""
        h = self.time[k + 1] - self.time[k]
        s = (np.atleast_1d(np.asarray(times, dtype=float)) - self.time[k]) / h
        s2, s3 = s * s, s * s * s
        basis = np.column_stack([2 * s3 - 3 * s2 + 1, (s3 - 2 * s2 + s) * h,
                                 -2 * s3 + 3 * s2, (s3 - s2) * h])

        def cubic(value, rate):
            return basis @ np.stack([value[k], rate[k], value[k + 1], rate[k + 1]])

        position = cubic(self.position, self.velocity_world)
        quaternion = cubic(self.quaternion, self.quaternion_rate)
        quaternion /= np.linalg.norm(quaternion, axis=1)[:, None]
        return position, quaternion

    def pose(self, k: int, t: float) -> tuple:
        """
        Return (position, quaternion) at one time t in [time[k], time[k + 1]], as floats.

        ``at`` for one time in plain floats: a minimisation asks for one time
        after another, and numpy's cost per call on arrays of one row is ten
        times the arithmetic. The same interpolant and normalization, to
        rounding (a few ulp: no fused multiply-adds here).
        """
        start, h, columns = self._interval(k)
        s = (t - start) / h
        s2, s3 = s * s, s * s * s
        b0, b1, b2, b3 = 2 * s3 - 3 * s2 + 1, (s3 - 2 * s2 + s) * h, -2 * s3 + 3 * s2, \
            (s3 - s2) * h
        values = [b0 * v0 + b1 * r0 + b2 * v1 + b3 * r1 for v0, r0, v1, r1 in columns]
        norm = math.sqrt(sum(v * v for v in values[3:]))
        return values[:3], [v / norm for v in values[3:]]

    def _interval(self, k: int) -> tuple:
        """Return interval k's start (s), length (s) and, per coordinate, its four Hermite data."""
        found = self._intervals.get(k)
        if found is None:
            ends = [np.hstack([self.position[j], self.quaternion[j]]).tolist() for j in (k, k + 1)]
            rates = [np.hstack([self.velocity_world[j], self.quaternion_rate[j]]).tolist()
                     for j in (k, k + 1)]
            found = (float(self.time[k]), float(self.time[k + 1] - self.time[k]),
                     list(zip(ends[0], rates[0], ends[1], rates[1])))
            self._intervals[k] = found
        return found


def rotation(quaternion) -> list:
    """
    Return the body-to-world matrix of a unit quaternion (x, y, z, w), nine floats row by row.

    ``rotations.matrices`` for one attitude in plain floats, its formulas entry by entry.
    """
    x, y, z, w = quaternion
    return [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
            2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
            2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]


def interval_rate(a: Motion, b: Motion, k: int, radius_a: float, radius_b: float) -> float:
    """Return a bound on |d distance / dt| over interval k (m/s), read from its ends."""
    ends = slice(k, k + 2)
    relative = np.linalg.norm(a.velocity_world[ends] - b.velocity_world[ends], axis=1).max()
    return RATE_MARGIN * float(relative + a.turn_rate[ends].max() * radius_a
                               + b.turn_rate[ends].max() * radius_b)


def least(time, sampled, evaluate, rate, start: float, end: float, one=None) -> tuple:
    """
    Return (least distance, its time) over [start, end], between samples included.

    Parameters
    ----------
    time, sampled : ndarray (n,)
        Sample times (s) and the distance there (m).
    evaluate : callable (k, times) -> distances, or None
        The distance at times within sample interval k (None: the samples
        alone, for a run whose twists were not recorded).
    rate : callable k -> float
        A bound on how fast the distance changes in interval k, m/s.
    start, end : float
        The window, s (the samples' span where it is wider).
    one : callable (k, t) -> float, optional
        The distance at one time t within interval k, as evaluate gives it
        (to rounding), for the minimisation's one time after another; from
        evaluate when None.

    Returns NaN, NaN when no sample lies in the window and no interval meets it.

    """
    time = np.asarray(time, dtype=float)
    sampled = np.asarray(sampled, dtype=float)
    inside = np.flatnonzero((time >= start - 0.5e-9) & (time <= end + 0.5e-9))
    best, when = math.nan, math.nan
    if len(inside):   # the least sample, the first if several tie
        k = inside[int(np.argmin(sampled[inside]))]
        best, when = float(sampled[k]), float(time[k])
    if evaluate is None or len(time) < 2:
        return best, when
    lo, hi = max(start, time[0]) if len(time) else start, min(end, time[-1]) if len(time) else end
    intervals = [k for k in range(len(time) - 1) if time[k + 1] > lo and time[k] < hi]
    bounds = []
    for k in intervals:
        h = time[k + 1] - time[k]
        ends = [sampled[j] for j in (k, k + 1) if lo - 0.5e-9 <= time[j] <= hi + 0.5e-9]
        reference = min(ends) if ends else float(np.mean(sampled[k:k + 2]))
        bounds.append((reference - rate(k) * h, k))
    for bound, k in sorted(bounds):
        if not math.isnan(best) and bound >= best - GAIN:
            break
        a, b = max(time[k], lo), min(time[k + 1], hi)
        if not b > a:
            continue
        found = _search(lambda t: evaluate(k, t), a, b,
                        (lambda t: float(evaluate(k, np.array([t]))[0])) if one is None
                        else (lambda t: one(k, t)))
        if math.isnan(best) or found[0] < best - GAIN:
            best, when = found
    return best, when


def _search(function, a: float, b: float, single) -> tuple:
    """Return the least (value, time) over [a, b]: function's probes, then Brent on single."""
    probes = np.linspace(a, b, PROBES + 1)
    values = np.asarray(function(probes), dtype=float)
    j = int(np.argmin(values))
    low, high = probes[max(j - 1, 0)], probes[min(j + 1, PROBES)]
    # imported here: a run imports this module for its metrics, and scipy costs most of a
    # second of start-up that a run without a distance window never needs
    from scipy.optimize import minimize_scalar
    found = minimize_scalar(single, bounds=(low, high),
                            method='bounded', options={'xatol': TIME_TOLERANCE})
    if found.fun < values[j]:
        return float(found.fun), float(found.x)
    return float(values[j]), float(probes[j])


def point_distances(position_a, quaternion_a, points_a, position_b, quaternion_b, points_b):
    """Return the least distance over point pairs at each pose pair (m), and the pair's indices."""
    world_a = position_a[:, None, :] + np.einsum('nij,pj->npi',
                                                 rotations.matrices(quaternion_a), points_a)
    world_b = position_b[:, None, :] + np.einsum('nij,pj->npi',
                                                 rotations.matrices(quaternion_b), points_b)
    gaps = np.linalg.norm(world_a[:, :, None, :] - world_b[:, None, :, :], axis=3)
    flat = gaps.reshape(len(gaps), -1)
    best = np.argmin(flat, axis=1)
    return flat[np.arange(len(flat)), best], best // len(points_b), best % len(points_b)


def least_point_distance(samples, body_a, points_a, body_b, points_b, start, end):
    """
    Return (distance, time, index a, index b) of the least clearance between samples.

    NaN, NaN, -1, -1 when the window holds nothing, or when the least is at
    a sample (the caller's sampled figures stand); points in body axes, m.
    """
    t, pos_a, quat_a = (np.asarray(v, dtype=float) for v in samples.bodies[body_a])
    _, pos_b, quat_b = (np.asarray(v, dtype=float) for v in samples.bodies[body_b])
    motion_a, motion_b = motion(samples, body_a), motion(samples, body_b)
    if motion_a is None or motion_b is None:
        return math.nan, math.nan, -1, -1
    sampled = point_distances(pos_a, quat_a, points_a, pos_b, quat_b, points_b)[0]
    radius_a = float(np.linalg.norm(points_a, axis=1).max())
    radius_b = float(np.linalg.norm(points_b, axis=1).max())

    def evaluate(k, times):
        (p_a, q_a), (p_b, q_b) = motion_a.at(k, times), motion_b.at(k, times)
        return point_distances(p_a, q_a, points_a, p_b, q_b, points_b)[0]

    pairs = [(a, b) for a in np.asarray(points_a, dtype=float).tolist()
             for b in np.asarray(points_b, dtype=float).tolist()]

    def one(k, time):
        (p_a, q_a), (p_b, q_b) = motion_a.pose(k, time), motion_b.pose(k, time)
        r_a, r_b = rotation(q_a), rotation(q_b)
        return min(math.sqrt(sum((p_a[i] + r_a[3 * i] * a[0] + r_a[3 * i + 1] * a[1]
                                  + r_a[3 * i + 2] * a[2] - p_b[i] - r_b[3 * i] * b[0]
                                  - r_b[3 * i + 1] * b[1] - r_b[3 * i + 2] * b[2]) ** 2
                                 for i in range(3)))
                   for a, b in pairs)

    value, when = least(t, sampled, evaluate,
                        lambda k: interval_rate(motion_a, motion_b, k, radius_a, radius_b),
                        start, end, one)
    k = int(np.searchsorted(t, when - 0.5e-9)) if not math.isnan(when) else 0
    if math.isnan(value) or (k < len(t) and abs(t[k] - when) <= 0.5e-9):
        return math.nan, math.nan, -1, -1
    (p_a, q_a), (p_b, q_b) = motion_a.at(k - 1, [when]), motion_b.at(k - 1, [when])
    found, index_a, index_b = point_distances(p_a, q_a, points_a, p_b, q_b, points_b)
    return float(found[0]), when, int(index_a[0]), int(index_b[0])
