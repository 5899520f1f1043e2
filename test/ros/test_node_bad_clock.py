# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A /clock that jumps or goes negative, and stamps or forces beyond any use (issue 41.3, 41.4).

A negative /clock ended the node (rclpy's time source raised through the
spin loop); a wrench stamped 2^31 - 1 s + 2^32 - 1 ns ended it in the
recorder; a 1e300 N wrench ended its run; one /clock message 1e5 s ahead
was simulated in one callback, deaf to SIGINT. Each is now a warning, the
bad message not applied, and a long catch-up goes in slices that a signal
stops.
"""

import signal
import time

from geometry_msgs.msg import WrenchStamped
from recordings import read_checked
from rosharness import NodeProcess, stamp_ns
from test_node import FREE_BODIES, MS, peer_factory, T0, tick, write_scenario  # noqa: F401


def test_bad_clock_and_stamps_are_warnings_and_a_long_catch_up_stops_on_sigint(
        tmp_path, peer_factory):  # noqa: F811
    scenario = write_scenario(tmp_path, FREE_BODIES)
    recording = tmp_path / 'clock.mcap'
    node = NodeProcess(tmp_path, scenario, use_sim_time=True, record=recording,
                       rate_hz=1000.0, duration=0.0, input_window=0.0)   # in lockstep
    try:
        peer = peer_factory(['ball', 'spinner'], [])
        peer.connected(timeout=120.0)
        tick(peer, T0, ['ball', 'spinner'])
        peer.clock(-1_000_000_000)                          # sec = -1
        far = WrenchStamped()
        far.header.stamp.sec, far.header.stamp.nanosec = 2 ** 31 - 1, 2 ** 32 - 1
        far.header.frame_id = 'world'
        far.wrench.force.x = 1.0
        peer.send(peer.wrench_pubs['ball'], far)
        peer.wrench('ball', [1e300, 0, 0], stamp=T0 + 20 * MS)
        peer.clock(T0 + 100_000 * 1_000_000_000)             # 1e5 s ahead: ignored
        # best effort: make sure the node saw this one before the next
        peer.spin_until(lambda: 'at once is ignored' in node.output, timeout=60.0,
                        what='the jump of /clock refused')
        tick(peer, T0 + 50 * MS, ['ball', 'spinner'])        # still following the clock
        assert node.alive(), node.output
        # 1000 s ahead at 1 kHz: a million samples; SIGINT must stop it within a slice
        peer.clock(T0 + 1000 * 1_000_000_000)
        peer.spin_until(lambda: any(stamp_ns(m.header) > T0 + 1000 * MS
                                    for m in peer.received['bodies/ball/pose']),
                        timeout=60.0, what='the catch-up under way')
        asked = time.monotonic()
        status = node.stop(signal.SIGINT, timeout=20.0)
        stopped_after = time.monotonic() - asked
    finally:
        if node.alive():
            node.stop(signal.SIGKILL)
    assert status == 0, node.output
    # generous: the catch-up yields every 0.05 s of wall time (TICK_BUDGET)
    assert stopped_after < 10.0, f'{stopped_after:.1f} s to stop'
    out = node.output
    assert 'negative time; ignored' in out
    assert 'is not a ROS time' in out and 'must be at most 1e+09' in out
    assert 'more than 3600 s at once is ignored' in out
    # nothing was applied: the ball never moved; the recording is complete
    assert all(m.pose.position.x == 0.0 for m in peer.received['bodies/ball/pose'])
    _, _, messages = read_checked(recording)
    assert any(topic == '/cfem/bodies/ball/pose' for topic, *_ in messages)
