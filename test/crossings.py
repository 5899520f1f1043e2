# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A reference search of a step's crossings, which the compiled one (kernel.locate) must equal.

The package locates release conditions, stroke ends and contacts in one
place, the kernel (``cpp/events.cpp``). This reference, for the tests only,
locates release conditions and ejector stroke ends with scipy's ``brentq``
on the step's RK4 map ``s -> rk4(y0, s)``, one Python call per evaluation
of the kernel's own condition values, joint loads and strokes: the kernel's
search must give the same bits (its Brent iteration is scipy's, rounded the
same way: ``events.cpp`` is compiled without fused multiply-adds).
``PythonSteps`` is the engine stepping with this reference search.
"""

import math

from cfem_ros.core._kernel import testing
from cfem_ros.core.engine import kernelcalls

from cfem_ros.core.engine.releases import TRIGGER_CAUSES
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.engine.stepping import Stepper
from cfem_ros.core.engine.strokes import stroke_end_event
from cfem_ros.core.native import kernel
from cfem_ros.core.native.kernel import LOADS
import numpy as np
from scipy.optimize import brentq

#: scipy's brentq as the kernel calls its own (``kernel.CROSSING_*``).
TOLERANCES = {'xtol': kernel.CROSSING_XTOL, 'rtol': kernel.CROSSING_RTOL,
              'maxiter': kernel.CROSSING_MAXITER}


def rk4(sim, y, h):
    """Return the kernel's RK4 step of h from y; raise sim's largest stage violation."""
    out = np.empty_like(y)
    worst = testing.rk4_step(sim.topology.system, y, h, out)
    assert worst >= 0.0, 'singular solve'
    sim.stepper.stage_violation = max(sim.stepper.stage_violation, worst)
    return out


def joint_forces(sim, y):
    """Return each joint's force on its child at y, world, (n_joints, 3) (zero if released)."""
    return sim.sampling.joint_loads(y)[0]


def step_with_condition(sim, t_end):
    """
    Take the kernel's steps up to the first in which a condition is reached; return its h.

    The step is then the one ``Stepper._step`` takes next, its loads set to its start.
    """
    assert sim.stepper.advance(t_end, math.inf, math.inf, None) == kernel.CONDITION
    sim._scheduled.set_time(sim.t)
    return min(sim.dt, t_end - sim.t)


def condition_values(sim, y, joints):
    """Angle (rad), distance (m) and force (N) of some joints at y, (k, 3)."""
    out = np.zeros((len(joints), 3))
    testing.conditions(np.ascontiguousarray(y), sim.joints.joints_i, sim.joints.joints_f,
                       np.asarray(joints, dtype=np.int64), out)
    if np.isfinite(sim.releases.triggers[joints, 3]).any():
        out[:, 2] = np.linalg.norm(joint_forces(sim, y), axis=1)[joints]
    return out


def release_crossing(sim, y0, y1, h):
    """Return the earliest release condition reached in the step y0 -> y1, or None."""
    triggers = sim.releases.triggers
    watched = np.flatnonzero(sim.active & np.isfinite(triggers[:, 1:]).any(axis=1))
    if not watched.size:
        return None
    reached = condition_values(sim, y1, watched) >= triggers[watched, 1:]
    if not reached.any():
        return None
    best = (h, [], [])
    for row, col in zip(*np.nonzero(reached)):
        k = int(watched[row])

        def excess(s, k=k, col=col):
            state = y0 if s == 0.0 else rk4(sim, y0, s)
            return condition_values(sim, state, [k])[0, col] - triggers[k, 1 + col]

        s = 0.0 if excess(0.0) >= 0.0 else brentq(excess, 0.0, h, **TOLERANCES)
        if s < best[0] - 1e-15:
            best = (s, [k], [TRIGGER_CAUSES[1 + col]])
        elif abs(s - best[0]) <= 1e-15 and k not in best[1]:
            best[1].append(k)
            best[2].append(TRIGGER_CAUSES[1 + col])
    return best


def stroke_crossing(sim, y0, y1, h):
    """Return the earliest ejector stroke end in the step y0 -> y1 as (s, wrenches), or None."""
    loads, n = sim._scheduled.array, sim.n
    rows = loads[n:n + sim._scheduled.count]
    watched = np.flatnonzero((rows[:, LOADS.S_ON] > 0.0) & np.isfinite(rows[:, LOADS.S_STROKE]))
    if not watched.size:
        return None

    def strokes(y):
        out = np.empty(loads.shape[0] - n)
        testing.loads_strokes(np.ascontiguousarray(y), loads, int(n), out)
        return out

    stroke = rows[watched, LOADS.S_STROKE]
    reached = strokes(y1)[watched] >= stroke
    if not reached.any():
        return None
    best, which = h, []
    for k, limit in zip(watched[reached], stroke[reached]):
        def excess(s, k=k, limit=limit):
            return strokes(y0 if s == 0.0 else rk4(sim, y0, s))[k] - limit

        s = 0.0 if excess(0.0) >= 0.0 else brentq(excess, 0.0, h, **TOLERANCES)
        if s < best - 1e-15:
            best, which = s, [int(k)]
        elif abs(s - best) <= 1e-15:
            which.append(int(k))
    return best, which


def reference_locate(sim, h):
    """Return (y1, crossing, stroke, largest stage violation) found by the reference search."""
    sim.stepper.stage_violation = 0.0
    y0 = sim.y
    y1 = rk4(sim, y0, h)
    crossing = release_crossing(sim, y0, y1, h)
    stroke = stroke_crossing(sim, y0, y1, h) if sim._scheduled.count else None
    return y1, crossing, stroke, sim.stepper.stage_violation


def assert_same_location(sim, h):
    """Check the compiled search against the reference, bit for bit; return its findings."""
    y1, crossing, stroke, _ = reference_locate(sim, h)
    cut = min([c[0] for c in (crossing, stroke) if c is not None] + [h])
    ys = rk4(sim, sim.y, cut) if cut < h else None   # the state the step is cut at
    worst = sim.stepper.stage_violation
    y1_k, ys_k, crossing_k, stroke_k, worst_k = kernelcalls.locate(sim.topology.system, sim.y,
                                                                   h, 0.0)
    assert crossing_k == crossing
    assert stroke_k == stroke
    np.testing.assert_array_equal(y1_k, y1)
    if ys is not None:
        np.testing.assert_array_equal(ys_k, ys)
    assert worst_k == worst   # the same RK4 steps
    return crossing_k, stroke_k


class PythonStepper(Stepper):
    """The step loop with a step cut by the reference search (``reference_locate``)."""

    def _step(self, h, t_end):
        sim = self.sim
        self.stage_violation = 0.0
        y0 = sim.y
        sim._scheduled.set_time(sim.t)
        if sim.kinematic:
            kernel.motion_set_time(sim._bodies, sim.t)
        y1 = rk4(sim, y0, h)
        crossing = release_crossing(sim, y0, y1, h)
        if sim._scheduled.count:
            stroke = stroke_crossing(sim, y0, y1, h)
            if stroke is not None and (crossing is None or crossing[0] >= stroke[0]):
                s, wrenches = stroke
                self._commit(rk4(sim, y0, s) if s < h else y1, sim.t + s if s < h else t_end)
                sim._scheduled.end_strokes(wrenches)
                sim.events.extend(stroke_end_event(sim, k) for k in wrenches)
                if crossing is not None and crossing[0] <= s:
                    for k, cause in zip(crossing[1], crossing[2]):
                        sim.release_indices([k], cause)
                self.fire_time_triggers()
                return
        if crossing is None:
            self._commit(y1, t_end)
        else:
            s, joints, causes = crossing
            self._commit(rk4(sim, y0, s) if s < h else y1, sim.t + s if s < h else t_end)
            for k, cause in zip(joints, causes):
                sim.release_indices([k], cause)


class PythonSteps(Simulator):
    """The engine whose step loop is ``PythonStepper``."""

    def __init__(self, model):
        super().__init__(model)
        self.stepper = PythonStepper(self, self.dynamics)


def assert_same_runs(model, times):
    """Run model with the compiled and the reference search; check every state bit for bit."""
    ours, theirs = Simulator(model), PythonSteps(model)
    for t in times:
        assert ours.advance_to(t), ours.message
        assert theirs.advance_to(t), theirs.message
        np.testing.assert_array_equal(ours.y, theirs.y)
        assert (ours.t, ours.steps, ours.max_violation) == (
            theirs.t, theirs.steps, theirs.max_violation)
        assert ours.events == theirs.events
    return ours
