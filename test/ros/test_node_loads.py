# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The node publishes and records the scheduled loads as the offline run does."""

import pathlib
import signal

from cfem_ros import analysis, cli
import numpy as np
import pytest
from rosharness import NodeProcess, Peer, stamp_ns

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
    node = NodeProcess(tmp_path, scenario, use_sim_time=True, record=recording, duration=0.0)
    try:
        peer.connected()
        received = peer.received['bodies/store/applied/aft_ejector']
        for k in range(0, 11):
            clock = T0 + 10 * k * MS
            deadline = 0
            while not any(stamp_ns(m.header) == clock for m in received):
                assert deadline < 40, f'no applied load at /clock {clock} ns'
                peer.clock(clock)
                peer.spin_for(0.25)
                deadline += 1
    finally:
        status = node.stop(signal.SIGINT)
    assert status == 0, node.output
    published = {stamp_ns(m.header): m.wrench for m in received}
    # the offline run's numbers, sample for sample
    out = tmp_path / 'offline.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out), '--duration', '0.1']) == 0
    offline = analysis.open_run(str(out)).applied['store/aft_ejector']
    recorded = analysis.open_run(str(recording)).applied['store/aft_ejector']
    for k in range(11):
        wrench = published[T0 + 10 * k * MS]
        force = [wrench.force.x, wrench.force.y, wrench.force.z]
        moment = [wrench.torque.x, wrench.torque.y, wrench.torque.z]
        assert np.array_equal(force, offline.force[k])
        assert np.array_equal(moment, offline.moment[k])
        assert np.array_equal(recorded.force[k], offline.force[k])
    assert offline.force[0, 2] == 42703.0 and offline.force[10, 2] == 0.0
