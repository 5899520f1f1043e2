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
a release or an end of stroke, within h^2 / 16 times the jump). A body's
``track`` holds those values and rates per sample (``kernel.TRACK``).

The search of a window is the kernel's (``cpp/between.hpp``), one call per
window and pair of bodies: the least of a distance over the window from its
sampled values. A bound L on |d distance / dt| in each sample interval (from
the bodies' relative CG speed, and each one's rate times its radius about the
CG, both bounded over the interval on the interpolant itself) bounds the
distance there from below by (d0 + d1 - L h) / 2, d0 and d1 its ends (the rate
lets it fall from one end and rise to the other, no more). Only the intervals
whose bound is more than ``DISTANCE_TOLERANCE`` below the best found are
probed (``PROBES`` points each); the same bound on each probed piece prunes
them again; in each one left, the least is searched about its least probe by
Brent (bounded: scipy's ``minimize_scalar(method='bounded')``, step for step)
to a time tolerance of ``DISTANCE_TOLERANCE`` / L, so that the value found is
within ``DISTANCE_TOLERANCE`` of the interpolant's local least there (a least
probe at an end, a window's edge most often, is first approached at distances
from it shrinking by 1 / ``PROBES``: Brent closes on an end in some 30 golden
sections). A value within ``GAIN`` of the best sample keeps the sample (so
that a body at rest gives its sample's number to the bit).
"""

from __future__ import annotations

import math

from cfem_ros.core.native import kernel
from cfem_ros.core.native.kernel import LEAST, TRACK
import numpy as np

#: How close the least found comes to the interpolant's least, m: Brent stops within this
#: over the interval's rate bound in time (a distance changes by at most rate x time).
DISTANCE_TOLERANCE = kernel.BETWEEN_DISTANCE_TOLERANCE
#: A distance between samples replaces the least sample only below it by more than this, m.
GAIN = kernel.BETWEEN_GAIN
#: Points tried in a sample interval before the bounded minimisation.
PROBES = kernel.BETWEEN_PROBES
#: Sample times within this of a time are at it, s.
AT_SAMPLE = 0.5e-9


def motion(samples, body: str):
    """
    Return a body's track from a run's samples (``track``), or None without its whole twist.

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
        found = track(position, quaternion, velocity, rates)
    if made is not None:
        made[body] = found
    return found


def track(position, quaternion, velocity, rates) -> np.ndarray:
    """
    Return a body's track, (n, ``TRACK.WIDTH``): its Hermite values and their rates per sample.

    Parameters
    ----------
    position, quaternion, velocity, rates : ndarray (n, 3), (n, 4), (n, 3), (n, 3)
        CG position (world, m), attitude (x y z w, body to world), CG
        velocity (body axes, m/s) and body rates (rad/s), as sampled.

    Each quaternion is put on the side of the one before (one sign along the
    track); the velocity is turned into world axes and the rates made the
    quaternion's rate of change (the kernel's, ``kernel.track``).

    """
    return kernel.track(position, quaternion, velocity, rates)


#: The track of a run without twists: the samples alone.
NO_TRACK = np.empty((0, TRACK.WIDTH))


def at_sample(time, when: float):
    """Return the sample at time ``when`` (within ``AT_SAMPLE``), or None between samples."""
    k = int(np.searchsorted(time, when - AT_SAMPLE))
    return k if k < len(time) and abs(time[k] - when) <= AT_SAMPLE else None


def poses(found: np.ndarray) -> tuple:
    """Return ((position (1, 3), quaternion (1, 4)) of a, of b) of a least between samples."""
    pose_a, pose_b = found[LEAST.span('L_POSE_A')], found[LEAST.span('L_POSE_B')]
    position, quaternion = TRACK.span('T_POSITION'), TRACK.span('T_QUATERNION')
    return (pose_a[None, position], pose_a[None, quaternion]), \
        (pose_b[None, position], pose_b[None, quaternion])


def least_point_distance(samples, body_a, points_a, body_b, points_b, start, end):
    """
    Return (distance, time, index a, index b) of the least clearance between samples.

    NaN, NaN, -1, -1 when the window holds nothing, or when the least is at
    a sample (the caller's sampled figures stand); points in body axes, m.
    """
    t = np.asarray(samples.bodies[body_a][0], dtype=float)
    track_a, track_b = motion(samples, body_a), motion(samples, body_b)
    if track_a is None or track_b is None:
        return math.nan, math.nan, -1, -1
    found = kernel.least_point_distance(t, track_a, track_b, points_a, points_b, start, end)
    value, when = float(found[LEAST.L_DISTANCE]), float(found[LEAST.L_TIME])
    if math.isnan(value) or at_sample(t, when) is not None:
        return math.nan, math.nan, -1, -1
    return value, when, int(found[LEAST.L_POINT_A]), int(found[LEAST.L_POINT_B])
