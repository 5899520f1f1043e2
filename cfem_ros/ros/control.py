# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Simulation control: the ROS 2 standard simulator interfaces (SPEC section 3).

``serve`` offers the ``simulation_interfaces`` (Kilted 1.6.1 types) services
and action under the node's namespace, doing what they ask through the
node's ``RunControl``. Without the types (a pip install that has not built
them) the node runs as before and one log line says how to get them.

What is supported is exactly what ``get_simulator_features`` lists: getting
and setting the simulation state (playing, paused, stopped = reset and
paused, quitting), stepping (one, several, the action), a full reset,
getting entity states and setting a free body's. Not: spawning, deleting,
worlds, named poses, bounds, tags, categories, entity info.
"""

from __future__ import annotations

import math
import re
import time

from cfem_ros.core import rotations
from cfem_ros.core.engine.bodies import state_views
from cfem_ros.ros.refusals import bounded
from cfem_ros.ros.runcontrol import ControlError, PAUSED, PLAYING, StepRun, STOPPED
import numpy as np
from rclpy.clock import Clock, ClockType

try:
    from simulation_interfaces.action import SimulateSteps
    from simulation_interfaces.msg import EntityState, Result, SimulationState, SimulatorFeatures
    from simulation_interfaces.srv import (
        GetEntities, GetEntitiesStates, GetEntityState, GetSimulationState,
        GetSimulatorFeatures, ResetSimulation, SetEntityState, SetSimulationState,
        StepSimulation)
except ImportError:   # a pip install without them (interfaces/build.py builds them)
    SimulateSteps = None

#: The one line a node without the types logs.
HOW_TO_GET = ('simulation control (pause, step, reset, entity states) is off: the '
              'simulation_interfaces types are not installed. With pip: make interfaces (or '
              '.venv/bin/python interfaces/build.py, about 3 CPU-minutes); on a ROS 2 install: '
              'rosdep install --from-paths src --ignore-src '
              '(ros-$ROS_DISTRO-simulation-interfaces)')
#: Feedback messages a SimulateSteps goal gets, about.
FEEDBACKS = 20
#: Most steps one step_simulation call takes: its answer (and the node, signals
#: included) waits for them all; the action takes more, a slice at a time.
MAX_SERVICE_STEPS = 10_000
#: Wall time a simulate_steps goal steps before the node answers anything else, s.
STEP_BUDGET = 0.05


def serve(node, control):
    """Offer the services and the action on node; return them (None without the types)."""
    if SimulateSteps is None:
        node.get_logger().info(HOW_TO_GET)
        return None
    return SimulationServices(node, control)


def _result(code: int = None, message: str = ''):
    return Result(result=Result.RESULT_OK if code is None else code, error_message=message)


def _vector(msg, v):
    msg.x, msg.y, msg.z = (float(c) for c in v)
    return msg


class SimulationServices:
    """The services and the action of ``simulation_interfaces``, on one node."""

    def __init__(self, node, control):
        self.node, self.control = node, control
        for kind, name, callback in (
                (GetSimulatorFeatures, 'get_simulator_features', self._features),
                (GetSimulationState, 'get_simulation_state', self._get_state),
                (SetSimulationState, 'set_simulation_state', self._set_state),
                (StepSimulation, 'step_simulation', self._step),
                (ResetSimulation, 'reset_simulation', self._reset),
                (GetEntities, 'get_entities', self._entities),
                (GetEntityState, 'get_entity_state', self._entity_state),
                (GetEntitiesStates, 'get_entities_states', self._entities_states),
                (SetEntityState, 'set_entity_state', self._set_entity_state)):
            node.create_service(kind, name, callback)
        from rclpy.action import ActionServer, CancelResponse
        self.action = ActionServer(
            node, SimulateSteps, 'simulate_steps', self._finish_goal,
            handle_accepted_callback=self._goal_accepted,
            cancel_callback=lambda request: CancelResponse.ACCEPT)
        self._goal = None   # the StepRun of the goal being stepped, and its handle
        self._goal_handle = None
        self._told, self._told_at = 0, 0.0   # steps done at the last feedback, and when
        self._timer = None
        self.finished_at = -math.inf   # when the last goal's result was made (monotonic)
        self._results = {}   # goal id -> the Result it ends with

    # ---------------------------------------------------------------- states

    def _features(self, request, response):
        f = SimulatorFeatures
        response.features.features = [
            f.SIMULATION_RESET, f.SIMULATION_STATE_GETTING, f.SIMULATION_STATE_SETTING,
            f.SIMULATION_STATE_PAUSE, f.STEP_SIMULATION_SINGLE, f.STEP_SIMULATION_MULTIPLE,
            f.STEP_SIMULATION_ACTION, f.ENTITY_STATE_GETTING, f.ENTITY_STATE_SETTING]
        response.features.spawn_formats = []
        response.features.custom_info = (
            "cfem_ros: entities are the scenario's bodies; states in the world frame (the "
            "scenario's frame_id); a reset starts the scenario again from t = 0 (scopes: "
            'all); set_entity_state moves only a body with no active joint, while paused; '
            'a step is one integration step of dt')
        return response

    def _get_state(self, request, response):
        response.state.state = {PLAYING: SimulationState.STATE_PLAYING,
                                PAUSED: SimulationState.STATE_PAUSED,
                                STOPPED: SimulationState.STATE_STOPPED}[self.control.state]
        response.result = _result()
        return response

    def _set_state(self, request, response):
        target, control, s = request.state.state, self.control, SimulationState
        current = {PLAYING: s.STATE_PLAYING, PAUSED: s.STATE_PAUSED,
                   STOPPED: s.STATE_STOPPED}[control.state]
        try:
            if target == current:
                response.result = _result(SetSimulationState.Response.ALREADY_IN_TARGET_STATE,
                                          f'already {control.state}')
                return response
            if target == s.STATE_PLAYING:
                control.play()
            elif target == s.STATE_PAUSED:
                if control.state is STOPPED:
                    response.result = _result(SetSimulationState.Response.INCORRECT_TRANSITION,
                                              'stopped: play it, then pause')
                    return response
                control.pause()
            elif target == s.STATE_STOPPED:
                control.stop()
            elif target == s.STATE_QUITTING:
                self.node.get_logger().info('quitting (set_simulation_state)')
                self.node.exit_code = 0
            elif target in (s.STATE_NO_WORLD, s.STATE_LOADING_WORLD):
                response.result = _result(Result.RESULT_FEATURE_UNSUPPORTED,
                                          f'state {target}: no worlds to load or unload')
                return response
            else:
                response.result = _result(
                    Result.RESULT_OPERATION_FAILED,
                    f'state {target}: not a SimulationState; expected {s.STATE_STOPPED} '
                    f'(stopped), {s.STATE_PLAYING} (playing), {s.STATE_PAUSED} (paused) or '
                    f'{s.STATE_QUITTING} (quitting)')
                return response
        except ControlError as err:
            response.result = _result(SetSimulationState.Response.STATE_TRANSITION_ERROR,
                                      str(err))
            return response
        response.result = _result()
        return response

    def _step(self, request, response):
        steps = int(request.steps)
        try:
            if self._goal is not None:
                raise ControlError('a simulate_steps goal is running; cancel it or wait')
            if steps > MAX_SERVICE_STEPS:
                raise ControlError(
                    f'steps is {steps}; step_simulation takes at most {MAX_SERVICE_STEPS} '
                    'steps a call (its answer waits for them all); the simulate_steps action '
                    'takes any number, with feedback, and can be cancelled')
            taken = self.control.step(steps)
        except ControlError as err:
            response.result = _result(Result.RESULT_OPERATION_FAILED, str(err))
            return response
        response.result = (_result() if taken == steps else _result(
            Result.RESULT_OPERATION_FAILED, f'{taken} of {steps} steps: the run ended'))
        return response

    def _reset(self, request, response):
        r = ResetSimulation.Request
        both = r.SCOPE_TIME | r.SCOPE_STATE
        if request.scope not in (r.SCOPE_DEFAULT, r.SCOPE_ALL) and request.scope & both != both:
            response.result = _result(Result.RESULT_FEATURE_UNSUPPORTED,
                                      'only a full reset (time and state together)')
            return response
        try:
            self.control.reset()
        except ControlError as err:
            response.result = _result(Result.RESULT_INCORRECT_STATE, str(err))
            return response
        response.result = _result()
        return response

    # -------------------------------------------------------------- entities

    def _matching(self, filters):
        """Return the names of the bodies that pass filters, or a Result saying why not."""
        if (filters.categories or filters.tags.tags
                or filters.bounds.type != filters.bounds.TYPE_EMPTY):
            return _result(Result.RESULT_FEATURE_UNSUPPORTED,
                           'only a name filter (no categories, tags or bounds)')
        shown = bounded(filters.filter, 64)
        try:
            pattern = re.compile(filters.filter)
        except re.error as err:
            return _result(Result.RESULT_OPERATION_FAILED, f'filter {shown!r}: {err}')
        except (RecursionError, OverflowError, MemoryError, ValueError) as err:
            # nested too deep, a repeat count beyond the engine's: not re.error
            return _result(Result.RESULT_OPERATION_FAILED,
                           f'filter {shown!r}: Python cannot compile it as a regular '
                           f'expression ({type(err).__name__}: {str(err)[:80]}); expected a '
                           'regular expression of plain nesting and repeat counts, e.g. '
                           "'^store' or 'pylon|store'")
        return [b.name for b in self.node.run.sim.model.bodies if pattern.search(b.name)]

    def _entities(self, request, response):
        names = self._matching(request.filters)
        if isinstance(names, Result):
            response.result = names
            return response
        response.entities, response.result = names, _result()
        return response

    def _state_of(self, i: int):
        """Return body i's EntityState now: world frame, at the simulation's stamp."""
        node, sim = self.node, self.node.run.sim
        state = EntityState()
        stamp = (node.run.start_ns or 0) + round(sim.t * 1e9)
        state.header.stamp.sec, state.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
        state.header.frame_id = sim.model.frame_id
        quat = sim.orientation[i]
        _vector(state.pose.position, sim.position[i])
        q = state.pose.orientation
        q.x, q.y, q.z, q.w = (float(c) for c in quat)
        turn = _matrix(quat)
        _vector(state.twist.linear, sim.velocity[i])
        _vector(state.twist.angular, turn @ sim.rates[i])
        try:
            _, acceleration, _, angular = state_views(sim.derivative(sim.y), sim.n)
            _vector(state.acceleration.linear, acceleration[i])
            _vector(state.acceleration.angular, turn @ angular[i])
        except Exception:  # noqa: B902 - a failed run's state: no accelerations to give
            pass
        return state

    def _entity_state(self, request, response):
        try:
            i = self.node.run.sim.body_index(request.entity)
        except ValueError:
            response.result = _result(Result.RESULT_NOT_FOUND,
                                      f'no body named {request.entity!r}')
            return response
        response.state, response.result = self._state_of(i), _result()
        return response

    def _entities_states(self, request, response):
        names = self._matching(request.filters)
        if isinstance(names, Result):
            response.result = names
            return response
        sim = self.node.run.sim
        response.entities = names
        response.states = [self._state_of(sim.body_index(name)) for name in names]
        response.result = _result()
        return response

    def _set_entity_state(self, request, response):
        state, world = request.state, self.node.run.sim.model.frame_id
        if state.header.frame_id not in ('', world):
            response.result = _result(Result.RESULT_OPERATION_FAILED,
                                      f'frame {state.header.frame_id!r}: only the world frame '
                                      f'{world!r} (or empty)')
            return response
        p, q = state.pose.position, state.pose.orientation
        v, w = state.twist.linear, state.twist.angular
        try:
            self.control.set_body_state(request.entity, [p.x, p.y, p.z], [q.x, q.y, q.z, q.w],
                                        [v.x, v.y, v.z], [w.x, w.y, w.z])
        except LookupError as err:
            response.result = _result(Result.RESULT_NOT_FOUND, str(err))
        except ValueError as err:
            response.result = _result(SetEntityState.Response.INVALID_POSE, str(err))
        except ControlError as err:
            response.result = _result(Result.RESULT_OPERATION_FAILED, str(err))
        else:
            response.result = _result()
        return response

    # ---------------------------------------------------------------- action

    def _goal_accepted(self, goal_handle):
        """Step the goal's steps a slice of wall time at a time, with feedback (a timer)."""
        try:
            if self._goal is not None:
                raise ControlError('another simulate_steps goal is running')
            self._goal = StepRun(self.control, int(goal_handle.request.steps))
        except ControlError as err:
            self._done(goal_handle, _result(Result.RESULT_OPERATION_FAILED, str(err)))
            return
        self._goal_handle, self._told, self._told_at = goal_handle, 0, time.monotonic()
        self._timer = self.node.create_timer(
            0.001, self._step_goal, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _step_goal(self):
        """
        Take the goal's next slice (``STEP_BUDGET`` of wall time at most).

        Feedback at each of ``FEEDBACKS`` shares of the steps, and at least
        every half second of wall time (a goal of 10^12 steps runs for hours).
        """
        run, goal_handle = self._goal, self._goal_handle
        if goal_handle.is_cancel_requested:
            return self._end_goal(_result(Result.RESULT_OPERATION_FAILED,
                                          f'canceled after {run.done} of {run.steps} steps'))
        if not self.control.paused or self.node.run.sim is not run.sim:
            why = 'reset' if self.node.run.sim is not run.sim else 'played'
            return self._end_goal(_result(Result.RESULT_OPERATION_FAILED,
                                          f'{run.done} of {run.steps} steps: the simulation '
                                          f'was {why}'))
        every = max(1, run.steps // FEEDBACKS)   # a feedback at each such share at least
        run.go(deadline=time.monotonic() + STEP_BUDGET, until=(run.done // every + 1) * every)
        done = run.done
        now = time.monotonic()
        if done // every > self._told // every or run.over or now - self._told_at > 0.5:
            self._told, self._told_at = done, now
            goal_handle.publish_feedback(SimulateSteps.Feedback(
                completed_steps=done, remaining_steps=max(run.steps - done, 0)))
        if not run.over:
            return
        if run.sim.t >= run.end:
            self._end_goal(_result())
        else:
            self._end_goal(_result(Result.RESULT_OPERATION_FAILED,
                                   f'{done} of {run.steps} steps: the run ended'))

    def _end_goal(self, result):
        self.node.destroy_timer(self._timer)
        run, goal_handle = self._goal, self._goal_handle
        self._goal = self._goal_handle = None
        self._done(goal_handle, result)   # before the run's end can end the node
        run.finish()

    def settling(self) -> bool:
        """Tell whether a goal's result is still on its way to the client."""
        return self._goal is not None or bool(self._results)

    def _done(self, goal_handle, result):
        self._results[bytes(goal_handle.goal_id.uuid)] = result
        goal_handle.execute()   # runs _finish_goal, which sets the goal's end state

    def _finish_goal(self, goal_handle):
        result = self._results.pop(bytes(goal_handle.goal_id.uuid))
        self.finished_at = time.monotonic()
        if goal_handle.is_cancel_requested:
            goal_handle.canceled()
        elif result.result == Result.RESULT_OK:
            goal_handle.succeed()
        else:
            goal_handle.abort()
        return SimulateSteps.Result(result=result)


def _matrix(quat) -> np.ndarray:
    """Return the rotation matrix (body to world) of a unit quaternion x, y, z, w."""
    return rotations.matrices(np.asarray(quat, dtype=float)[None])[0]
