# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Pause, play, step, reset and set a body's state: the node's run under control.

``RunControl`` does what the simulation control services ask (``control.py``
serves them with the standard ``simulation_interfaces`` types) on the
node's run (``node.run``: simulator, session, publishers, recording) and
pacing (``node.stepping``), through their public faces; it needs no
interface types, so a node without them still starts paused
(``paused:=true``). Every change is an event on ``events`` and in the
recording (SPEC section 3):

- ``{"event": "pause", "time": t}``, ``{"event": "play", "time": t}``;
- ``{"event": "step", "time": t, "steps": N, "to": t + N dt}``;
- ``{"event": "reset", "time": t, "start_stamp_ns": S}``: the run so far ended at
  t; the next starts at t = 0 with stamp S (its samples are stamped from S,
  in the same recording);
- ``{"event": "set_state", "time": t, "body": name}``.
"""

from __future__ import annotations

import json
import math
import time
from typing import Optional

from cfem_ros.core import rotations
from cfem_ros.core.engine.bodies import state_views
from cfem_ros.core.engine.events import describe_event, Event, TextEnum
from cfem_ros.core.engine.sampling import NumericalFailure
from cfem_ros.core.errors import ArgumentError, CfemError
from cfem_ros.core.scenario.checker import MAX_MAGNITUDE
import numpy as np
from std_msgs.msg import String


class ControlState(TextEnum):
    """Where the node's run is (``RunControl.state``): playing, paused, or stopped (reset)."""

    PLAYING = 'playing'
    PAUSED = 'paused'
    STOPPED = 'stopped'


PLAYING, PAUSED, STOPPED = ControlState.PLAYING, ControlState.PAUSED, ControlState.STOPPED

#: Most steps taken between two looks at the wall clock (``StepRun.go``).
SLICE_STEPS = 100


class ControlError(CfemError):
    """A request the run cannot do now (the message says why); nothing changed."""


class RunControl:
    """
    The state of a node's run (playing, paused, stopped) and what changes it.

    Parameters
    ----------
    node : CfemNode
        Whose run (``node.run``) it controls, paced by ``node.stepping``.
    paused : bool
        Start paused (``paused:=true``).

    """

    def __init__(self, node, paused: bool = False):
        self.node = node
        self.state = PAUSED if paused else PLAYING

    @property
    def paused(self) -> bool:
        """Tell whether the run waits (paused or stopped)."""
        return self.state is not PLAYING

    # ---------------------------------------------------------------- states

    def pause(self):
        """Stop advancing where the run is."""
        if self.state is PLAYING:
            self.state = PAUSED
            self.announce({'event': Event.PAUSE, 'time': self.node.run.sim.t})

    def play(self):
        """Advance again: in real time from now, at the real-time factor; or with /clock."""
        if self.state is PLAYING:
            return
        node, run = self.node, self.node.run
        self.state = PLAYING
        self.announce({'event': Event.PLAY, 'time': run.sim.t})
        if run.start_ns is None:
            return
        if not run.session.started:
            run.session.start()
        if not node.sim_time:
            node.pace.resume(time.monotonic(), run.sim.t)

    def stop(self):
        """Reset and wait (``STATE_STOPPED``)."""
        self.state = STOPPED
        self.reset()

    def step(self, steps: int, announce: bool = True) -> int:
        """
        Advance by steps steps of dt, while paused; return how many dt it advanced.

        The run goes from t0 to t0 + steps dt exactly (``StepRun``). The
        run's end stops it early. ControlError if playing, or not started
        (following /clock, before the first /clock).
        """
        run = StepRun(self, steps)
        run.go()
        return run.finish(announce)

    def check_step(self, steps: int):
        """Raise ControlError if the run cannot take steps now."""
        run = self.node.run
        if not self.paused:
            raise ControlError('the simulation is playing; pause it first')
        if run.start_ns is None:
            raise ControlError('the run has not started (waiting for /clock)')
        if steps < 1:
            raise ControlError(f'steps is {steps}; expected 1 or more')
        if run.session.finished:
            raise ControlError(f'the run is over (t = {run.sim.t:.9g} s)')

    def reset(self):
        """
        Start the run again from t = 0 of the scenario (released joints joined again).

        The recording goes on: a ``reset`` event at the time the run got to
        says the stamp of the new run's t = 0, which is the ROS time now
        (real time) or the latest /clock (sim time). Inputs held for later
        are dropped. Playing, the new run starts now; paused, its t = 0
        sample is published and it waits.
        """
        node, run = self.node, self.node.run
        if run.start_ns is None:
            raise ControlError('the run has not started (waiting for /clock)')
        start_ns = node.stepping.reset_stamp()
        self.announce({'event': Event.RESET, 'time': run.sim.t, 'start_stamp_ns': int(start_ns)})
        run.restart(start_ns)
        node.stepping.restarted()
        if self.paused or not node.sim_time:
            run.session.start()
        if not node.sim_time:
            node.pace.resume(time.monotonic(), 0.0)

    # ---------------------------------------------------------------- bodies

    def free_body(self, name: str) -> int:
        """Return the index of a body that moves freely and has no active joint."""
        sim = self.node.run.sim
        try:
            i = sim.body_index(name)
        except ValueError as err:
            raise LookupError(str(err)) from None
        if not sim.free[i]:
            raise ControlError(f'body {name!r} is fixed or kinematic (follows its motion)')
        for k, joint in enumerate(sim.model.joints):
            if sim.active[k] and i in (joint.parent, joint.child):
                raise ControlError(f'body {name!r} is held by the active joint '
                                   f'{joint.name!r}; only a body with no active joint can be '
                                   'set')
        return i

    def set_body_state(self, name: str, position, quaternion, velocity, angular_velocity):
        """
        Put a free body (no active joint) at a pose and twist, while paused.

        position (m), quaternion x y z w (body to world, normalized here),
        CG velocity and angular velocity (rad/s), all in the world frame.
        The simulator then watches on from there (``Simulator.set_state``, as a
        batch copy's initial state): strokes, contacts and aero tables.
        ControlError (or LookupError for an unknown body) if it cannot be.
        """
        if not self.paused:
            raise ControlError('the simulation is playing; pause it first')
        i = self.free_body(name)
        values = [np.asarray(v, dtype=float) for v in
                  (position, quaternion, velocity, angular_velocity)]
        for what, unit, v in zip(('position', 'quaternion', 'velocity', 'angular velocity'),
                                 ('m', '', 'm/s', 'rad/s'), values):
            if not np.isfinite(v).all():
                raise ArgumentError(f'the {what} {v.tolist()} is not finite; expected finite '
                                    'numbers')
            if np.abs(v).max() > MAX_MAGNITUDE:
                raise ArgumentError(f'the {what} {v.tolist()} has a component of magnitude '
                                    f'{np.abs(v).max():g} {unit}'.rstrip() + ', beyond any '
                                    f'physical state; expected components of magnitude at most '
                                    f'{MAX_MAGNITUDE:g}, as in a scenario')
        norm = np.linalg.norm(values[1])
        if not 0.5 < norm < 1.5:
            raise ArgumentError(f'the quaternion has norm {norm:.6g}; expected a unit quaternion')
        quat = values[1] / norm
        sim = self.node.run.sim
        y = sim.y.copy()
        pos, vel, q, rates = state_views(y, sim.n)
        pos[i], vel[i], q[i] = values[0], values[2], quat
        rates[i] = rotations.to_body(quat[None], values[3][None])[0]
        try:
            with np.errstate(all='ignore'):
                finite = np.isfinite(sim.derivative(y)).all()
        except NumericalFailure as err:
            raise ArgumentError(f'at that state the joints cannot be solved ({err}); nothing '
                                'changed') from None
        if not finite:
            raise ArgumentError('at that state the accelerations are not finite (loads such as '
                                'the aerodynamic ones beyond double precision at that speed); '
                                'expected a state the run can go on from; nothing changed')
        sim.set_state(y)   # strokes, contacts and aero watched from there, as a batch copy
        self.announce({'event': Event.SET_STATE, 'time': sim.t, 'body': name})

    # ---------------------------------------------------------------- events

    def announce(self, event: dict):
        """Publish an event of the run's control on ``events``, record it, and log it."""
        node, run = self.node, self.node.run
        run.publishers.event_publisher.publish(String(data=json.dumps(event)))
        if run.recording is not None and run.start_ns is not None:
            run.recording.state.note(event)
        node.get_logger().info(describe_event(event))


class StepRun:
    """
    N steps of dt from where a paused run is, taken a slice at a time (``go``).

    The run goes from t0 to t0 + N dt exactly. Where no release, stroke end
    or contact cuts a step in between, these are the steps the run takes
    unpaced (sample times and inputs on the grid of dt cut nothing). After
    such a cut the grid of dt starts from it, and the last step is cut to
    end on t0 + N dt, as a sample time cuts one: from there on the run
    differs from an unpaced one in its last digits. How the steps are
    sliced (``go``'s wall deadline and step bound) changes when they are
    taken, never which: N steps in one call or in many are the same run.
    """

    def __init__(self, control: RunControl, steps: int):
        control.check_step(steps)
        self.control, self.node, self.run = control, control.node, control.node.run
        self.sim = self.run.sim
        if not self.run.session.started:
            self.run.session.start()
        self.steps = steps
        self.t0 = self.sim.t
        self.end = self.t0 + steps * self.sim.dt

    @property
    def done(self) -> int:
        """Return the steps of dt taken so far."""
        return int(round((self.sim.t - self.t0) / self.sim.dt))

    @property
    def over(self) -> bool:
        """Tell whether all steps are taken or the run ended (or was reset) first."""
        return (self.run.sim is not self.sim or self.run.session.finished
                or self.sim.t >= self.end)

    def go(self, deadline: float = math.inf, until: Optional[int] = None):
        """
        Take steps until ``until`` of them are done (all: None) or the wall deadline passes.

        The wall clock is read between slices of ``SLICE_STEPS`` steps: a
        slice is the most that runs between two looks at it.
        """
        session, dt = self.run.session, self.sim.dt
        until = self.steps if until is None else min(until, self.steps)
        goal = self.t0 + until * dt
        while not self.over:
            aim = min(self.sim.t + SLICE_STEPS * dt, goal)
            session.advance(aim + 1e-6 * dt)
            if aim >= goal:   # every step that ends by the goal is taken
                break
            if time.monotonic() >= deadline:
                return
        if (until == self.steps and not self.over
                and self.end - self.sim.t > 1e-6 * dt):   # an event cut the grid
            session.advance(self.end, land=True)

    def finish(self, announce: bool = True) -> int:
        """Announce the steps taken (a ``step`` event) and end the run if it is over."""
        advanced = self.done if self.run.sim is self.sim else 0
        if announce and advanced:
            self.control.announce({'event': Event.STEP, 'time': self.t0, 'steps': advanced,
                                   'to': self.sim.t})
        if self.run.session.finished and self.node.exit_code is None:
            self.node.stepping.end()
        return advanced
