# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
No input is ever dropped or misplaced because the node is busy (SPEC section 3, issue 47).

The node is made as busy as a node can be: stopped (SIGSTOP) while a burst
of 300 stamped wrenches is sent, far more than the 10 messages ROS keeps by
default. Every one must reach the recording at its own stamp
(``input_queue_depth`` 1,000); with a queue of 10, every one lost must be
counted (``dropped_inputs``) and warned about. Following ``/clock``, an
input stamped before a ``/clock`` the node has followed, by less than
``input_window``, still takes effect at its stamp; one later than that is
counted in ``late_inputs`` and named.
"""

import os
import re
import signal

from geometry_msgs.msg import WrenchStamped
from recordings import read_checked
from rosharness import NodeProcess, Peer, stamp_ns
from test_player import SCENARIO, wait_for_clock_subscription
import yaml

T0 = 3_000_000_000_000   # the first /clock, ns: simulated time 0
MS = 1_000_000
BURST = 300
#: The burst's stamps: 0.5 ms apart from 0.5 ms on (simulated time), force x = its number.
BURST_STAMPS = [T0 + (k + 1) * MS // 2 for k in range(BURST)]
TOPIC = '/cfem/bodies/store/wrench'


def _wrench(stamp, force_x, frame='world'):
    msg = WrenchStamped()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp), 1_000_000_000)
    msg.header.frame_id = frame
    msg.wrench.force.x = float(force_x)
    return msg


def _started(tmp_path, **parameters):
    """Start a use_sim_time node of the hinged store at /clock T0; return it and its peer."""
    scenario = tmp_path / 'scenario.yaml'
    scenario.write_text(yaml.safe_dump(SCENARIO))
    recording = tmp_path / 'node.mcap'
    node = NodeProcess(tmp_path, scenario, use_sim_time=True, record=recording, duration=0.3,
                       **parameters)
    wait_for_clock_subscription(node)
    peer = Peer(['pylon', 'store'], ['pivot'])
    peer.connected(60.0)
    peer.spin_until(lambda: peer.clock(T0) or 'simulated time 0 is that stamp' in node.output,
                    60.0, 'the node to start at the first /clock')
    # a first message the node takes (refused: an unknown frame), so that the burst's
    # sequence numbers follow one it has seen
    peer.wrench_pubs['store'].publish(_wrench(T0, 0.0, 'nowhere'))
    peer.spin_until(lambda: 'nowhere' in node.output, 60.0,
                    'the refusal of the first message')
    return node, peer, recording


def _burst_while_stopped(node, peer):
    """Send the burst while the node's process is stopped; it goes on after it."""
    os.kill(node.process.pid, signal.SIGSTOP)
    try:
        for k, stamp in enumerate(BURST_STAMPS):
            peer.wrench_pubs['store'].publish(_wrench(stamp, k + 1))
        peer.spin_for(0.5)
    finally:
        os.kill(node.process.pid, signal.SIGCONT)


def _run_out(node, peer, start_ms):
    """Send /clock from start_ms to 450 ms every 10 ms; the node ends at 0.3 s by itself."""
    for ms in range(start_ms, 460, 10):
        peer.clock(T0 + ms * MS)
        peer.spin_for(0.02)
    status = node.wait(120.0)
    assert status == 0, node.output


def _wrenches(recording):
    """Return (log time, stamp, force x) of each good wrench input recorded."""
    return [(log, stamp_ns(m.header), m.wrench.force.x)
            for topic, log, _, m in read_checked(recording)[2]
            if topic == TOPIC and m.header.frame_id == 'world']


def test_a_burst_to_a_stopped_node_all_on_its_stamps_and_late_inputs_counted(tmp_path):
    node, peer, recording = _started(tmp_path)
    try:
        _burst_while_stopped(node, peer)
        # /clock 0.2 s: the run goes to 0.15 s (input_window 0.05 behind it)
        peer.spin_until(lambda: peer.clock(T0 + 200 * MS) or any(
            stamp_ns(m.header) == T0 + 150 * MS for m in peer.received['bodies/store/pose']),
            60.0, 'the sample at 0.15 s')
        peer.wrench_pubs['store'].publish(_wrench(T0 + 100 * MS, -1.0))   # 50 ms too late
        peer.wrench_pubs['store'].publish(_wrench(T0 + 170 * MS, -2.0))   # within the window
        # the late one is taken (and warned about) before the next /clock: at this one's time
        peer.spin_until(lambda: 'a message stamped 0.100000 s' in node.output, 60.0,
                        'the late input taken')
        _run_out(node, peer, 200)
    finally:
        node.stop()
        peer.close()
    wrenches = _wrenches(recording)
    burst = [w for w in wrenches if w[2] > 0]
    assert [w[2] for w in burst] == list(range(1, BURST + 1)), node.output   # none lost
    assert all(log == stamp for log, stamp, _ in burst)   # each at its own stamp
    # before a /clock the node followed, within input_window: at its stamp
    assert (T0 + 170 * MS, T0 + 170 * MS, -2.0) in wrenches
    # stamped 0.1 s when the run was at 0.15 s: late, at the /clock it came with (0.2 s)
    assert (T0 + 200 * MS, T0 + 100 * MS, -1.0) in wrenches
    assert f'diagnostics: late_inputs 1 (1 on {TOPIC}), dropped_inputs 0' in node.output
    assert re.search(rf'{TOPIC}: a message stamped 0\.100000 s .*raise input_window',
                     node.output), node.output


def test_a_full_queue_counts_every_message_it_lost(tmp_path):
    node, peer, recording = _started(tmp_path, input_queue_depth=10)
    try:
        _burst_while_stopped(node, peer)
        _run_out(node, peer, 0)
    finally:
        node.stop()
        peer.close()
    burst = [w for w in _wrenches(recording) if w[2] > 0]
    dropped = int(re.search(r'dropped_inputs (\d+)', node.output).group(1))
    assert len(burst) + dropped == BURST, node.output   # each recorded or counted
    assert dropped > 0 and len(burst) >= 10, node.output   # the queue of 10 overflowed
    assert 'input_queue_depth 10' in node.output and f'{dropped} on {TOPIC}' in node.output
    assert all(log == stamp for log, stamp, _ in burst)   # those kept: at their stamps
