# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Recorded poses in another body's axes: what a captive trajectory system gives.

``relative_pose`` composes two stacks of poses sample by sample (the body's
and the reference's, both body-to-world as recorded): the body's CG from
the reference's CG in the reference's axes, and its attitude relative to
the reference. ``relative_velocity`` gives the CG's velocity seen from the
reference (the compiled core's formula of a sample of a body with a
``reference``, ``kernel.relative_states``). ``relative_track`` does it for two bodies of a ``Run``
matched by their stamps; ``release_time`` gives a run's first release.
Used by ``cfem-sim export``, ``plot --relative-to`` and the sweep
envelopes; no second simulation is involved anywhere.
"""

from __future__ import annotations

from dataclasses import dataclass

from cfem_ros.core import rotations
from cfem_ros.recording.errors import RecordingError
import numpy as np

__all__ = ['RelativeTrack', 'relative_pose', 'relative_track', 'relative_velocity',
           'release_time', 'velocity_seen']


def relative_pose(position, quaternion, ref_position, ref_quaternion) -> tuple:
    """
    Return a body's pose relative to a reference body, in the reference's axes.

    Parameters
    ----------
    position, ref_position : array_like, shape (n, 3)
        The two CGs in the world frame, m.
    quaternion, ref_quaternion : array_like, shape (n, 4)
        Body-to-world attitudes, x y z w (any non-zero norm).

    Returns
    -------
    (ndarray (n, 3), ndarray (n, 4))
        ``R_ref^T (p - p_ref)``, the CG from the reference's CG in the
        reference's axes (m), and ``conj(q_ref) q``, the body-to-reference
        attitude (unit quaternions, x y z w): its Z-Y-X angles
        (``rotations.to_rpy_deg``) are the roll, pitch and yaw relative to
        the reference.

    """
    from cfem_ros.core.native import kernel
    position = np.asarray(position, dtype=float).reshape(-1, 3)
    if not len(position):
        return np.zeros((0, 3)), np.zeros((0, 4))
    still = np.zeros((len(position), 3))   # the pose only: the kernel's relative state
    out = kernel.relative_states(
        position, still, np.asarray(quaternion, dtype=float).reshape(-1, 4), still,
        np.asarray(ref_position, dtype=float).reshape(-1, 3), still,
        np.asarray(ref_quaternion, dtype=float).reshape(-1, 4), still)
    return out[:, kernel.SAMPLE.span('O_POSITION')], out[:, kernel.SAMPLE.span('O_QUATERNION')]


def relative_velocity(body, ref, mine=None, theirs=None) -> np.ndarray:
    """
    Return a body's CG velocity seen from a reference body, in the reference's axes, (n, 3).

    ``R_ref^T (v - v_ref - w_ref x (p - p_ref))``, m/s: the velocity relative
    to the reference-fixed point where the CG is, what a tracker on the
    reference measures (the time derivative of ``relative_pose``'s
    position). From the compiled core (``kernel.relative_states``), the
    formula a sample of a body with a ``reference`` holds.

    Parameters
    ----------
    body, ref : recording.tracks BodyTrack
        The two recorded bodies (CG, world velocity, attitude, body rates).
    mine, theirs : ndarray of int, optional
        Their samples to take, matched (all, if not given).

    """
    mine = slice(None) if mine is None else mine
    theirs = slice(None) if theirs is None else theirs
    return velocity_seen(body.position[mine], body.velocity_world[mine], body.quaternion[mine],
                         body.rates[mine], ref.position[theirs], ref.velocity_world[theirs],
                         ref.quaternion[theirs], ref.rates[theirs])


def velocity_seen(position, velocity, quaternion, rates, ref_position, ref_velocity,
                  ref_quaternion, ref_rates) -> np.ndarray:
    """
    Return ``relative_velocity`` of stacks of states, (n, 3) m/s in the reference's axes.

    CG positions and velocities in the world (m, m/s), attitudes x y z w
    (body to world), rates in body axes (rad/s), each (n, 3) or (n, 4).
    """
    from cfem_ros.core.native import kernel
    position = np.asarray(position, dtype=float).reshape(-1, 3)
    if not len(position):
        return np.zeros((0, 3))
    shaped = [np.asarray(a, dtype=float).reshape(len(position), -1) for a in (
        velocity, quaternion, rates, ref_position, ref_velocity, ref_quaternion, ref_rates)]
    out = kernel.relative_states(position, *shaped)
    return out[:, kernel.SAMPLE.span('O_VELOCITY')]


@dataclass
class RelativeTrack:
    """
    A body's recorded motion in a reference body's axes, at the samples both have.

    Attributes
    ----------
    name, reference : str
    time : ndarray (n,)
        s from the run's start.
    position : ndarray (n, 3)
        m, reference axes, from the reference's CG.
    quaternion : ndarray (n, 4)
        Body to reference, x y z w.
    euler_deg : ndarray (n, 3)
        Roll, pitch, yaw relative to the reference, Z-Y-X, deg.

    """

    name: str
    reference: str
    time: np.ndarray
    position: np.ndarray
    quaternion: np.ndarray
    euler_deg: np.ndarray


def matching(stamps: np.ndarray, ref_stamps: np.ndarray) -> tuple:
    """Return the indices (into stamps, into ref_stamps) of the stamps both hold."""
    _, mine, theirs = np.intersect1d(stamps, ref_stamps, assume_unique=True,
                                     return_indices=True)
    return mine, theirs


def relative_track(run, name: str, reference: str) -> RelativeTrack:
    """
    Return body ``name`` of a ``Run`` in the axes of body ``reference``.

    Only the samples whose stamps both bodies have (every sample of a
    cfem_ros recording).

    Raises
    ------
    RecordingError
        If either body is not in the recording.

    """
    for body in (name, reference):
        if body not in run.bodies:
            raise RecordingError(f'{run.path}: no body {body!r} in the recording (it has '
                                 f'{", ".join(run.bodies)})')
    body, ref = run.bodies[name], run.bodies[reference]
    mine, theirs = matching(body.stamp_ns, ref.stamp_ns)
    position, quaternion = relative_pose(body.position[mine], body.quaternion[mine],
                                         ref.position[theirs], ref.quaternion[theirs])
    euler = rotations.to_rpy_deg(quaternion) if len(quaternion) else np.zeros((0, 3))
    return RelativeTrack(name, reference, body.time[mine], position, quaternion, euler)


def release_time(run) -> float:
    """Return the time of a run's first release, s (NaN if nothing was released)."""
    releases = run.releases()
    return float(releases[0][0]) if releases else float('nan')
