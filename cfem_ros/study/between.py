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
values. A bound L on |d distance / dt| in each sample interval (from the
bodies' relative velocity, rates and sizes, on the interpolant) bounds the distance there from
below by (d0 + d1 - L h) / 2, d0 and d1 its ends (the rate lets it fall from
one end and rise to the other, no more). Only the intervals whose bound is
more than ``DISTANCE_TOLERANCE`` below the best found are probed, all in one
call (``PROBES`` points each); the same bound on each probed piece prunes
them again; in each one left, the least is searched about its least probe by
Brent (bounded) to a time tolerance of ``DISTANCE_TOLERANCE`` / L, so that
the value found is within ``DISTANCE_TOLERANCE`` of the interpolant's local
least there (a least probe at an end, a window's edge most often, is first
approached in one call: Brent closes on an end in some 30 golden sections).
A value within ``GAIN`` of the best sample keeps the sample (so
that a body at rest gives its sample's number to the bit).
"""

from __future__ import annotations

import math

from cfem_ros.core import rotations
import numpy as np

#: How close the least found comes to the interpolant's least, m: Brent stops within this
#: over the interval's rate bound in time (a distance changes by at most rate x time).
DISTANCE_TOLERANCE = 1e-9
#: A distance between samples replaces the least sample only below it by more than this, m.
GAIN = 1e-12
#: Points tried in a sample interval before the bounded minimisation.
PROBES = 8


def motion(samples, body: str):
    """
    Return a body's ``Motion`` from a run's samples, or None without its whole twist.

    Made once per body and kept in ``samples.motions`` (where the samples
    have it): a run's metrics ask for the same body's several times.
    """
    made = getattr(samples, 'motions', None)
    if made is not None and body in made:
        return made[body]
    t, position, quaternion = samples.bodies[body]
    velocity, rates = samples.velocities.get(body), samples.rates.get(body)
    found = None
    if not (velocity is None or rates is None or len(t) < 2
            or not (np.isfinite(velocity).all() and np.isfinite(rates).all())):
        found = Motion(t, position, quaternion, velocity, rates)
    if made is not None:
        made[body] = found
    return found


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
        # each sample's seven Hermite values and their rates, side by side for ``pose``
        self._values = np.hstack([self.position, quaternion])
        self._rates = np.hstack([self.velocity_world, self.quaternion_rate])
        self._intervals = {}

    def at(self, k, times) -> tuple:
        """
        Return (positions (m, 3), quaternions (m, 4)) at times.

        k is the sample interval of every time (times[i] in [time[k], time[k + 1]]), or
        one interval index per time: probes of many intervals in one call.
        """
        times = np.atleast_1d(np.asarray(times, dtype=float))
        k = np.asarray(k, dtype=int)
        if k.ndim == 0:   # one interval: its rows, not a gather per time
            k = int(k)
        start, h = self.time[k], self.time[k + 1] - self.time[k]
        s = (times - start) / h
        s2, s3 = s * s, s * s * s
        # position and quaternion side by side (``_values``, ``_rates``): one cubic of 7
        both = (2 * s3 - 3 * s2 + 1)[:, None] * self._values[k] \
            + ((s3 - 2 * s2 + s) * h)[:, None] * self._rates[k] \
            + (-2 * s3 + 3 * s2)[:, None] * self._values[k + 1] \
            + ((s3 - s2) * h)[:, None] * self._rates[k + 1]
        quaternion = both[:, 3:]
        quaternion /= np.linalg.norm(quaternion, axis=1)[:, None]
        return both[:, :3], quaternion

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
            ends, rates = self._values[k:k + 2].tolist(), self._rates[k:k + 2].tolist()
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


def interval_rates(a: Motion, b: Motion, radius_a: float, radius_b: float) -> np.ndarray:
    """
    Return a bound on |d distance / dt| in each sample interval (m/s), on the interpolant.

    A point of a body moves at its CG's velocity plus its rate times its distance
    from the CG (at most the body's radius about the CG, m): the distance between
    the bodies changes at most at their relative CG speed plus each one's rate
    times its radius. Both are bounded over the interval on the interpolant itself
    (``hermite_speeds``): the relative CG position's cubic, and each body's rate
    from its quaternion's cubic, 2 |q'| / |q| (|q| >= 1 - |q'| h from a unit end).
    """
    h = np.diff(a.time)
    speed = hermite_speeds(a.position - b.position, a.velocity_world - b.velocity_world,
                           a.time)
    out = speed
    for motion, radius in ((a, radius_a), (b, radius_b)):
        if not radius > 0:   # a point at the CG: its turn moves it not
            continue
        turning = hermite_speeds(motion.quaternion, motion.quaternion_rate, motion.time)
        # a quaternion cubic that strays half its length from a unit end: no useful
        # bound on the turn (a turn of a radian within a sample): every interval searched
        with np.errstate(invalid='ignore'):
            out = out + np.where(turning * h < 0.5, 2 * turning / (1 - turning * h),
                                 np.inf) * radius
    return out


def hermite_speeds(value, rate, time) -> np.ndarray:
    """
    Return, per sample interval, a bound on |d/dt| of the cubic Hermite interpolant.

    Its derivative is (1 - s) v0 + s v1 + 6 s (1 - s) (chord / h - (v0 + v1) / 2)
    for s in [0, 1]: at most the larger end rate plus 1.5 times that last vector.
    value, rate: (n, m) at the sample times (n,); returns (n - 1,).
    """
    h = np.diff(time)[:, None]
    with np.errstate(divide='ignore', invalid='ignore'):   # two samples at one time: no
        bent = (value[1:] - value[:-1]) / h - 0.5 * (rate[1:] + rate[:-1])   # interval
    ends = np.linalg.norm(rate, axis=1)
    found = np.maximum(ends[:-1], ends[1:]) + 1.5 * np.linalg.norm(bent, axis=1)
    return np.where(np.isfinite(found), found, np.inf)


def lower_bounds(first, second, rate, length):
    """
    Return the least a distance can reach between two of its values (m).

    first, second: the distance at the two ends of a piece of length ``length`` (s)
    over which it changes at most at ``rate`` (m/s): (first + second - rate length) / 2.
    Ends further apart than the rate allows (the bound does not hold there) give
    -inf: such a piece is searched.
    """
    with np.errstate(invalid='ignore'):   # no rate bound over no time: NaN, searched
        reach = rate * length
        bound = 0.5 * (first + second - reach)
        return np.where(np.abs(second - first) <= reach * (1 + 1e-9) + 1e-15, bound,
                        -np.inf)


def least(time, sampled, evaluate, rates, start: float, end: float, one=None) -> tuple:
    """
    Return (least distance, its time) over [start, end], between samples included.

    Parameters
    ----------
    time, sampled : ndarray (n,)
        Sample times (s) and the distance there (m).
    evaluate : callable (k, times) -> distances, or None
        The distance at times, k the sample interval of each (an index per
        time); None: the samples alone, for a run whose twists were not
        recorded.
    rates : ndarray (n - 1,)
        A bound on how fast the distance changes in each interval, m/s
        (``interval_rates``).
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
    lo, hi = max(start, time[0]), min(end, time[-1])
    rates = np.asarray(rates, dtype=float)
    intervals = np.flatnonzero((time[1:] > lo) & (time[:-1] < hi))
    # the bound over the whole interval holds over the part of it in the window
    bounds = lower_bounds(sampled[intervals], sampled[intervals + 1], rates[intervals],
                          np.diff(time)[intervals])
    if not math.isnan(best):
        keep = bounds < best - DISTANCE_TOLERANCE
        intervals, bounds = intervals[keep], bounds[keep]
    if not len(intervals):
        return best, when
    # every interval left probed in one call
    a, b = np.maximum(time[intervals], lo), np.minimum(time[intervals + 1], hi)
    keep = b > a
    intervals, a, b = intervals[keep], a[keep], b[keep]
    if not len(intervals):
        return best, when
    steps = np.linspace(0.0, 1.0, PROBES + 1)
    probes = a[:, None] + (b - a)[:, None] * steps
    values = np.asarray(evaluate(np.repeat(intervals, PROBES + 1), probes.ravel()),
                        dtype=float).reshape(probes.shape)
    j = np.argmin(values, axis=1)
    lowest = values[np.arange(len(j)), j]
    i = int(np.argmin(lowest))
    if math.isnan(best) or lowest[i] < best - GAIN:
        best, when = float(lowest[i]), float(probes[i, j[i]])
    # each probed piece bounded as the interval was: what cannot go DISTANCE_TOLERANCE below
    # the best is done
    rates = rates[intervals]
    pieces = lower_bounds(values[:, :-1], values[:, 1:], rates[:, None],
                          ((b - a) / PROBES)[:, None]).min(axis=1)
    for m in np.argsort(pieces):
        if pieces[m] >= best - DISTANCE_TOLERANCE:
            break
        k = int(intervals[m])
        single = (lambda t, k=k: float(evaluate(k, np.array([t]))[0])) if one is None \
            else (lambda t, k=k: one(k, t))
        found = _around(lambda times, k=k: evaluate(k, times), single, probes[m], values[m],
                        int(j[m]), float(rates[m]), best)
        if found[0] < best - GAIN:
            best, when = found
    return best, when


def _around(evaluate, single, probes, values, j: int, rate: float, best: float) -> tuple:
    """
    Return the least (value, time) near probe j of an interval: Brent about it.

    A least probe at an end of the probes (a window's edge, or a distance still
    falling at the interval's end) is approached first in one call, at distances
    from it shrinking by 1 / PROBES down to where the rate bound leaves no more than
    ``DISTANCE_TOLERANCE`` below it: Brent would take some 30 golden sections to
    close on an end, where a minimum inside needs about ten.
    """
    # no rate bound (inf): no distance tolerance to give, the time to 1e-13 s; below
    # 1e-3 m/s, 1e-6 s (within the distance tolerance still, and a search that ends)
    tolerance = min(max(DISTANCE_TOLERANCE / max(rate, 1e-300), 1e-13), 1e-6)
    last = len(probes) - 1
    if 0 < j < last:
        return _search(single, probes[j - 1], probes[j + 1], tolerance)
    end, inner = probes[j], probes[1] if j == 0 else probes[-2]
    width = abs(inner - end)
    # the piece next to the end 1 / PROBES ** count of it, at most the time tolerance
    count = max(1, min(16, math.ceil(math.log(max(width / tolerance, 2.0)) / math.log(PROBES))))
    times = end + (inner - end) * float(PROBES) ** -np.arange(count, 0, -1.0)
    near = np.concatenate([[end], times, [inner]])   # from the end inwards
    found = np.concatenate([[values[j]], np.asarray(evaluate(times), dtype=float),
                            [values[1 if j == 0 else -2]]])
    i = int(np.argmin(found))
    least = min(best, float(found[i]))
    if lower_bounds(found[:-1], found[1:], rate, np.abs(np.diff(near))).min() \
            >= least - DISTANCE_TOLERANCE:
        return float(found[i]), float(near[i])
    low, high = sorted((near[max(i - 1, 0)], near[min(i + 1, len(near) - 1)]))
    searched = _search(single, low, high, tolerance)
    return searched if searched[0] < found[i] else (float(found[i]), float(near[i]))


def _search(single, low: float, high: float, tolerance: float) -> tuple:
    """
    Return the least (value, time) over [low, high]: Brent (bounded) to ``tolerance`` (s).

    The variable is the time from ``low``: scipy's bounded Brent adds 1.5e-8 of
    the variable to its tolerance, which on the time itself (up to seconds) would be
    some 1e-8 s, not the tolerance asked for.
    """
    # imported here: a run imports this module for its metrics, and scipy costs most of a
    # second of start-up that a run without a distance window never needs
    from scipy.optimize import minimize_scalar
    found = minimize_scalar(lambda x: single(low + x), bounds=(0.0, high - low),
                            method='bounded', options={'xatol': tolerance})
    return float(found.fun), float(low + found.x)


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
                        interval_rates(motion_a, motion_b, radius_a, radius_b), start, end, one)
    k = int(np.searchsorted(t, when - 0.5e-9)) if not math.isnan(when) else 0
    if math.isnan(value) or (k < len(t) and abs(t[k] - when) <= 0.5e-9):
        return math.nan, math.nan, -1, -1
    (p_a, q_a), (p_b, q_b) = motion_a.at(k - 1, [when]), motion_b.at(k - 1, [when])
    found, index_a, index_b = point_distances(p_a, q_a, points_a, p_b, q_b, points_b)
    return float(found[0]), when, int(index_a[0]), int(index_b[0])
