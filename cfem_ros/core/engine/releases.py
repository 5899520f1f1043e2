# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Release triggers of a run's joints, where in a step they are reached, and the releases.

A joint is released at a time, or when its rotation from the start, the
separation of its two points or its load's magnitude first reaches a limit
(CFEM.md, "Releases"). Time triggers cut the steps; the other conditions are
watched at the end of each step, and a crossing is located inside the step
on the step's own RK4 map, s -> rk4(y0, s), so a run released at a condition
is the run cut there. The kernel watches and locates them (``kernel.advance``,
``kernel.locate``: ``cpp/events.cpp``, the one implementation); this module
keeps the triggers and says which joints the kernel watches.
"""

from __future__ import annotations

from typing import Optional

from cfem_ros.core.engine.events import Event
from cfem_ros.core.engine.topology import JointTables
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
        Releases so far: ``{'event': Event.RELEASE, 'joint', 'time', 'cause'}``.
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
        # the joints with a condition (angle, distance or force)
        self._conditional = np.isfinite(self.triggers[:, 1:]).any(axis=1)

    def release(self, joints, t: float, cause: str) -> list:
        """Mark joints released at time t for a cause ('command', 'time', ...); return events."""
        events = []
        for k in joints:
            self.active[k] = False
            event = {'event': Event.RELEASE, 'joint': self.names[k], 'time': t, 'cause': cause}
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
