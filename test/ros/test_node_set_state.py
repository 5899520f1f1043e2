# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
One way to set a state: the node's set_entity_state is a batch copy's initial state (issue 46.4).

A store under its pylon, free (the hooks taken out), pushed by two
ejectors over their strokes, watched for contact with the pylon and the
wing, with aero tables. A node made in this process, paused, is given the
store's pose and twist through the ``set_entity_state`` service's handler,
then stepped 60 steps. The batch's copy of that state (``Simulator`` then
``set_state(y0, start=True)``, as ``batch.run`` makes it) run offline over
the same samples must give every sample to the bit: the strokes measured
from the state set (the ejectors let go 0.1006 m below where the store was
put, not where the scenario had it), the contact pairs and the aero tables
watched from there. ``batch.run`` itself, which takes no samples, agrees at
the first sample in the last digits. Before issue 46.4 the node only wrote
the state: its samples parted from the batch's by up to 5e-3 (m/s, rad/s) at t = 0.03 s.
"""

import pathlib
import shutil

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.run import batch
from cfem_ros.core.run.session import Session, Sink
from cfem_ros.core.scenario.parse import load_scenario
from cfem_ros.ros.node import CfemNode
import numpy as np
import pytest
import rclpy
from rclpy.signals import SignalHandlerOptions
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
#: Steps compared (0.06 s at dt 1 ms): the strokes end at about 0.035 s.
STEPS = 60


@pytest.fixture
def scenario(tmp_path):
    data = yaml.safe_load((CONFIG / 'store_release_near_pylon.yaml').read_text())
    data.pop('joints')   # the store free from t = 0: set_entity_state may move it
    data['duration'] = 1.0
    shutil.copy(CONFIG / 'store_release_near_pylon_field.csv', tmp_path)
    path = tmp_path / 'free_store.yaml'
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture
def node(scenario):
    context = rclpy.Context()
    rclpy.init(args=['--ros-args', '-p', f'scenario:={scenario}', '-p', 'paused:=true',
                     '-p', 'real_time_factor:=0.0'],
               context=context, signal_handler_options=SignalHandlerOptions.NO)
    made = None
    try:
        made = CfemNode(context=context)
        yield made
    finally:
        if made is not None:
            made.close()
            made.destroy_node()
        rclpy.try_shutdown(context=context)


class Rows(Sink):
    """A session output that keeps each sample's time, numbers (``outputs``) and state."""

    def __init__(self, sim):
        self.sim, self.rows = sim, []

    def sample(self):
        self.rows.append((self.sim.t, self.sim.outputs(), self.sim.y.copy()))


def test_a_state_set_through_the_service_runs_as_a_batch_copy_of_it(node, scenario):
    srv = pytest.importorskip('simulation_interfaces.srv')
    msg = pytest.importorskip('simulation_interfaces.msg')
    request = srv.SetEntityState.Request(entity='store')
    state = request.state
    state.pose.position.x, state.pose.position.y, state.pose.position.z = 0.01, 0.0, 0.02
    half = 0.5 * np.radians(2.0)   # pitched 2 degrees nose up
    q = state.pose.orientation
    q.x, q.y, q.z, q.w = 0.0, np.sin(half), 0.0, np.cos(half)
    state.twist.linear.x, state.twist.linear.z = 250.0, 1.5
    state.twist.angular.y = 0.2
    response = node.simulation_services._set_entity_state(
        request, srv.SetEntityState.Response())
    assert response.result.result == msg.Result.RESULT_OK, response.result.error_message
    y0 = node.sim.y.copy()
    assert node.sim.position[node.sim.body_index('store')].tolist() == [0.01, 0.0, 0.02]
    mine = Rows(node.sim)
    node.run.session.outputs.append(mine)
    assert node.control.step(STEPS, announce=False) == STEPS

    # the batch's copy of that state (batch.run: a Simulator, then set_state(y0, start=True)),
    # run offline over the same samples, as cfem-sim run runs it
    model = load_scenario(str(scenario))
    sim = Simulator(model)
    sim.set_state(y0, start=True)
    theirs = Rows(sim)
    session = Session(sim, rate_hz=node.rate_hz, duration=node.duration, outputs=[theirs])
    session.start()
    session.advance(node.sim.t, land=True)
    assert sim.t == node.sim.t == pytest.approx(STEPS * model.dt)
    # the node's t = 0 sample went out before the state was set (paused); theirs is of it
    assert len(mine.rows) == len(theirs.rows) - 1 == STEPS // 10   # 100 Hz
    for (t, row, y), (t_batch, row_batch, y_batch) in zip(mine.rows, theirs.rows[1:]):
        assert t == t_batch, t
        assert np.array_equal(row, row_batch) and np.array_equal(y, y_batch), f't = {t}'
    assert np.array_equal(node.sim.y, sim.y)
    strokes = [e for e in sim.events if e['event'] == 'stroke_end']
    assert len(strokes) == 2 and [e for e in node.sim.events if e['event'] == 'stroke_end'] \
        == strokes
    # pushed down and pitching, the store's push points run their 0.1006 m strokes first
    # aft, then forward, about 35 ms after the state was set (the scenario's place: 52 ms)
    assert 0.03 < strokes[0]['time'] < strokes[1]['time'] < 0.045
    # and batch.run itself, which takes no samples, to the first sample: the same steps
    # (no event before it); the state differs in its last digits only (one kernel call
    # against one per step puts the stage times a rounding apart)
    first = batch.run(model, [{'y0': y0}], duration=mine.rows[0][0], workers=1)[0]
    np.testing.assert_allclose(first.y, mine.rows[0][2], rtol=0, atol=1e-12)
