# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The simulation control services at their limits (issue 52, items 1, 4 and 10).

Each case was found by an attack campaign: a step request of 10^12 steps froze
the node (one callback; SIGINT and SIGTERM ignored), a name filter that Python's
``re`` cannot compile for other reasons than ``re.error`` ended the node, a body
set to 1.7e308 m/s ended the run, and a ``simulate_steps`` goal that reached the
run's end never got its result. Deadlines here are generous and stated: they
hold on a machine loaded with other work.
"""

import pathlib
import signal
import time

from action_msgs.msg import GoalStatus
import pytest
from rosharness import NodeProcess
from simclient import Client
from simulation_interfaces.action import SimulateSteps
from simulation_interfaces.msg import Result, SimulationState
from simulation_interfaces.srv import GetEntities, SetEntityState

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
#: Wall seconds any answer may take on a loaded machine; an answer within it proves
#: the node was not stuck in one callback for the 10^12 steps (hours of work).
ANSWER_S = 30.0


@pytest.fixture
def client():
    made = Client()
    yield made
    made.close()


def _goal(client, steps, feedback):
    goal = client.wait(client.action.send_goal_async(
        SimulateSteps.Goal(steps=steps),
        feedback_callback=lambda m: feedback.append(m.feedback.completed_steps)))
    assert goal.accepted
    return goal


def _spin_until(client, condition, timeout):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, 'timed out'
        client.executor.spin_once(timeout_sec=0.05)


def test_a_huge_step_is_refused_or_sliced_and_the_node_still_answers(tmp_path, client):
    node = NodeProcess(tmp_path, CONFIG / 'store_separation.yaml', paused=True, duration=0.0)
    try:
        client.ready(node)
        refused = client.call('step_simulation', steps=10**12).result
        assert refused.result == Result.RESULT_OPERATION_FAILED
        assert 'at most 10000' in refused.error_message
        assert 'simulate_steps' in refused.error_message
        assert client.call('step_simulation', steps=10_000).result.result == Result.RESULT_OK

        # the action: slice after slice, answering services between, cancellable
        feedback = []
        goal = _goal(client, 10**12, feedback)
        _spin_until(client, lambda: len(feedback) >= 2, ANSWER_S)
        started = time.monotonic()
        answer = client.call('get_simulation_state')
        assert answer.state.state == SimulationState.STATE_PAUSED
        assert time.monotonic() - started < ANSWER_S
        refused = client.call('step_simulation', steps=1).result
        assert 'goal is running' in refused.error_message
        client.wait(goal.cancel_goal_async())
        result = client.wait(goal.get_result_async())
        assert result.status == GoalStatus.STATUS_CANCELED
        assert 0 < feedback[-1] < 10**12

        # a signal in the middle of a huge goal ends the node, with its recording's end
        feedback.clear()
        _goal(client, 10**12, feedback)
        _spin_until(client, lambda: len(feedback) >= 1, ANSWER_S)
        assert node.stop(signal.SIGTERM, timeout=ANSWER_S) == 0, node.output
        assert 'SIGTERM received' in node.output
    finally:
        node.stop(signal.SIGKILL)


def test_a_goal_that_reaches_the_run_end_gets_its_result(tmp_path, client):
    # duration 0.05 s, dt 1 ms: a goal of 1000 steps ends with the run at 50
    node = NodeProcess(tmp_path, CONFIG / 'store_separation.yaml', paused=True, duration=0.05)
    try:
        client.ready(node)
        feedback = []
        goal = _goal(client, 1000, feedback)
        result = client.wait(goal.get_result_async(), timeout=ANSWER_S)
        assert result.status == GoalStatus.STATUS_ABORTED
        assert result.result.result.result == Result.RESULT_OPERATION_FAILED
        assert result.result.result.error_message == '50 of 1000 steps: the run ended'
        assert node.wait(timeout=ANSWER_S) == 0, node.output
        assert 'never awaited' not in node.output
    finally:
        node.stop(signal.SIGKILL)


def test_bad_filters_and_non_physical_states_are_refused_with_the_reason(tmp_path, client):
    node = NodeProcess(tmp_path, CONFIG / 'store_separation.yaml', paused=True, duration=0.0)
    try:
        client.ready(node)
        for pattern, why in (('(' * 1000 + ')' * 1000, 'RecursionError'),
                             ('a{99999999999999999999}', 'OverflowError'),
                             ('(', 'missing )')):
            filters = GetEntities.Request().filters
            filters.filter = pattern
            for service in ('get_entities', 'get_entities_states'):
                answer = client.call(service, filters=filters).result
                assert answer.result == Result.RESULT_OPERATION_FAILED, service
                assert why in answer.error_message and 'filter' in answer.error_message
        assert node.alive(), node.output

        # release the store (the pivot opens at 0.28 s), then try to fling it
        assert client.call('step_simulation', steps=400).result.result == Result.RESULT_OK
        before = client.state('store')
        for field, value, what in (('linear', 1.7e308, 'velocity'),
                                   ('angular', 1e12, 'angular velocity'),
                                   ('linear', float('nan'), 'velocity')):
            state = client.state('store')
            setattr(getattr(state.twist, field), 'x', value)
            answer = client.call('set_entity_state', entity='store', state=state).result
            assert answer.result == SetEntityState.Response.INVALID_POSE, what
            assert f'the {what}' in answer.error_message
        far = client.state('store')
        far.pose.position.z = -2e9
        answer = client.call('set_entity_state', entity='store', state=far).result
        assert answer.result == SetEntityState.Response.INVALID_POSE
        assert 'at most 1e+09' in answer.error_message and 'position' in answer.error_message
        after = client.state('store')   # nothing changed
        assert after.pose == before.pose and after.twist == before.twist
        # a fast but physical state is taken, and the run goes on from it
        fast = client.state('store')
        fast.twist.linear.x = 300.0
        answer = client.call('set_entity_state', entity='store', state=fast).result
        assert answer.result == Result.RESULT_OK, answer.error_message
        assert client.call('step_simulation', steps=10).result.result == Result.RESULT_OK
        assert client.state('store').pose.position.x > fast.pose.position.x + 2.9
        assert node.alive(), node.output
    finally:
        node.stop(signal.SIGINT)
