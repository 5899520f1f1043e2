# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Scheduled wrenches whose start or end is tied to a release (SPEC section 7).

A wrench may start (or end) at a joint's or a release group's release plus
a delay. Until that release its time is unknown (inf); when it happens, the
simulator calls ``ScheduledLoads.released`` at the release's own time, located as
the release is (a time, a condition inside a step, a command), so the load
switches on (or off) exactly there, or at a later time the steps are cut at
like any scheduled time. ``loads.ScheduledLoads`` holds a ``Ties`` and its
wrenches' start and end times.
"""

from __future__ import annotations

import numpy as np


def tied_joints(model, name) -> frozenset:
    """Return the joints of a joint's or a release group's name (empty for None)."""
    if not name:
        return frozenset()
    for group in getattr(model, 'release_groups', ()):
        if group.name == name:
            return frozenset(group.joints)
    return frozenset([model.joint_index(name)])


class Ties:
    """
    Which scheduled wrenches start or end at a release, and after what delay.

    Parameters
    ----------
    model : Model
        Its ``wrenches`` (``start_release``, ``end_release``: a joint's or a
        release group's name, or None for a time).

    """

    def __init__(self, model):
        self.wrenches = tuple(getattr(model, 'wrenches', ()))
        # per wrench: the joints whose release starts (ends) it, none if a time
        self._ties = [(tied_joints(model, w.start_release), tied_joints(model, w.end_release))
                      for w in self.wrenches]

    def times(self) -> tuple:
        """Return each wrench's start and end (s; inf while tied to a release, or no end)."""
        start = np.array([np.inf if w.start_release else w.start for w in self.wrenches],
                         dtype=float)
        end = np.array([np.inf if w.end_release or w.end is None else w.end
                        for w in self.wrenches], dtype=float)
        return start, end

    def released(self, joints, t: float, start: np.ndarray, end: np.ndarray) -> bool:
        """
        Time the starts and ends tied to the release of ``joints`` at t, in place.

        A start or end tied to a joint or a group is set to t plus its delay
        (once: at the first release of the joint or group). Returns True if
        any is now due at t.
        """
        joints = {int(k) for k in joints}
        due = False
        for k, (on, off) in enumerate(self._ties):
            w = self.wrenches[k]
            if on and start[k] == np.inf and joints & on:
                start[k] = t + w.start
                due = due or start[k] <= t
            if off and end[k] == np.inf and joints & off:
                end[k] = t + w.end
                due = due or end[k] <= t
        return due
