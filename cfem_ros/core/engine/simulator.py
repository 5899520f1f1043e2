# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The CFEM engine: a run in time, in RK4 steps, with its releases.

The state of n bodies is one flat array ``y`` of 13 n numbers, in blocks:
CG positions (world, m), CG velocities (world, m/s), quaternions (x, y, z, w,
body to world) and angular velocities (body axes, rad/s). Ground (fixed)
bodies are carried with zero inverse mass and inertia, so every formula is the
same for all bodies.

``Simulator`` owns the run's time, its status and the step loop: it steps in
the compiled kernel and cuts steps at release times, release conditions,
strokes' ends and contacts. It holds its parts rather than inheriting them:
the equations of motion (``dynamics.Dynamics``: bodies and applied loads),
the joints (``jointset.JointSet``: rows, releases, the active ``Topology``),
the kinematic bodies (``Carriers``), the braces, contact pairs and aero
tables watched (``watch.Watch``) and what a sample shows (``Sampling``).
"""

from __future__ import annotations

import logging
import math
from typing import Optional

from cfem_ros.core import rotations
from cfem_ros.core.engine.bodies import state_views
from cfem_ros.core.engine.carrier import Carriers
from cfem_ros.core.engine.dynamics import Dynamics
from cfem_ros.core.engine.events import AERO_EVENTS, Failure, LOAD_EVENTS, Status
from cfem_ros.core.engine.jointset import JointSet
from cfem_ros.core.engine.kernelcalls import (advance, diverged, DIVERGENCE_VIOLATION, locate,
                                              NOT_FINITE)
from cfem_ros.core.engine.sampling import (LOADS_NOT_FINITE, NumericalFailure, SampleGrid,
                                           Sampling, SINGULAR)
from cfem_ros.core.engine.startcheck import start_refusal
from cfem_ros.core.engine.strokes import stroke_end_event
from cfem_ros.core.engine.watch import Watch
from cfem_ros.core.errors import ArgumentError
from cfem_ros.core.model.model import Model
from cfem_ros.core.native import kernel
import numpy as np


class Simulator:
    """
    Step a model's bodies and joints in time with RK4.

    Parameters
    ----------
    model : Model
        Built by ``scenario.parse_scenario``.
    logger : logging.Logger, optional
        Where warnings go (velocity projection, redundant joints).
    check_start : bool
        A run that ends within its first step asks ``startcheck`` whether
        ``cfem-sim check`` refuses its scenario (True; the check's own
        trial runs say False).

    Attributes
    ----------
    t : float
        Simulated time, s.
    y : ndarray, shape (13 n,)
        The state (module docstring).
    status : Status
        ``RUNNING``; ``FAILED`` (a non-finite state or joint load, a violation
        beyond ``DIVERGENCE_VIOLATION``, a singular solve: the last good state
        kept); ``CONTACT`` (a pair with ``on_contact: stop`` touched) or
        ``AERO_OUTSIDE`` (a table's ``outside: stop``): stopped there.
    message, reason : str
        Why it failed or stopped, with the time, and without ('' while running).
        A run that ended within its first step of a scenario ``cfem-sim
        check`` refuses has check's line as its message (``refusal``).
    refusal : str
        Check's line (``startcheck.cannot_start``) if the run ended within
        its first step and check refuses its scenario; '' otherwise.
    failure : Failure or None
        Which failure (``FAILED`` only): what a caller tests, not the message.
    events : list of dict
        Releases so far: ``{'event': Event.RELEASE, 'joint', 'time', 'cause'}``
        (and ``'group'`` for a joint of a release group), the ends of
        ejector strokes (``strokes.stroke_end_event``), contacts
        (``{'event': Event.CONTACT, 'bodies', 'time', 'point', 'parts'}``) and
        the braces' pads letting go or touching again
        (``braces.contact_event``).
    active : ndarray of bool, shape (n_joints,)
        Joints not yet released.
    load_states : dict or None
        None unless an output asks for it (a viewer's load arrows): then, by
        the time (s) of each event located within a step that starts or
        ends a load (``LOAD_EVENTS``), the sample there: (``outputs()``,
        ``active_joints``, ``held_wrenches()``) just after it. A caller
        that steps over an event (to the next sample time) finds the state
        of its instant here.

    """

    def __init__(self, model: Model, logger: Optional[logging.Logger] = None, *,
                 check_start: bool = True):
        self.model = model
        self.check_start = check_start
        self.refusal = ''
        self.dynamics = dynamics = Dynamics(model, logger)
        # the dynamics' tables, read through the simulator too (the same arrays)
        self.log, self.eta, self.n, self.free = dynamics.log, dynamics.eta, dynamics.n, \
            dynamics.free
        self.kinematic, self.gravity = dynamics.kinematic, dynamics.gravity
        self.mass, self.inertia_body = dynamics.mass, dynamics.inertia_body
        self._bodies, self._scheduled = dynamics.bodies, dynamics.scheduled
        self._loads = dynamics.loads
        self.y = dynamics.y0
        self._stage_violation = 0.0   # the largest violation within the step being taken
        self.dt = float(model.dt)
        self.t = 0.0
        self.status = Status.RUNNING
        self.message = ''
        self.failure: Optional[Failure] = None
        self.reason = ''
        self.steps = 0
        self.max_violation = 0.0
        self._info = np.zeros(kernel.ADVANCE_INFO.WIDTH)   # advance's, reused
        self.load_states = None
        self.carriers = Carriers(self, self._bodies)   # kinematic bodies, their odometry
        if self.kinematic:
            self.carriers.place(0.0)
            self.carriers.start()

        pos0, _, quat0, _ = state_views(self.y, self.n)
        self.joint_set = JointSet(model, pos0, quat0)
        self.joints, self.groups = self.joint_set.tables, self.joint_set.groups
        self.releases = self.joint_set.releases
        self.sampling = Sampling(model, self.joints, self._scheduled)
        self._set_topology()
        self._fire_time_triggers()
        dynamics.project_velocities(self._topology, self.y)
        self.watch = Watch(model, self._scheduled, self.n)   # pads, pairs and aero tables
        self._watched(*self.watch.arm(self.y, self.t))   # an axis outside at t = 0 is told

    def set_state(self, y, *, start: bool = False):
        """
        Put the bodies at state y now, and watch on from there as from a start.

        The one way to set the state (a batch copy's initial state, the
        node's ``set_entity_state``): the wrenches on measure their strokes
        from y, and the braces, contact pairs and aero tables are watched
        from y (``Watch.arm``: an axis outside there is an event now, which
        stops the run if its table says so).

        Parameters
        ----------
        y : array_like, shape (13 n,)
            The state (module docstring); its velocities are used as given.
        start : bool
            y replaces the scenario's initial state (t = 0, no step taken):
            the aero events told of the scenario's own state are dropped. A
            run under way keeps its events, which outputs have taken.

        Raises
        ------
        ValueError
            If y is not of shape (13 n,), or start is asked after a step.

        """
        y = np.array(y, dtype=float)
        if y.shape != self.y.shape:
            raise ArgumentError(f'the state has shape {y.shape}; expected {self.y.shape} '
                                f'(13 numbers per body, {self.n} bodies)')
        if start and self.steps:
            raise ArgumentError(f'start: the run has taken {self.steps} steps (t = {self.t:.9g} '
                                's); expected a state set before the first step')
        self.y = y
        self._scheduled.reanchor(self.y)   # strokes measured from here
        if start:   # the scenario's initial state is not this run's: what it told goes
            self.events[:] = [e for e in self.events if e['event'] not in AERO_EVENTS]
        self._watched(*self.watch.arm(self.y, self.t))   # pads, pairs and tables from here

    def set_odometry(self, body, t: float, position, quaternion, velocity_body, rates_body):
        """Drive a kinematic body from an odometry message now (``Carriers.set_odometry``)."""
        self.carriers.set_odometry(body, t, position, quaternion, velocity_body, rates_body)

    def derivative(self, y: np.ndarray) -> np.ndarray:
        """Return dy/dt at state y (external wrenches held constant)."""
        return self.dynamics.derivative(self._topology, y)

    def joint_projection(self) -> np.ndarray:
        """Return the least (mass weighted) change of velocities that the joints allow, (n, 6)."""
        return self.dynamics.joint_projection(self._topology, self.y)

    def set_wrench(self, body, force, torque, body_axes: bool = False, point=None):
        """Hold an external force and moment on a body until replaced (``Dynamics.set_wrench``)."""
        self.dynamics.set_wrench(body, force, torque, body_axes, point)

    def held_wrenches(self) -> np.ndarray:
        """Return the wrenches held on the bodies, (n, 10) (``Dynamics.held_wrenches``)."""
        return self.dynamics.held_wrenches()

    def body_index(self, body) -> int:
        """Return the index of a body given by name or index."""
        return self.dynamics.body_index(body)

    def joint_index(self, joint) -> int:
        """Return the index of a joint given by name or index."""
        return self.dynamics.joint_index(joint)

    # ----------------------------------------- the state and a sample (Sampling)

    @property
    def position(self) -> np.ndarray:
        """CG positions, world, m, shape (n, 3)."""
        return state_views(self.y, self.n)[0].copy()

    @property
    def velocity(self) -> np.ndarray:
        """CG velocities, world axes, m/s, shape (n, 3)."""
        return state_views(self.y, self.n)[1].copy()

    @property
    def orientation(self) -> np.ndarray:
        """Return unit quaternions (x, y, z, w), body to world, shape (n, 4)."""
        return state_views(self.y, self.n)[2].copy()

    @property
    def rates(self) -> np.ndarray:
        """Angular velocities (P, Q, R), body axes, rad/s, shape (n, 3)."""
        return state_views(self.y, self.n)[3].copy()

    def velocity_body(self) -> np.ndarray:
        """CG velocities in body axes, m/s, shape (n, 3)."""
        _, vel, quat, _ = state_views(self.y, self.n)
        return rotations.to_body(quat, vel)

    def joint_wrenches(self):
        """Return the joints' loads on their children now (``Sampling.joint_loads``)."""
        return self.sampling.joint_loads(self.y)[:2]

    @property
    def active_joints(self) -> tuple:
        """Return the active joints (model indices, ascending)."""
        return self.sampling.active_joints

    def outputs(self, out: Optional[np.ndarray] = None) -> np.ndarray:
        """Return what a sample publishes now, in one kernel call (``Sampling.outputs_size``)."""
        out = np.empty(self.sampling.outputs_size()) if out is None else out
        code = kernel.sample_outputs(self._topology.system, self.y, out)
        if code == kernel.SINGULAR or code == kernel.LOADS_NOT_FINITE:   # else a finite row
            raise (NumericalFailure(SINGULAR, Failure.SINGULAR) if code == kernel.SINGULAR
                   else NumericalFailure(LOADS_NOT_FINITE, Failure.LOADS_NOT_FINITE))
        return out

    @property
    def applied_sources(self) -> list:
        """Return (body, source) of each scheduled load a sample shows (``outputs``)."""
        return self.sampling.applied_sources

    def applied_loads(self) -> np.ndarray:
        """Return each applied source's force and moment about its body's CG, world, (k, 6)."""
        return self.sampling.applied_loads(self.outputs())

    def air(self, outputs: Optional[np.ndarray] = None) -> np.ndarray:
        """Return the air each aero body sees, (k, 12), of outputs if given (``Sampling.air``)."""
        return self.sampling.air(self.outputs() if outputs is None else outputs)

    def relative_states(self) -> np.ndarray:
        """Return each reference pair's relative state, (k, 13) (``Sampling.relative_states``)."""
        return self.sampling.relative_states(self.y)

    def joint_points(self, y: Optional[np.ndarray] = None):
        """Return each joint's point on its parent and on its child, world, m, (n_joints, 3)."""
        return self.sampling.joint_points(self.y if y is None else y)

    def joint_angles(self, y: Optional[np.ndarray] = None) -> np.ndarray:
        """Rotation of each child relative to its parent since t = 0, rad."""
        return self.sampling.joint_angles(self.y if y is None else y)

    def constraint_violation(self) -> float:
        """Largest |g| of the active rows now (m, or rad for rotation rows)."""
        return self.sampling.constraint_violation(self.y)

    # -------------------------------------------------------------- releases

    def _set_topology(self):
        """Rebuild the active joints' rows (``JointSet.rebuild``)."""
        self._topology = self.joint_set.rebuild(self.dynamics, self.sampling, self.y)
        self.dof = self.joint_set.dof

    def release(self, joint, cause: str = 'command') -> dict:
        """
        Release now an active joint, or a release group, or several (names apart).

        ``joint``: an index, or a name, or names separated by spaces or
        commas (``groups.command_names``), all released at this instant with
        the rest of their groups. Returns the first event (``release_all``
        returns them all). ValueError if a name is unknown or nothing named
        is still active.
        """
        return self.release_all(joint, cause)[0]

    def release_all(self, names, cause: str = 'command') -> list:
        """Release as ``release`` does; return every event."""
        return self._release(self.joint_set.commanded(names, self.joint_index), cause)

    def _release(self, joints, cause):
        released, events = self.joint_set.release(joints, self.t, cause)
        self._set_topology()
        # wrenches tied to these releases: on (or off) now, or at a time to cut a step at
        if self._scheduled.released(released, self.t):
            self._scheduled.switch(self.t, self.y)
        return events

    @property
    def active(self) -> np.ndarray:
        """Return the joints not yet released, bool, (n_joints,) (``Releases.active``)."""
        return self.releases.active

    @property
    def events(self) -> list:
        """Return the releases and stroke ends so far, in order (``Releases.events``)."""
        return self.releases.events

    # ------------------------------------------------------------- stepping

    def advance_to(self, t_target: float, limit: Optional[float] = None,
                   samples: Optional[SampleGrid] = None, *,
                   release_at_end: bool = True) -> bool:
        """
        Integrate to t_target in RK4 steps of dt, the last one cut to land on it.

        Steps are also cut at release times, and a step in which a release
        condition is crossed is cut at the crossing, located on the step's own
        RK4 map. With ``limit``, stop before the first step that would end
        after it: the steps taken are the same as those toward t_target
        without a limit, so a run paced by a clock is the run without one.
        With ``samples``, the samples on its grid are taken on the way (one
        due now first), and the call returns early after a release or when
        the grid's rows are full, so that the caller can record the events
        and the samples in time order and call again. A joint whose release
        time is where the call ends is released before it returns, unless
        ``release_at_end`` is False: then it stays for the caller to sample
        (a release at t acts after the samples at t) and is released by
        ``release_due()`` or the next call.
        Returns False (and sets ``status`` and ``message``) if the run failed
        (the state is then the last good one) or stopped at a contact (status
        ``CONTACT``, the state the one at the contact).

        Raises
        ------
        ValueError
            If t_target is not finite or before the current time, or limit is NaN.

        """
        t_target = float(t_target)
        if not math.isfinite(t_target):
            raise ArgumentError(f't_target is {t_target!r}; expected a finite time in s')
        if t_target < self.t:
            raise ArgumentError(f't_target is {t_target:.9g} s, before the current time '
                                f'{self.t:.9g} s; time only moves forward')
        limit = math.inf if limit is None else float(limit)
        if math.isnan(limit):
            raise ArgumentError('limit is nan; expected a time in s (inf for none)')
        if self.status is not Status.RUNNING:
            return False
        if samples is not None and samples.rows.shape[1] not in (
                0, self.sampling.outputs_size()):
            raise ArgumentError(f'sample rows have {samples.rows.shape[1]} columns; the outputs '
                                f'of this state have {self.sampling.outputs_size()}')
        steps = self.steps

        def release_now():
            # a release at t acts after the samples at t and at the end of a call
            # that stops at t, as inputs do (the caller takes the sample first)
            return samples is None or samples.next_time > self.t

        try:
            if release_now():
                self._fire_time_triggers()   # left by a call that stopped at its time
            while self.t < t_target or (samples is not None and self.t >= samples.next_time):
                due = self._next_time_trigger()
                due = math.inf if due is None else due
                result = self._advance(t_target, due, limit, samples)
                if result == kernel.CONDITION:
                    # a release condition is reached within the next step: locate it
                    goal = t_target if samples is None else min(t_target, samples.next_time)
                    remaining = goal - self.t
                    if remaining <= self.dt * (1.0 + 1e-9):
                        h, t_end = remaining, goal
                    else:
                        h, t_end = self.dt, self.t + self.dt
                    if due < t_end:
                        h, t_end = due - self.t, due
                    self._step(h, t_end)
                    if self.status is not Status.RUNNING:
                        return False   # shapes touched: the run stops here (CONTACT)
                if (self.t < t_target or release_at_end) and release_now():
                    self._fire_time_triggers()
                if samples is not None:
                    break   # back to the caller: rows to take, or a release's events
                if result != kernel.CONDITION and self.t < t_target and self.t < due:
                    break   # the next step would end after limit
            if self.t >= t_target and self.steps > steps:
                self._check_violation()   # the kernel checks each step's start, not the end
            self.carriers.check()
            self.events.extend(self.watch.aero.atmosphere(self.y, self.t))
        except NumericalFailure as err:
            self.fail(str(err), err.failure)
            return False
        return True

    def _advance(self, t_target, due, limit, samples) -> int:
        """Take the kernel's steps toward t_target (``kernelcalls.advance``); its result."""
        done = advance(self._topology.system, self.y, self._info, self.t, self.max_violation,
                       t_target, due, limit, self.dt, samples)
        self.t = done.t
        self.steps += done.steps
        self.max_violation = done.violation
        if done.error is not None:
            raise done.error
        return done.result

    def _check_violation(self):
        """Fail if the joints are violated beyond ``DIVERGENCE_VIOLATION`` now."""
        violation = self.constraint_violation()
        if violation > DIVERGENCE_VIOLATION:
            raise diverged(violation)

    def fail(self, reason: str, failure: Failure = Failure.OTHER):
        """Stop the run as failed now (``status``, ``failure``, ``message`` with the time)."""
        if self.status is Status.RUNNING:
            self.status, self.failure, self.reason = Status.FAILED, failure, reason
            self.message = f'at t = {self.t:.9g} s: {reason}'
            self._refused_at_start()

    def release_due(self) -> list:
        """
        Release the joints whose release time has come, now; return the events.

        ``advance_to`` leaves a release due at the time a call ends to the
        next call, so that a sample taken at that time still shows the
        joint (a release at t acts after the samples at t, whatever its
        cause); a caller that samples calls this after its sample.
        """
        before = len(self.events)
        self._fire_time_triggers()
        return self.events[before:]

    def _next_time_trigger(self) -> Optional[float]:
        due = self.releases.due   # changes with the topology
        switch = self._scheduled.due(self.t)   # scheduled wrenches' start and end (loads.py)
        return due if switch is None else switch if due is None else min(due, switch)

    def _fire_time_triggers(self):
        self._scheduled.switch(self.t, self.y)   # scheduled wrenches (loads.py)
        due = self.releases.timed_out(self.active, self.t)
        if due.size:
            self._release(due, 'time')

    def _step(self, h, t_end):
        """Advance one step of length h to t_end, locating condition releases and stroke ends."""
        events = len(self.events)
        self._locate_step(h, t_end)
        if self.load_states is not None and any(
                e.get('event') in LOAD_EVENTS for e in self.events[events:]):
            self.load_states[self.t] = (self.outputs(), self.active_joints,
                                        self.held_wrenches())

    def _locate_step(self, h, t_end):
        """Take the step of ``_step``: its events, and the state at the first of them."""
        self._stage_violation = 0.0
        y0 = self.y
        self._scheduled.set_time(self.t)
        if self.kinematic:
            kernel.motion_set_time(self._bodies, self.t)   # motion.py
        y1, ys, crossing, stroke, self._stage_violation = locate(
            self._topology.system, y0, h, self._stage_violation)
        if stroke is not None and (crossing is None or crossing[0] >= stroke[0]):
            # an ejector's stroke ends first (or with a release), or shapes touch
            s, rows = stroke
            wrenches = [k for k in rows if k < self._scheduled.count]
            self._commit(ys if s < h else y1, self.t + s if s < h else t_end)
            self._scheduled.end_strokes(wrenches)   # an event for each (strokes.py)
            self.events.extend(stroke_end_event(self, k) for k in wrenches)
            self._watched(*self.watch.located(rows, self.y, y1, self.t))   # pads, pairs, air
            if crossing is not None and crossing[0] <= s:
                for k, cause in zip(crossing[1], crossing[2]):
                    self._release([k], cause)
            self._fire_time_triggers()
        elif crossing is None:
            self._commit(y1, t_end)
        else:
            s, joints, causes = crossing
            self._commit(ys if s < h else y1, self.t + s if s < h else t_end)
            for k, cause in zip(joints, causes):
                self._release([k], cause)

    def _watched(self, events: list, stops: list):
        """Record the watch's events; stop the run as the first stop says (``Watch``)."""
        self.events.extend(events)
        if stops and self.status is Status.RUNNING:
            self.status, self.message = stops[0]
            self.reason = self.message
            self._refused_at_start()

    def _refused_at_start(self):
        """Give check's line as the message of a run check refuses, ended at its start."""
        if self.check_start:
            self.refusal = start_refusal(self)   # '' at once unless it ended in its first step
            self.message = self.refusal or self.message

    def _commit(self, y1, t1):
        if not np.isfinite(y1).all():
            raise NumericalFailure(NOT_FINITE, Failure.NOT_FINITE)
        if self._stage_violation > DIVERGENCE_VIOLATION:
            raise diverged(self._stage_violation)
        self.max_violation = max(self.max_violation, self._stage_violation)
        self.y = y1
        self.t = t1
        self._scheduled.set_time(t1)
        if self.kinematic:
            self.carriers.place(t1)   # the state, and accelerations, at t1 (motion.py)
        self.steps += 1
