# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The z-up frames that follow the bodies: ``<body>_view`` and ``<body>_chase`` (SPEC section 4).

A carrier's body axes are the scenario's (x forward, y right, z down in the
store examples): a viewer following the carrier's own frame shows the scene
upside down. Each kinematic body gets a frame ``<body>_view`` on ``/tf``,
child of the z-up root (``visuals.root_frame``): origin at the body's CG,
z along -gravity, x along the body's x axis projected on the level plane
(heading only: no pitch, no roll). A viewer whose display frame follows it
keeps the separation in view, right way up.

Each free body gets a frame ``<body>_chase``, child of the root too: origin
at the body's CG, z up, x along the first carrier's ``<carrier>_view`` x axis
(the root's x when there is no carrier). A viewer following it keeps that
body in view to the end of the run, right way up however it tumbles, seen
from the carrier's side.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from cfem_ros.core import rotations
from cfem_ros.core.native.kernel import SAMPLE
from cfem_ros.recording import visuals
import numpy as np

#: Suffix of a carrier's view frame: ``aircraft`` -> ``aircraft_view``.
SUFFIX = '_view'
#: Suffix of a free body's chase frame: ``store`` -> ``store_chase``.
CHASE = '_chase'


def carriers(model) -> list:
    """Return the indices of the kinematic bodies (given a ``motion``), in model order."""
    return [i for i, body in enumerate(model.bodies) if not body.fixed and not body.dynamic]


def free_bodies(model) -> list:
    """Return the indices of the free bodies (moved by their loads), in model order."""
    return [i for i, body in enumerate(model.bodies) if body.dynamic]


def frame_name(model, body: str, suffix: str = SUFFIX) -> str:
    """Return the view frame of a body: ``<body>_view`` (``_z_up`` added while that is taken)."""
    taken = ({model.frame_id, visuals.root_frame(model)} | {b.name for b in model.bodies}
             | {j.name for j in model.joints})
    name = body + suffix
    while name in taken:
        name += '_z_up'
    return name


def chase_name(model, body: str) -> str:
    """Return the chase frame of a free body: ``<body>_chase`` (``_z_up`` added if taken)."""
    return frame_name(model, body, CHASE)


def view_poses(up_xyzw: Optional[tuple], position: np.ndarray,
               quat_xyzw: np.ndarray) -> np.ndarray:
    """
    Return the view frames' poses in the root frame: translation and rotation x y z w.

    Parameters
    ----------
    up_xyzw : tuple of 4 float or None
        The rotation from the scenario's axes to the root's (``visuals.up_rotation``);
        None: the scenario's axes are the root's.
    position : ndarray, shape (k, 3)
        The bodies' CG positions, scenario (world) axes, m.
    quat_xyzw : ndarray, shape (k, 4)
        The bodies' attitudes, body to world.

    Returns
    -------
    ndarray, shape (k, 7)
        Origin at the CG (root axes, m); a turn about the root's z by the
        heading of the body's x axis on the level plane (0 when that axis is
        vertical).

    """
    position = np.asarray(position, dtype=float)
    x_world = rotations.matrices(np.asarray(quat_xyzw, dtype=float))[:, :, 0]
    if up_xyzw is not None:
        up = rotations.matrices(np.asarray(up_xyzw, dtype=float)[None])[0]
        position, x_world = position @ up.T, x_world @ up.T
    half = 0.5 * np.arctan2(x_world[:, 1], x_world[:, 0])
    out = np.zeros((len(position), 7))
    out[:, :3] = position
    out[:, 5], out[:, 6] = np.sin(half), np.cos(half)
    return out


@dataclass(frozen=True)
class ViewFrames:
    """
    A sample's z-up frames, computed from the bodies' poses in the sample.

    ``numbers(block)`` turns samples (rows in ``Simulator.outputs`` order:
    ``kernel.SAMPLE.BODY`` numbers per body) into 7 numbers per frame
    (translation, rotation x y z w from ``root`` to each of ``names``): the
    carriers' view frames (their numbers from ``pose_columns``), then the free
    bodies' chase frames (from ``chase_columns``).
    """

    root: str
    names: tuple
    pose_columns: tuple
    up_xyzw: Optional[tuple]
    chase_columns: tuple = ()

    @property
    def size(self) -> int:
        """Return how many numbers a sample's frames take."""
        return 7 * (len(self.pose_columns) + len(self.chase_columns))

    def numbers(self, block: np.ndarray) -> np.ndarray:
        """Return the frames of samples (k, columns) as (k, 7 per frame)."""
        views = [view_poses(self.up_xyzw, *_pose(block, c)) for c in self.pose_columns]
        chases = []
        for c in self.chase_columns:   # at the CG, turned as the first carrier's view
            chase = view_poses(self.up_xyzw, *_pose(block, c))
            chase[:, 3:] = views[0][:, 3:] if views else (0.0, 0.0, 0.0, 1.0)
            chases.append(chase)
        return np.hstack(views + chases)


def _pose(block: np.ndarray, first: int) -> tuple:
    """Return the CG positions and attitudes of samples (k, columns), a body's from first."""
    return (block[:, first + SAMPLE.O_POSITION:][:, :SAMPLE.width('O_POSITION')],
            block[:, first + SAMPLE.O_QUATERNION:][:, :SAMPLE.width('O_QUATERNION')])


def of_model(model) -> Optional[ViewFrames]:
    """Return the view and chase frames of a model, None if it has neither."""
    bodies, free = carriers(model), free_bodies(model)
    if not bodies and not free:
        return None
    names = tuple(frame_name(model, model.bodies[i].name) for i in bodies) + tuple(
        chase_name(model, model.bodies[i].name) for i in free)
    return ViewFrames(visuals.root_frame(model), names, tuple(SAMPLE.BODY * i for i in bodies),
                      visuals.up_rotation(model.gravity), tuple(SAMPLE.BODY * i for i in free))


def state_poses(model, position: np.ndarray, quat_xyzw: np.ndarray) -> np.ndarray:
    """
    Return the view and chase frames' poses at one state, (frames, 7), as ``of_model`` names them.

    position, quat_xyzw: every body's CG (world, m) and attitude, (n, 3) and (n, 4).
    """
    frames = of_model(model)
    if frames is None:
        return np.zeros((0, 7))
    state = np.zeros((1, SAMPLE.BODY * len(model.bodies)))
    rows = state.reshape(len(model.bodies), SAMPLE.BODY)
    rows[:, SAMPLE.span('O_POSITION')] = position
    rows[:, SAMPLE.span('O_QUATERNION')] = quat_xyzw
    return frames.numbers(state).reshape(-1, 7)


def transforms(model, stamp: dict, position: np.ndarray, quat_xyzw: np.ndarray) -> list:
    """
    Return the view and chase frames at one state as TransformStamped dicts (for the node).

    position, quat_xyzw: every body's CG (world, m) and attitude, (n, 3) and (n, 4).
    """
    frames = of_model(model)
    if frames is None:
        return []
    poses = state_poses(model, position, quat_xyzw)
    return [{'header': {'stamp': stamp, 'frame_id': frames.root}, 'child_frame_id': name,
             'transform': {'translation': dict(zip('xyz', map(float, pose[:3]))),
                           'rotation': dict(zip('xyzw', map(float, pose[3:])))}}
            for name, pose in zip(frames.names, poses)]
