# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Simulation control over the standard simulator interfaces (SPEC section 3).

The node runs in its own process; this process is a client that knows only
the ``simulation_interfaces`` types (built by ``make interfaces``, which
``make test`` runs): it pauses, steps, reads and sets bodies, resets, plays
and runs the SimulateSteps action with feedback and a cancel. Numbers are
checked against the same scenario stepped offline, to the bit.
"""

import json
import pathlib
import signal

from action_msgs.msg import GoalStatus
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.run.session import Session
from cfem_ros.core.scenario.parse import load_scenario
import numpy as np
import pytest
import rclpy
from recordings import read_checked
from rosharness import NodeProcess, Peer, stamp_ns
from simclient import Client
from simulation_interfaces.action import SimulateSteps
from simulation_interfaces.msg import Result, SimulationState, SimulatorFeatures
from simulation_interfaces.srv import GetEntities, SetSimulationState

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'


def pose_of(state):
    p, q = state.pose.position, state.pose.orientation
    return np.array([p.x, p.y, p.z, q.x, q.y, q.z, q.w])


def offline(scenario, until, land=None):
    """Return the simulator stepped unpaced to the last step by until (s), then to land."""
    sim = Simulator(load_scenario(str(scenario)))
    session = Session(sim, rate_hz=100.0)
    session.start()
    session.advance(until)
    if land is not None:
        assert sim.t < land   # the grid was cut: the landing is a step of its own
        session.advance(land, land=True)
    return sim


@pytest.fixture
def client():
    made = Client()
    yield made
    made.close()


def test_pause_step_state_reset_play_and_the_action(tmp_path, client):
    scenario = CONFIG / 'store_separation.yaml'
    recording = tmp_path / 'control.mcap'
    node = NodeProcess(tmp_path, scenario, record=recording, paused=True, duration=0.0,
                       rate_hz=100.0)
    peer = Peer(['store'], ['pivot'])
    try:
        client.ready(node)
        features = set(client.call('get_simulator_features').features.features)
        f = SimulatorFeatures
        assert features == {
            f.SIMULATION_RESET, f.SIMULATION_STATE_GETTING, f.SIMULATION_STATE_SETTING,
            f.SIMULATION_STATE_PAUSE, f.STEP_SIMULATION_SINGLE, f.STEP_SIMULATION_MULTIPLE,
            f.STEP_SIMULATION_ACTION, f.ENTITY_STATE_GETTING, f.ENTITY_STATE_SETTING}
        assert client.call('get_simulation_state').state.state == SimulationState.STATE_PAUSED
        # paused from the start: the t = 0 sample is out (the recording has it), and
        # nothing after it
        poses = peer.received['bodies/store/pose']
        peer.spin_until(lambda: peer.node.count_publishers('/cfem/bodies/store/pose') > 0,
                        timeout=60.0, what='discovery')
        peer.spin_for(0.3)
        start = stamp_ns(client.state('store').header)
        assert all(stamp_ns(m.header) == start for m in poses)   # t = 0, if it came in time

        # step 7: exactly 7 ms on, the state the offline run has there, to the bit
        assert client.call('step_simulation', steps=7).result.result == Result.RESULT_OK
        state = client.state('store')
        assert stamp_ns(state.header) - start == 7_000_000
        sim = offline(scenario, 0.0075)
        assert sim.t == pytest.approx(0.007, abs=1e-15)
        assert (pose_of(state) == np.r_[sim.position[1], sim.orientation[1]]).all()
        assert state.header.frame_id == 'world'
        # held by its hinge: not to be moved
        refused = client.call('set_entity_state', entity='store', state=state).result
        assert refused.result == Result.RESULT_OPERATION_FAILED
        assert 'pivot' in refused.error_message
        missing = client.call('get_entity_state', entity='nope').result
        assert missing.result == Result.RESULT_NOT_FOUND
        found = client.call('get_entities', filters=GetEntities.Request().filters)
        assert list(found.entities) == ['pylon', 'store']
        states = client.call('get_entities_states', filters=GetEntities.Request().filters)
        assert (pose_of(states.states[1]) == pose_of(state)).all()

        # past the release (t = 0.280158914 s), which starts the grid of dt again: still
        # exactly 278 ms on, the last step cut to land there
        assert client.call('step_simulation', steps=278).result.result == Result.RESULT_OK
        state = client.state('store')
        assert stamp_ns(state.header) - start == 285_000_000
        end = offline(scenario, 0.007 + 1e-9).t + 278 * 0.001   # t0 + N dt as the node sums it
        sim = offline(scenario, end + 1e-9, land=end)
        assert sim.t == end == pytest.approx(0.285, abs=1e-15)
        assert (pose_of(state) == np.r_[sim.position[1], sim.orientation[1]]).all()
        # on to t = 0.4 s; the store is free then
        assert client.call('step_simulation', steps=115).result.result == Result.RESULT_OK
        first = client.state('store')
        assert client.call('reset_simulation').result.result == Result.RESULT_OK
        after = client.state('store')
        sim = offline(scenario, 0.0)
        assert (pose_of(after) == np.r_[sim.position[1], sim.orientation[1]]).all()
        second_start = stamp_ns(after.header)
        assert second_start > start + 400_000_000 - 1

        # the action: 285 steps with feedback (its last share of 5 crosses the release and
        # lands on 0.285 s), then 115: the run is the first one again
        feedback = []
        goal = client.wait(client.action.send_goal_async(
            SimulateSteps.Goal(steps=285), feedback_callback=lambda m: feedback.append(
                m.feedback.completed_steps)))
        assert goal.accepted
        result = client.wait(goal.get_result_async())
        assert result.status == GoalStatus.STATUS_SUCCEEDED
        assert result.result.result.result == Result.RESULT_OK
        # feedback is a topic: under load its last messages may come after the result
        client.executor.spin_until_future_complete(
            _until(client, lambda: feedback and feedback[-1] == 285), timeout_sec=30.0)
        assert len(feedback) >= 10 and feedback[-1] == 285 and feedback == sorted(feedback)
        assert client.call('step_simulation', steps=115).result.result == Result.RESULT_OK
        again = client.state('store')
        assert (pose_of(again) == pose_of(first)).all()
        assert stamp_ns(again.header) - second_start == stamp_ns(first.header) - start

        # released now: the store can be put somewhere and given a twist
        moved = client.state('store')
        moved.pose.position.x, moved.pose.position.z = 5.0, -1.0
        moved.twist.linear.x, moved.twist.angular.z = 2.0, 0.5
        answer = client.call('set_entity_state', entity='store', state=moved).result
        assert answer.result == Result.RESULT_OK, answer.error_message
        placed = client.state('store')
        assert (pose_of(placed)[:3] == pose_of(moved)[:3]).all()
        assert pose_of(placed)[3:] == pytest.approx(pose_of(moved)[3:], abs=1e-15)   # normed
        assert placed.twist.linear.x == 2.0
        assert placed.twist.angular.z == pytest.approx(0.5, abs=1e-15)

        # a long goal, cancelled after its first feedback
        feedback.clear()
        goal = client.wait(client.action.send_goal_async(
            SimulateSteps.Goal(steps=1_000_000),
            feedback_callback=lambda m: feedback.append(m.feedback.completed_steps)))
        client.executor.spin_until_future_complete(
            _until(client, lambda: feedback), timeout_sec=60.0)
        assert feedback, 'no feedback'
        client.wait(goal.cancel_goal_async())
        result = client.wait(goal.get_result_async())
        assert result.status == GoalStatus.STATUS_CANCELED
        assert 'canceled after' in result.result.result.error_message
        assert feedback[-1] < 1_000_000

        # play: samples flow; stepping is refused while playing; pause
        before = len(poses)
        assert client.set_state(SimulationState.STATE_PLAYING).result == Result.RESULT_OK
        peer.spin_until(lambda: len(poses) >= before + 5, timeout=60.0, what='playing')
        assert client.call('step_simulation', steps=1).result.result == \
            Result.RESULT_OPERATION_FAILED
        assert client.set_state(SimulationState.STATE_PAUSED).result == Result.RESULT_OK
        assert client.set_state(SimulationState.STATE_PAUSED).result == \
            SetSimulationState.Response.ALREADY_IN_TARGET_STATE
        # a world state is unsupported; a number that is no state is named as such
        world = client.set_state(SimulationState.STATE_NO_WORLD)
        assert world.result == Result.RESULT_FEATURE_UNSUPPORTED
        assert 'no worlds to load or unload' in world.error_message
        wrong = client.set_state(77)
        assert wrong.result == Result.RESULT_OPERATION_FAILED
        assert wrong.error_message == ('state 77: not a SimulationState; expected 0 (stopped), '
                                       '1 (playing), 2 (paused) or 3 (quitting)')
        assert client.set_state(SimulationState.STATE_QUITTING).result == Result.RESULT_OK
        assert node.wait(timeout=60.0) == 0, node.output
    finally:
        peer.close()
        node.stop(signal.SIGINT)

    # the recording: the second run starts where the reset event says, and repeats the
    # first one's samples to the bit
    _, _, messages = read_checked(recording)
    events = [json.loads(m.data) for topic, _, _, m in messages if topic == '/cfem/events']
    kinds = [e['event'] for e in events]
    assert kinds.count('release') == 2 and kinds.count('reset') == 1
    assert {'step', 'set_state', 'play', 'pause'} <= set(kinds)
    reset = next(e for e in events if e['event'] == 'reset')
    assert reset['start_stamp_ns'] == second_start
    assert reset['time'] == pytest.approx(0.4, abs=1e-12)
    samples = [(log, m) for topic, log, _, m in messages if topic == '/cfem/bodies/store/pose']
    run1 = {log - start: pose_of(m) for log, m in samples if log < second_start}
    run2 = {log - second_start: pose_of(m) for log, m in samples
            if second_start <= log <= second_start + 400_000_000}
    assert len(run1) == len(run2) == 41
    assert all((run1[t] == run2[t]).all() for t in run1)


def _until(client, condition):
    """Return a future done once condition() holds (checked by a timer of the client)."""
    future = rclpy.task.Future()

    def check():
        if condition() and not future.done():
            future.set_result(True)
    client.node.create_timer(0.01, check)
    return future


def test_without_the_types_the_node_says_in_one_line_how_to_get_them(monkeypatch):
    from cfem_ros.ros import control
    lines = []
    logger = type('Logger', (), {'info': lambda self, line: lines.append(line)})()
    node = type('Node', (), {'get_logger': lambda self: logger})()
    monkeypatch.setattr(control, 'SimulateSteps', None)
    assert control.serve(node, None) is None
    assert len(lines) == 1 and 'make interfaces' in lines[0]
    assert 'ros-$ROS_DISTRO-simulation-interfaces' in lines[0]
