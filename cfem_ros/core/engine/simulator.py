# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The CFEM engine: a run in time, in RK4 steps, with its releases.

The state of n bodies is one flat array ``y`` of 13 n numbers, in blocks:
CG positions (world, m), CG velocities (world, m/s), quaternions (x, y, z, w,
body to world) and angular velocities (body axes, rad/s), as ``kernel.STATE``
lays them out (``bodies.state_views``). Ground (fixed)
bodies are carried with zero inverse mass and inertia, so every formula is the
same for all bodies.

``Simulator`` owns the run's time and its status; its step loop is held
(``stepping.Stepper``: the compiled kernel's steps, cut at release times,
release conditions, strokes' ends and contacts). It holds its parts rather
than inheriting them:
the equations of motion (``dynamics.Dynamics``: bodies and applied loads),
the joints (``jointset.JointSet``: rows, releases, the active ``Topology``),
the kinematic bodies (``Carriers``), the braces, contact pairs and aero
tables watched (``watch.Watch``), what a sample shows (``Sampling``) and how
the run stands (``outcome.Outcome``: its status, the one place it fails or
stops); what is a part's own it reads through ``outcome.Forward``.
"""

from __future__ import annotations

import logging
from typing import Optional

from cfem_ros.core import rotations
from cfem_ros.core.engine.bodies import state_views
from cfem_ros.core.engine.carrier import Carriers
from cfem_ros.core.engine.dynamics import Dynamics
from cfem_ros.core.engine.events import AERO_EVENTS, Failure
from cfem_ros.core.engine.jointset import JointSet
from cfem_ros.core.engine.outcome import Forward, Outcome
from cfem_ros.core.engine.sampling import SampleGrid
from cfem_ros.core.engine.stepping import Stepper
from cfem_ros.core.engine.watch import Watch
from cfem_ros.core.errors import ArgumentError
from cfem_ros.core.model.model import Model
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
    status, message, reason, refusal, failure
        How the run stands and why it ended, ``outcome``'s (``Outcome``:
        ``RUNNING``, ``FAILED``, ``CONTACT`` or ``AERO_OUTSIDE``).
    load_states : dict or None
        None unless an output asks for it (a viewer's load arrows): then, by
        the time (s) of each event located within a step that starts or
        ends a load (``LOAD_EVENTS``), the sample there: (``outputs()``,
        ``active_joints``, ``held_wrenches()``) just after it. A caller
        that steps over an event (to the next sample time) finds the state
        of its instant here.

    """

    # the parts' own, read (and set) through the simulator
    status, message, reason = Forward('outcome'), Forward('outcome'), Forward('outcome')
    refusal, failure = Forward('outcome'), Forward('outcome')
    set_wrench, held_wrenches = Forward('dynamics'), Forward('dynamics')   # wrenches held
    body_index, joint_index = Forward('dynamics'), Forward('dynamics')   # by name or index
    set_odometry = Forward('carriers')   # a kinematic body driven by odometry
    active_joints, applied_sources = Forward('sampling'), Forward('sampling')   # a sample's
    active = Forward('releases')   # joints not yet released, bool, (n_joints,)

    def __init__(self, model: Model, logger: Optional[logging.Logger] = None, *,
                 check_start: bool = True):
        self.model = model
        self.outcome = Outcome(check_start)   # status, message, failure (outcome.py)
        self.dynamics = dynamics = Dynamics(model, logger)
        # the dynamics' tables, read through the simulator too (the same arrays)
        self.log, self.eta, self.n, self.free = dynamics.log, dynamics.eta, dynamics.n, \
            dynamics.free
        self.kinematic, self.gravity = dynamics.kinematic, dynamics.gravity
        self.mass, self.inertia_body = dynamics.mass, dynamics.inertia_body
        self._bodies, self._scheduled = dynamics.bodies, dynamics.scheduled
        self._loads = dynamics.loads
        self.y = dynamics.y0
        self.dt = float(model.dt)
        self.t = 0.0
        self.steps = 0
        self.max_violation = 0.0
        self.load_states = None
        self.carriers = Carriers(self, self._bodies)   # kinematic bodies, their odometry
        if self.kinematic:
            self.carriers.place(0.0)
            self.carriers.start()

        pos0, _, quat0, _ = state_views(self.y, self.n)
        self.joint_set = joint_set = JointSet(model, pos0, quat0, dynamics)   # releases
        self.joints, self.groups = joint_set.tables, joint_set.groups
        self.releases, self.sampling = joint_set.releases, joint_set.sampling
        joint_set.rebuild(self.y)
        self.stepper = Stepper(self, dynamics)   # the step loop (stepping.py)
        self.stepper.fire_time_triggers()
        dynamics.project_velocities(self.topology, self.y)
        self.watch = Watch(model, self._scheduled, self.n)   # pads, pairs and aero tables
        self.record_watch(*self.watch.arm(self.y, self.t))   # an axis outside at t = 0 is told

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
        self.record_watch(*self.watch.arm(self.y, self.t))   # pads, pairs and tables from here

    def derivative(self, y: np.ndarray) -> np.ndarray:
        """Return dy/dt at state y (external wrenches held constant)."""
        return self.dynamics.derivative(self.topology, y)

    def joint_projection(self) -> np.ndarray:
        """Return the least (mass weighted) change of velocities that the joints allow, (n, 6)."""
        return self.dynamics.joint_projection(self.topology, self.y)

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

    def outputs(self, out: Optional[np.ndarray] = None) -> np.ndarray:
        """Return what a sample publishes now, in one kernel call (``Sampling.outputs_size``)."""
        out = np.empty(self.sampling.outputs_size()) if out is None else out
        return self.sampling.outputs(self.y, out)

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

    @property
    def topology(self):
        """Return the active joints' rows and solve plan (``Topology``; changes at releases)."""
        return self.joint_set.topology

    @property
    def dof(self) -> int:
        """Return the degrees of freedom the active joints leave."""
        return self.joint_set.dof

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
        return self.release_indices(self.joint_set.commanded(names, self.joint_index), cause)

    def release_indices(self, joints, cause: str) -> list:
        """Release the active joints of these model indices now; return the events."""
        return self.joint_set.release(joints, self.t, self.y, cause)

    @property
    def events(self) -> list:
        """
        Return what happened so far, in order (``Releases.events``), a dict each.

        Releases (``{'event': Event.RELEASE, 'joint', 'time', 'cause'}``, and
        ``'group'`` for a joint of a release group), the ends of ejector
        strokes (``strokes.stroke_end_event``), contacts (``{'event':
        Event.CONTACT, 'bodies', 'time', 'point', 'parts'}``), the braces'
        pads letting go or touching again (``braces.contact_event``).
        """
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
        ArgumentError
            If t_target is not finite or before the current time, limit is
            NaN, or the sample rows are not as wide as the outputs.

        """
        return self.stepper.run_to(t_target, limit, samples, release_at_end)

    def fail(self, reason: str, failure: Failure = Failure.OTHER):
        """Stop the run as failed now (``status``, ``failure``, ``message`` with the time)."""
        self.outcome.fail(self, reason, failure)

    def release_due(self) -> list:
        """
        Release the joints whose release time has come, now; return the events.

        ``advance_to`` leaves a release due at the time a call ends to the
        next call, so that a sample taken at that time still shows the
        joint (a release at t acts after the samples at t, whatever its
        cause); a caller that samples calls this after its sample.
        """
        before = len(self.events)
        self.stepper.fire_time_triggers()
        return self.events[before:]

    def record_watch(self, events: list, stops: list):
        """Record the watch's events; stop the run as the first stop says (``Watch``)."""
        self.events.extend(events)
        self.outcome.stop(self, stops)
