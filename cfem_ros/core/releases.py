# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Release triggers of a run's joints, where in a step they are reached, and the releases.

A joint is released at a time, or when its rotation from the start, the
separation of its two points or its load's magnitude first reaches a limit
(CFEM.md, "Releases"). Time triggers cut the steps; the other conditions are
watched at the end of each step, and a crossing is located inside the step
on the step's own RK4 map, s -> rk4(y0, s), so a run released at a condition
is the run cut there. The engine locates it in compiled code
(``kernel.locate``); ``Releases.crossing`` is the same search in Python, the
reference it is tested against.
"""

from __future__ import annotations

from typing import Callable, Optional

from cfem_ros.core import kernel
from cfem_ros.core.roots import brentq
from cfem_ros.core.topology import JointTables
import numpy as np

#: Indices of the release triggers in ``Releases.triggers``.
TRIGGER_CAUSES = ('time', 'angle', 'distance', 'force')


class Releases:
    """
    The release triggers of a model's joints, the joints still active, the releases so far.

    Parameters
    ----------
    tables : JointTables
        The run's joints; its ``triggers`` are shared, not copied.
    names : sequence of str
        The joints' names, for the events.

    Attributes
    ----------
    active : ndarray of bool, shape (n_joints,)
        Joints not yet released.
    events : list of dict
        Releases so far: ``{'event': 'release', 'joint', 'time', 'cause'}``.
    triggers : ndarray, shape (n_joints, 4)
        Time (s), angle (rad), distance (m), force (N) per joint; NaN: none.
    due : float or None
        Earliest release time of the active joints.
    watch, watch_limits, watch_triggers, watch_lines : ndarray
        The active joints with a condition, their limits (inf: none; NaN:
        none in ``watch_triggers``) and their lines in the topology's plan,
        for the kernel.

    """

    def __init__(self, tables: JointTables, names=(), group_of=()):
        self.triggers = tables.triggers
        self.names = tuple(names)
        self.group_of = tuple(group_of) or (None,) * len(self.names)
        self.active = np.ones(len(self.triggers), dtype=bool)
        self.events = []
        self._joints_i = tables.joints_i
        self._joints_f = tables.joints_f
        self.due: Optional[float] = None
        # the joints with a condition (angle, distance or force), and with a force one
        self._conditional = np.isfinite(self.triggers[:, 1:]).any(axis=1)
        self._by_force = np.isfinite(self.triggers[:, 3])

    def release(self, joints, t: float, cause: str) -> list:
        """Mark joints released at time t for a cause ('command', 'time', ...); return events."""
        events = []
        for k in joints:
            self.active[k] = False
            event = {'event': 'release', 'joint': self.names[k], 'time': t, 'cause': cause}
            if self.group_of[k] is not None:
                event['group'] = self.group_of[k]
            events.append(event)
            self.events.append(event)
        return events

    def update(self, active: np.ndarray, line: np.ndarray):
        """Watch the active joints (``line``: each joint's line in the new plan)."""
        watched = np.flatnonzero(active & self._conditional)
        self.watch = watched.astype(np.int64)
        limits = self.triggers[watched, 1:]
        self.watch_limits = np.ascontiguousarray(np.where(np.isfinite(limits), limits, np.inf))
        self.watch_triggers = np.ascontiguousarray(limits)
        self.watch_lines = np.ascontiguousarray(line[watched])
        times = self.triggers[active, 0]
        times = times[np.isfinite(times)]
        self.due = float(times.min()) if times.size else None

    def watched(self) -> tuple:
        """Return the watched joints as ``kernel.System`` takes them (after ``update``)."""
        return (self._joints_i, self._joints_f, self.watch, self.watch_limits,
                self.watch_triggers, self.watch_lines)

    def timed_out(self, active: np.ndarray, t: float) -> np.ndarray:
        """Return the active joints whose release time is t or earlier."""
        if self.due is None or t < self.due:
            return np.empty(0, dtype=np.int64)
        return np.flatnonzero(active & (self.triggers[:, 0] <= t))

    def values(self, y: np.ndarray, joints, joint_forces: Callable) -> np.ndarray:
        """Angle (rad), distance (m) and force (N) of some joints at y, (k, 3)."""
        out = np.zeros((len(joints), 3))
        kernel.conditions(np.ascontiguousarray(y), self._joints_i, self._joints_f,
                          np.asarray(joints, dtype=np.int64), out)
        if self._by_force[joints].any():
            out[:, 2] = np.linalg.norm(joint_forces(y), axis=1)[joints]
        return out

    def crossing(self, y0: np.ndarray, y1: np.ndarray, h: float, active: np.ndarray,
                 rk4: Callable, joint_forces: Callable):
        """
        Return the earliest condition reached in the step y0 -> y1, or None.

        Parameters
        ----------
        y0, y1 : ndarray
            The states at the step's start and end.
        h : float
            The step's length, s.
        active : ndarray of bool
            Joints not yet released.
        rk4 : callable
            ``rk4(y0, s)``, the step's map.
        joint_forces : callable
            ``joint_forces(y)``: each joint's force on its child at y, (n_joints, 3).

        Returns
        -------
        (s, joints, causes) or None
            Where in the step (0 < s <= h) the first condition is reached,
            the joints that reach it there, and the cause of each.

        """
        watched = np.flatnonzero(active & self._conditional)
        if not watched.size:
            return None
        limits = self.triggers[watched, 1:]
        reached = self.values(y1, watched, joint_forces) >= limits
        if not reached.any():
            return None
        return self._locate(y0, h, watched, reached, rk4, joint_forces)

    def _locate(self, y0, h, watched, reached, rk4, joint_forces):
        """Find the earliest crossing in (0, h] on the RK4 map s -> rk4(y0, s)."""
        best = (h, [], [])
        for row, col in zip(*np.nonzero(reached)):
            k = watched[row]

            def excess(s, k=k, col=col):
                state = y0 if s == 0.0 else rk4(y0, s)
                values = self.values(state, np.array([k]), joint_forces)
                return values[0, col] - self.triggers[k, 1 + col]

            if excess(0.0) >= 0.0:
                s = 0.0
            else:
                s = brentq(excess, 0.0, h, xtol=1e-15, rtol=4 * np.finfo(float).eps,
                           maxiter=200)
            if s < best[0] - 1e-15:
                best = (s, [k], [TRIGGER_CAUSES[1 + col]])
            elif abs(s - best[0]) <= 1e-15 and k not in best[1]:
                best[1].append(k)
                best[2].append(TRIGGER_CAUSES[1 + col])
        return best
