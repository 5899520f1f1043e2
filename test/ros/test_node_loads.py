# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The node publishes and records the scheduled loads as the offline run does."""

import pathlib
import signal

from cfem_ros import cli
from cfem_ros.core import rotations
from cfem_ros.recording import analysis
import numpy as np
import pytest
from rosharness import clock_through, NodeProcess, Peer, stamp_ns

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
T0 = 1_000_000_000_000  # /clock start: 1000 s
MS = 1_000_000


@pytest.fixture
def peer():
    made = Peer(['pylon', 'store'], [], applied=[('store', 'aft_ejector')])
    yield made
    made.close()


def test_node_publishes_and_records_the_applied_loads(tmp_path, peer):
    scenario = CONFIG / 'store_separation_ejectors.yaml'
    recording = tmp_path / 'node.mcap'
    node = NodeProcess(tmp_path, scenario, use_sim_time=True, record=recording, duration=0.0,
                       input_window=0.0)   # in lockstep: each sample at its /clock
    try:
        peer.connected()
        received = peer.received['bodies/store/applied/aft_ejector']
        clock_through(peer, received, [T0 + 10 * k * MS for k in range(11)], 'applied load')
    finally:
        status = node.stop(signal.SIGINT)
    assert status == 0, node.output
    published = {stamp_ns(m.header): m for m in received}
    in_world = {stamp_ns(m.header): m for m in peer.received[
        'bodies/store/applied_world/aft_ejector']}
    # the offline run's numbers, sample for sample
    out = tmp_path / 'offline.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out), '--duration', '0.1']) == 0
    run = analysis.open_run(str(out))
    offline = run.applied['store/aft_ejector']
    recorded = analysis.open_run(str(recording)).applied['store/aft_ejector']
    # in the store's axes on applied/, in world axes on applied_world/ (SPEC section 5)
    attitude = run.bodies['store'].quaternion[:11]
    force_body = rotations.to_body(attitude, offline.force[:11])
    moment_body = rotations.to_body(attitude, offline.moment[:11])
    for k in range(11):
        world, body = in_world[T0 + 10 * k * MS], published[T0 + 10 * k * MS]
        assert (world.header.frame_id, body.header.frame_id) == ('world', 'store')
        assert np.array_equal(_vector(world.wrench.force), offline.force[k])
        assert np.array_equal(_vector(world.wrench.torque), offline.moment[k])
        assert np.array_equal(recorded.force[k], offline.force[k])
        np.testing.assert_allclose(_vector(body.wrench.force), force_body[k], rtol=0,
                                   atol=1e-9 * np.abs(offline.force[k]).max())
        np.testing.assert_allclose(_vector(body.wrench.torque), moment_body[k], rtol=0,
                                   atol=1e-9 * max(np.abs(offline.moment[k]).max(), 1.0))
    assert offline.force[0, 2] == 42703.0 and offline.force[10, 2] == 0.0


def _vector(v):
    return [v.x, v.y, v.z]
