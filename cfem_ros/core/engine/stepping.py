# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A simulator's step loop: the kernel's steps, cut at release times, crossings and strokes.

``Stepper`` takes the steps of ``Simulator.advance_to`` on the simulator
that holds it: it calls the compiled kernel (``kernelcalls.advance``) for
the steps that end nowhere special, locates on a step's own RK4 map a
release condition crossed, an ejector's stroke ending or shapes touching
(``kernelcalls.locate``), and fires the releases and scheduled wrenches
whose time has come. It acts on the simulator's public state (``y``,
``t``, ``steps``, ``max_violation``, ``events``) and asks it to release
joints (``Simulator.release_indices``), to record what the watch saw
(``Simulator.record_watch``) and to fail (``Simulator.fail``).
"""

from __future__ import annotations

import math
from typing import Optional

from cfem_ros.core.engine.events import Failure, LOAD_EVENTS, Status
from cfem_ros.core.engine.kernelcalls import (advance, diverged, DIVERGENCE_VIOLATION, locate,
                                              NOT_FINITE)
from cfem_ros.core.engine.sampling import NumericalFailure, SampleGrid
from cfem_ros.core.engine.strokes import stroke_end_event
from cfem_ros.core.errors import ArgumentError
from cfem_ros.core.native import kernel
import numpy as np


class Stepper:
    """
    Take a simulator's RK4 steps toward a time (``Simulator.advance_to``).

    Attributes
    ----------
    stage_violation : float
        The largest joint violation within the step being located.

    """

    def __init__(self, sim, dynamics):
        self.sim = sim
        self._scheduled, self._bodies = dynamics.scheduled, dynamics.bodies
        self.stage_violation = 0.0
        self._info = np.zeros(kernel.ADVANCE_INFO.WIDTH)   # advance's, reused

    def run_to(self, t_target: float, limit: Optional[float], samples: Optional[SampleGrid],
               release_at_end: bool) -> bool:
        """Step as ``Simulator.advance_to`` says (its arguments checked); False if it failed."""
        sim = self.sim
        t_target = float(t_target)
        if not math.isfinite(t_target):
            raise ArgumentError(f't_target is {t_target!r}; expected a finite time in s')
        if t_target < sim.t:
            raise ArgumentError(f't_target is {t_target:.9g} s, before the current time '
                                f'{sim.t:.9g} s; time only moves forward')
        limit = math.inf if limit is None else float(limit)
        if math.isnan(limit):
            raise ArgumentError('limit is nan; expected a time in s (inf for none)')
        if sim.status is not Status.RUNNING:
            return False
        if samples is not None and samples.rows.shape[1] not in (
                0, sim.sampling.outputs_size()):
            raise ArgumentError(f'sample rows have {samples.rows.shape[1]} columns; the outputs '
                                f'of this state have {sim.sampling.outputs_size()}')
        steps = sim.steps

        def release_now():
            # a release at t acts after the samples at t and at the end of a call
            # that stops at t, as inputs do (the caller takes the sample first)
            return samples is None or samples.next_time > sim.t

        try:
            if release_now():
                self.fire_time_triggers()   # left by a call that stopped at its time
            while sim.t < t_target or (samples is not None and sim.t >= samples.next_time):
                due = self._next_time_trigger()
                due = math.inf if due is None else due
                result = self.advance(t_target, due, limit, samples)
                if result == kernel.CONDITION:
                    # a release condition is reached within the next step: locate it
                    goal = t_target if samples is None else min(t_target, samples.next_time)
                    remaining = goal - sim.t
                    if remaining <= sim.dt * (1.0 + 1e-9):
                        h, t_end = remaining, goal
                    else:
                        h, t_end = sim.dt, sim.t + sim.dt
                    if due < t_end:
                        h, t_end = due - sim.t, due
                    self._step(h, t_end)
                    if sim.status is not Status.RUNNING:
                        return False   # shapes touched: the run stops here (CONTACT)
                if (sim.t < t_target or release_at_end) and release_now():
                    self.fire_time_triggers()
                if samples is not None:
                    break   # back to the caller: rows to take, or a release's events
                if result != kernel.CONDITION and sim.t < t_target and sim.t < due:
                    break   # the next step would end after limit
            if sim.t >= t_target and sim.steps > steps:
                self._check_violation()   # the kernel checks each step's start, not the end
            sim.carriers.check()
            sim.events.extend(sim.watch.aero.atmosphere(sim.y, sim.t))
        except NumericalFailure as err:
            sim.fail(str(err), err.failure)
            return False
        return True

    def advance(self, t_target, due, limit, samples) -> int:
        """Take the kernel's steps toward t_target (``kernelcalls.advance``); its result."""
        sim = self.sim
        done = advance(sim.topology.system, sim.y, self._info, sim.t, sim.max_violation,
                       t_target, due, limit, sim.dt, samples)
        sim.t = done.t
        sim.steps += done.steps
        sim.max_violation = done.violation
        if done.error is not None:
            raise done.error
        return done.result

    def _check_violation(self):
        """Fail if the joints are violated beyond ``DIVERGENCE_VIOLATION`` now."""
        violation = self.sim.constraint_violation()
        if violation > DIVERGENCE_VIOLATION:
            raise diverged(violation)

    def _next_time_trigger(self) -> Optional[float]:
        sim = self.sim
        due = sim.releases.due   # changes with the topology
        switch = self._scheduled.due(sim.t)   # scheduled wrenches' start and end (loads.py)
        return due if switch is None else switch if due is None else min(due, switch)

    def fire_time_triggers(self):
        """Switch the scheduled wrenches due now, and release the joints whose time has come."""
        sim = self.sim
        self._scheduled.switch(sim.t, sim.y)   # scheduled wrenches (loads.py)
        due = sim.releases.timed_out(sim.active, sim.t)
        if due.size:
            sim.release_indices(due, 'time')

    def _step(self, h, t_end):
        """Advance one step of length h to t_end, locating condition releases and stroke ends."""
        sim = self.sim
        events = len(sim.events)
        self._locate_step(h, t_end)
        if sim.load_states is not None and any(
                e.get('event') in LOAD_EVENTS for e in sim.events[events:]):
            sim.load_states[sim.t] = (sim.outputs(), sim.active_joints, sim.held_wrenches())

    def _locate_step(self, h, t_end):
        """Take the step of ``_step``: its events, and the state at the first of them."""
        sim = self.sim
        self.stage_violation = 0.0
        y0 = sim.y
        self._scheduled.set_time(sim.t)
        if sim.kinematic:
            kernel.motion_set_time(self._bodies, sim.t)   # motion.py
        y1, ys, crossing, stroke, self.stage_violation = locate(
            sim.topology.system, y0, h, self.stage_violation)
        if stroke is not None and (crossing is None or crossing[0] >= stroke[0]):
            # an ejector's stroke ends first (or with a release), or shapes touch
            s, rows = stroke
            wrenches = [k for k in rows if k < self._scheduled.count]
            self._commit(ys if s < h else y1, sim.t + s if s < h else t_end)
            self._scheduled.end_strokes(wrenches)   # an event for each (strokes.py)
            sim.events.extend(stroke_end_event(sim, k) for k in wrenches)
            sim.record_watch(*sim.watch.located(rows, sim.y, y1, sim.t))   # pads, pairs, air
            if crossing is not None and crossing[0] <= s:
                for k, cause in zip(crossing[1], crossing[2]):
                    sim.release_indices([k], cause)
            self.fire_time_triggers()
        elif crossing is None:
            self._commit(y1, t_end)
        else:
            s, joints, causes = crossing
            self._commit(ys if s < h else y1, sim.t + s if s < h else t_end)
            for k, cause in zip(joints, causes):
                sim.release_indices([k], cause)

    def _commit(self, y1, t1):
        sim = self.sim
        if not np.isfinite(y1).all():
            raise NumericalFailure(NOT_FINITE, Failure.NOT_FINITE)
        if self.stage_violation > DIVERGENCE_VIOLATION:
            raise diverged(self.stage_violation)
        sim.max_violation = max(sim.max_violation, self.stage_violation)
        sim.y = y1
        sim.t = t1
        self._scheduled.set_time(t1)
        if sim.kinematic:
            sim.carriers.place(t1)   # the state, and accelerations, at t1 (motion.py)
        sim.steps += 1
