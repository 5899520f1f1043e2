# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The node publishes and records the air each body sees as the offline run does (SPEC 10)."""

import pathlib
import signal

from cfem_ros import cli
from cfem_ros.recording import analysis
from cfem_ros.recording.airtracks import read_air
from geometry_msgs.msg import Vector3Stamped
import numpy as np
import pytest
from rosharness import clock_through, NodeProcess, Peer, stamp_ns

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
T0 = 1_000_000_000_000  # /clock start: 1000 s
MS = 1_000_000
TOPICS = ('flow', 'air', 'force_coefficients', 'moment_coefficients')


@pytest.fixture
def peer():
    made = Peer(['pylon', 'store'], [])
    for name in TOPICS:
        made._collect(Vector3Stamped, f'bodies/store/aero/{name}')
    yield made
    made.close()


def test_node_publishes_and_records_the_air_each_body_sees(tmp_path, peer):
    scenario = CONFIG / 'store_separation_aero.yaml'
    recording = tmp_path / 'node.mcap'
    node = NodeProcess(tmp_path, scenario, use_sim_time=True, record=recording, duration=0.0,
                       input_window=0.0)   # in lockstep: each sample at its /clock
    try:
        peer.connected()
        received = peer.received['bodies/store/aero/flow']
        clock_through(peer, received, [T0 + 10 * k * MS for k in range(11)], 'aero flow')
    finally:
        status = node.stop(signal.SIGINT)
    assert status == 0, node.output
    out = tmp_path / 'offline.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out), '--duration', '0.1']) == 0
    run = analysis.open_run(str(out))
    offline = read_air(str(out), run.namespace, run.start_ns)['store']
    node_run = analysis.open_run(str(recording))
    recorded = read_air(str(recording), node_run.namespace, node_run.start_ns)['store']
    for name in TOPICS:
        published = {stamp_ns(m.header): m for m in peer.received[f'bodies/store/aero/{name}']}
        for k in range(11):
            message = published[T0 + 10 * k * MS]
            assert message.header.frame_id == 'store'
            v = message.vector
            assert np.array_equal([v.x, v.y, v.z], offline.values[name][k]), (name, k)
            assert np.array_equal(recorded.values[name][k], offline.values[name][k]), (name, k)
    # the numbers are the air's: 290 m/s at 7925 m ISA, alpha growing as the store pitches
    assert offline.values['air'][0, 2] == pytest.approx(290.0)
    assert offline.values['flow'][0, 2] == pytest.approx(290.0 / 308.1, rel=1e-3)
    assert offline.values['flow'][10, 0] > offline.values['flow'][0, 0] + 0.5
