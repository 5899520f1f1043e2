# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Real time: a sample's stamp is the ROS time of its publication; an input acts at its stamp.

The node runs in its own process; the start stamp must be taken after all
set-up, so set-up is made slow (a sleep hook) and the stamps must still be
on ROS time. How close to its stamp a sample is published is a matter of
load: ``benchmarks/bench_node.py`` measures it. What is asserted here holds
on any machine: stamps are on ROS time (not 2 s behind it, as a start stamp
taken before set-up would make them), on the sample grid, increasing;
and a wrench stamped ahead takes effect exactly at its stamp.
"""

import os
import signal

from recordings import read_checked
from rosharness import NodeProcess, stamp_ns
from test_node import FREE_BODIES, MS, peer_factory, write_scenario  # noqa: F401

RATE_HZ = 100.0
PERIOD_NS = int(1e9 / RATE_HZ)
SET_UP_DELAY = 2.0
#: A bound only a broken clock (or a start stamp taken before set-up) crosses, ms.
GENEROUS_MS = 1000.0 * SET_UP_DELAY / 2


def _slow_set_up():
    return dict(os.environ, CFEM_NODE_SETUP_DELAY=repr(SET_UP_DELAY))


def test_stamps_are_ros_time_and_a_stamped_input_acts_at_its_stamp(
        tmp_path, peer_factory):  # noqa: F811
    scenario = write_scenario(tmp_path, FREE_BODIES)
    recording = tmp_path / 'rt.mcap'
    node = NodeProcess(tmp_path, scenario, env=_slow_set_up(), record=recording,
                       rate_hz=RATE_HZ, duration=0.0)
    try:
        peer = peer_factory(['ball', 'spinner'], [])
        peer.connected(timeout=180.0)
        poses = peer.received['bodies/ball/pose']
        peer.spin_until(lambda: len(poses) >= 50, timeout=60.0, what='poses')
        t_on = peer.now_ns() + 500 * MS   # ahead of the simulation: it waits for it
        peer.wrench('ball', [4.0, 0, 0], stamp=t_on)
        peer.spin_until(lambda: len(poses) >= 150, timeout=60.0, what='150 poses')
    finally:
        status = node.stop(signal.SIGINT)
    assert status == 0, node.output

    # publication (the DDS source timestamp: the node's ROS time when it wrote the
    # sample) minus stamp: never before the stamp (clock resolution aside), and not
    # the set-up's seconds after it
    stamps = [stamp_ns(m.header) for m in poses]
    delays_ms = [(written - stamp) / 1e6
                 for written, stamp in zip(peer.published['bodies/ball/pose'], stamps)]
    assert len(delays_ms) >= 150
    assert min(delays_ms) >= -0.5, min(delays_ms)
    assert sorted(delays_ms)[len(delays_ms) // 2] < GENEROUS_MS
    # on the sample grid, increasing (reliable keep-last may drop one under load)
    assert all(b > a and (b - a) % PERIOD_NS == 0 for a, b in zip(stamps, stamps[1:]))

    # the wrench took effect at its stamp, to the nanosecond, and not before
    _, _, messages = read_checked(recording)
    logged = [log for topic, log, _, _ in messages if topic == '/cfem/bodies/ball/wrench']
    assert logged == [t_on]
    assert '] [cfem.cfem_sim]: diagnostics: late_inputs 0' in node.output
    # and from that very time: x = F (t - t_on)^2 / (2 m), exact under RK4 (cut at t_on)
    for msg in poses:
        t = stamp_ns(msg.header)
        expected = 4.0 * (max(t - t_on, 0) / 1e9) ** 2 / (2 * 2.0)
        # RK4 is exact for a constant force; what is left is rounding, relative to x
        assert abs(msg.pose.position.x - expected) <= 1e-12 * max(1.0, expected)
