# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Scheduled wrenches whose start or end is tied to a release (SPEC section 7).

A wrench may start (or end) at a joint's or a release group's release plus
a delay. Until that release its time is unknown (inf); when it happens, the
simulator calls ``TiedLoads.released`` at the release's own time, located as
the release is (a time, a condition inside a step, a command), so the load
switches on (or off) exactly there, or at a later time the steps are cut at
like any scheduled time. Everything else is ``loads.ScheduledLoads``.
"""

from __future__ import annotations

from cfem_ros.core.engine.loads import ScheduledLoads
from cfem_ros.core.native.kernel import LOADS
import numpy as np


def tied_joints(model, name) -> frozenset:
    """Return the joints of a joint's or a release group's name (empty for None)."""
    if not name:
        return frozenset()
    for group in getattr(model, 'release_groups', ()):
        if group.name == name:
            return frozenset(group.joints)
    return frozenset([model.joint_index(name)])


class TiedLoads(ScheduledLoads):
    """
    ``ScheduledLoads`` whose start and end times may wait for a release.

    Attributes
    ----------
    start, end : ndarray, shape (count,)
        Per wrench: when it switches on and off, s; inf while it waits for
        the release it is tied to (``released``), or for no end.

    """

    def __init__(self, model, n: int):
        super().__init__(model, n)
        wrenches = getattr(model, 'wrenches', ())
        self.start = np.array([np.inf if w.start_release else w.start for w in wrenches],
                              dtype=float)
        self.end = np.array([np.inf if w.end_release or w.end is None else w.end
                             for w in wrenches], dtype=float)
        # per wrench: the joints whose release starts (ends) it, none if a time
        self._ties = [(tied_joints(model, w.start_release), tied_joints(model, w.end_release))
                      for w in wrenches]

    def due(self, t: float):
        """Return the next time after t at which a wrench switches, or None."""
        times = []
        for k in range(self.count):
            if self.done[k]:
                continue
            if not self.started[k] and t < self.start[k] < np.inf:
                times.append(self.start[k])
            elif self.started[k] and t < self.end[k] < np.inf:
                times.append(self.end[k])
        return float(min(times)) if times else None

    def switch(self, t: float, y: np.ndarray) -> bool:
        """Switch the wrenches whose start or end is t or earlier; True if any did."""
        changed = False
        for k in range(self.count):
            if self.done[k]:
                continue
            if not self.started[k] and self.end[k] <= t:
                self.done[k] = True   # its end came first (a release): it never starts
                continue
            if not self.started[k] and self.start[k] <= t:
                self.started[k] = True
                self._anchor(k, y)
                self.array[self.n + k, LOADS.S_START] = self.start[k]   # tables against time
                self.array[self.n + k, LOADS.S_ON] = 1.0
                changed = True
            if self.started[k] and self.end[k] <= t:
                self._off(k)
                changed = True
        return changed

    def released(self, joints, t: float) -> bool:
        """
        Time the wrenches tied to the release of ``joints`` at t.

        A start or end tied to a joint or a group is set to t plus its delay
        (once: at the first release of the joint or group). Returns True if
        any is now due at t (the caller then calls ``switch``).
        """
        joints = {int(k) for k in joints}
        due = False
        for k, (on, off) in enumerate(self._ties):
            w = self.model.wrenches[k]
            if on and self.start[k] == np.inf and joints & on:
                self.start[k] = t + w.start
                due = due or self.start[k] <= t
            if off and self.end[k] == np.inf and joints & off:
                self.end[k] = t + w.end
                due = due or self.end[k] <= t
        return due
