# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Pause, play, step, reset and set a body's state: the node's run under control.

``RunControl`` does what the simulation control services ask (``control.py``
serves them with the standard ``simulation_interfaces`` types) on the
node's simulator, session, pacing, publishers and recording; it needs no
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
import time

from cfem_ros.core import rotations
from cfem_ros.core.engine.bodies import state_views
from cfem_ros.core.engine.simulator import Simulator
import numpy as np
from std_msgs.msg import String

PLAYING, PAUSED, STOPPED = 'playing', 'paused', 'stopped'


class ControlError(Exception):
    """A request the run cannot do now (the message says why); nothing changed."""


class RunControl:
    """
    The state of a node's run (playing, paused, stopped) and what changes it.

    Parameters
    ----------
    node : CfemNode
        Whose run it controls.
    paused : bool
        Start paused (``paused:=true``).

    """

    def __init__(self, node, paused: bool = False):
        self.node = node
        self.state = PAUSED if paused else PLAYING

    @property
    def paused(self) -> bool:
        """Tell whether the run waits (paused or stopped)."""
        return self.state != PLAYING

    # ---------------------------------------------------------------- states

    def pause(self):
        """Stop advancing where the run is."""
        if self.state == PLAYING:
            self.state = PAUSED
            self.announce({'event': 'pause', 'time': self.node.sim.t})

    def play(self):
        """Advance again: in real time from now, at the real-time factor; or with /clock."""
        if self.state == PLAYING:
            return
        node = self.node
        self.state = PLAYING
        self.announce({'event': 'play', 'time': node.sim.t})
        if node.start_ns is None:
            return
        if not node.session.started:
            node.session.start()
        if not node.sim_time:
            node.pace.resume(time.monotonic(), node.sim.t)

    def stop(self):
        """Reset and wait (``STATE_STOPPED``)."""
        self.state = STOPPED
        self.reset()

    def step(self, steps: int, announce: bool = True) -> int:
        """
        Advance by steps steps of dt, while paused; return how many dt it advanced.

        The run goes from t0 to t0 + steps dt exactly. Where no release,
        stroke end or contact cuts a step in between, these are the steps
        the run takes unpaced (sample times and inputs on the grid of dt cut
        nothing). After such a cut the grid of dt starts from it, and the
        last step is cut to end on t0 + steps dt, as a sample time cuts one:
        from there on the run differs from an unpaced one in its last digits.
        The run's end stops it early. ControlError if playing, or not
        started (following /clock, before the first /clock).
        """
        node, sim = self.node, self.node.sim
        if not self.paused:
            raise ControlError('the simulation is playing; pause it first')
        if node.start_ns is None:
            raise ControlError('the run has not started (waiting for /clock)')
        if steps < 1:
            raise ControlError(f'steps is {steps}; expected 1 or more')
        if node.session.finished:
            raise ControlError(f'the run is over (t = {sim.t:.9g} s)')
        if not node.session.started:
            node.session.start()
        t0 = sim.t
        # the steps it takes unpaced that end by t0 + steps dt (to the rounding of t)
        end = t0 + steps * sim.dt
        node.session.advance(end + 1e-6 * sim.dt)
        if end - sim.t > 1e-6 * sim.dt:   # an event cut the grid: the last step lands on end
            node.session.advance(end, land=True)
        advanced = int(round((sim.t - t0) / sim.dt))
        if announce:
            self.announce({'event': 'step', 'time': t0, 'steps': advanced, 'to': sim.t})
        if node.session.finished and node.exit_code is None:
            node._end()
        return advanced

    def reset(self):
        """
        Start the run again from t = 0 of the scenario (released joints joined again).

        The recording goes on: a ``reset`` event at the time the run got to
        says the stamp of the new run's t = 0, which is the ROS time now
        (real time) or the latest /clock (sim time). Inputs held for later
        are dropped. Playing, the new run starts now; paused, its t = 0
        sample is published and it waits.
        """
        node = self.node
        if node.start_ns is None:
            raise ControlError('the run has not started (waiting for /clock)')
        old = node.sim
        if node.sim_time:
            start_ns = node.start_ns + round((node._clock_limit or 0.0) * 1e9)
        else:
            start_ns = node.get_clock().now().nanoseconds
        self.announce({'event': 'reset', 'time': old.t, 'start_stamp_ns': int(start_ns)})
        node.sim = Simulator(old.model, logger=old.log)
        node._publishers_sink.restart(node.sim, start_ns)
        if node.recording is not None:
            node.recording.sim = node.sim
            node.recording.state.restart(node.sim, start_ns)
        node.new_session()
        node.start_ns = node.timing.start_ns = int(start_ns)
        if node.sim_time:
            node._clock_limit = 0.0
        if self.paused or not node.sim_time:
            node.session.start()
        if not node.sim_time:
            node.pace.resume(time.monotonic(), 0.0)

    # ---------------------------------------------------------------- bodies

    def free_body(self, name: str) -> int:
        """Return the index of a body that moves freely and has no active joint."""
        sim = self.node.sim
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
        ControlError (or LookupError for an unknown body) if it cannot be.
        """
        if not self.paused:
            raise ControlError('the simulation is playing; pause it first')
        i = self.free_body(name)
        values = [np.asarray(v, dtype=float) for v in
                  (position, quaternion, velocity, angular_velocity)]
        if not all(np.isfinite(v).all() for v in values):
            raise ValueError('the state must be finite numbers')
        norm = np.linalg.norm(values[1])
        if not 0.5 < norm < 1.5:
            raise ValueError(f'the quaternion has norm {norm:.6g}; expected a unit quaternion')
        quat = values[1] / norm
        sim = self.node.sim
        pos, vel, q, rates = state_views(sim.y, sim.n)
        pos[i], vel[i], q[i] = values[0], values[2], quat
        rates[i] = rotations.to_body(quat[None], values[3][None])[0]
        self.announce({'event': 'set_state', 'time': sim.t, 'body': name})

    # ---------------------------------------------------------------- events

    def announce(self, event: dict):
        """Publish an event of the run's control on ``events``, record it, and log it."""
        node = self.node
        node._publishers_sink.event_publisher.publish(String(data=json.dumps(event)))
        if node.recording is not None and node.start_ns is not None:
            node.recording.state.note(event)
        details = ', '.join(f'{k} {v}' for k, v in event.items() if k not in ('event', 'time'))
        node.get_logger().info(f"{event['event']} at t = {event['time']:.9g} s"
                               + (f' ({details})' if details else ''))
