# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The Python search of a step's crossings, which the compiled one (kernel.locate) must equal.

``Releases.crossing`` and ``ScheduledLoads.crossing`` locate a release
condition and an ejector's stroke end with ``roots.brentq`` (scipy's
brentq, checked bit for bit in test_roots) on the step's RK4 map, one
Python call per evaluation; the engine does the same in one kernel call.
``PythonSteps`` is the engine stepping with the Python search, as it did
before the kernel did it.
"""

import math

from cfem_ros.core import kernel, kernelcalls
from cfem_ros.core.engine import Simulator
import numpy as np


def step_with_condition(sim, t_end):
    """
    Take the kernel's steps up to the first in which a condition is reached; return its h.

    The step is then the one ``Simulator._step`` takes next, its loads set to its start.
    """
    assert sim._advance(t_end, math.inf, math.inf, None) == kernel.CONDITION
    sim._scheduled.set_time(sim.t)
    return min(sim.dt, t_end - sim.t)


def python_locate(sim, h):
    """Return (y1, crossing, stroke, largest stage violation) found by the Python search."""
    sim._stage_violation = 0.0
    y0 = sim.y
    y1 = sim._rk4(y0, h)
    crossing = sim.releases.crossing(y0, y1, h, sim.active, sim._rk4, sim._joint_forces)
    stroke = sim._scheduled.crossing(y0, y1, h, sim._rk4) if sim._scheduled.count else None
    return y1, crossing, stroke, sim._stage_violation


def assert_same_location(sim, h):
    """Check the compiled search against the Python one, bit for bit; return its findings."""
    y1, crossing, stroke, _ = python_locate(sim, h)
    cut = min([c[0] for c in (crossing, stroke) if c is not None] + [h])
    ys = sim._rk4(sim.y, cut) if cut < h else None   # the state the step is cut at
    worst = sim._stage_violation
    y1_k, ys_k, crossing_k, stroke_k, worst_k = kernelcalls.locate(sim._topology.system, sim.y,
                                                                   h, 0.0)
    if crossing is not None:   # Python's lists of numpy integers
        crossing = (crossing[0], [int(k) for k in crossing[1]], crossing[2])
    assert crossing_k == crossing
    assert stroke_k == stroke
    np.testing.assert_array_equal(y1_k, y1)
    if ys is not None:
        np.testing.assert_array_equal(ys_k, ys)
    assert worst_k == worst   # the same RK4 steps
    return crossing_k, stroke_k


class PythonSteps(Simulator):
    """The engine with a step cut by the Python search (``python_locate``)."""

    def _step(self, h, t_end):
        self._stage_violation = 0.0
        y0 = self.y
        self._scheduled.set_time(self.t)
        if self.kinematic:
            kernel.motion_set_time(self._bodies, self.t)
        y1 = self._rk4(y0, h)
        crossing = self.releases.crossing(y0, y1, h, self.active, self._rk4, self._joint_forces)
        if self._scheduled.count:
            stroke = self._scheduled.crossing(y0, y1, h, self._rk4)
            if stroke is not None and (crossing is None or crossing[0] >= stroke[0]):
                s, wrenches = stroke
                self._commit(self._rk4(y0, s) if s < h else y1, self.t + s if s < h else t_end)
                self._end_strokes(wrenches)
                if crossing is not None and crossing[0] <= s:
                    for k, cause in zip(crossing[1], crossing[2]):
                        self._release([k], cause)
                self._fire_time_triggers()
                return
        if crossing is None:
            self._commit(y1, t_end)
        else:
            s, joints, causes = crossing
            self._commit(self._rk4(y0, s) if s < h else y1, self.t + s if s < h else t_end)
            for k, cause in zip(joints, causes):
                self._release([k], cause)


def assert_same_runs(model, times):
    """Run model with the compiled and the Python search; check every state bit for bit."""
    ours, theirs = Simulator(model), PythonSteps(model)
    for t in times:
        assert ours.advance_to(t), ours.message
        assert theirs.advance_to(t), theirs.message
        np.testing.assert_array_equal(ours.y, theirs.y)
        assert (ours.t, ours.steps, ours.max_violation) == (
            theirs.t, theirs.steps, theirs.max_violation)
        assert ours.events == theirs.events
    return ours
