# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
cfem_node under a flood of good and bad inputs from another process.

A second process (``rosharness.flood``) sends wrenches and release commands
as fast as it can up to 10 kHz: good wrenches mixed with non-finite ones,
unknown and empty frames, unknown, empty and repeated joints, and 1 MiB
strings. The node must keep its publish rate, keep its memory bounded,
rate-limit its warnings, record refused messages in a bounded form, never
apply a bad message, apply every good one it took, and leave a complete
recording after SIGINT. ``CFEM_LONG_TESTS=1`` floods for 10 s instead of 3.
"""

import math
import os
import pathlib
import re
import signal

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.run.inputs import InputKind
from cfem_ros.core.scenario.parse import load_scenario
from cfem_ros.recording import offline
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.recorder import StateRecorder
from cfem_ros.recording.replay import read_inputs
from cfem_ros.ros.refusals import REFUSED_STRING_BYTES
import numpy as np
from recordings import read_checked
from rosharness import BIG, Flood, NodeProcess
from test_node import numbers, peer_factory  # noqa: F401

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
LONG = os.environ.get('CFEM_LONG_TESTS') == '1'
SECONDS = 10.0 if LONG else 3.0
RATE_HZ = 100.0


def rss_mb(pid) -> float:
    """Resident memory of a process, MB."""
    for line in pathlib.Path(f'/proc/{pid}/status').read_text().splitlines():
        if line.startswith('VmRSS:'):
            return int(line.split()[1]) / 1024
    raise AssertionError('no VmRSS')


def good(item, released):
    """Tell whether the node must apply an input of store_release_on_command."""
    if item.kind is InputKind.RELEASE:
        return item.target == 'pivot' and not released
    return (item.target == 'store' and item.frame_id in ('world', 'store')
            and np.isfinite(item.force).all() and np.isfinite(item.torque).all())


def test_flood_of_good_and_bad_inputs(tmp_path, peer_factory):  # noqa: F811
    scenario = CONFIG / 'store_release_on_command.yaml'
    recording = tmp_path / 'flood.mcap'
    node = NodeProcess(tmp_path, scenario, record=recording, rate_hz=RATE_HZ, duration=0.0)
    try:
        peer = peer_factory(['pylon', 'store'], ['pivot'])
        peer.connected(timeout=60.0)
        poses = peer.received['bodies/store/pose']
        peer.spin_until(lambda: len(poses) >= 100, timeout=60.0, what='poses')
        pid = node.process.pid
        rss_before = rss_mb(pid)
        flood = Flood(tmp_path, '/cfem', 'store', SECONDS)
        peer.spin_until(lambda: 'message not applied' in node.output, timeout=60.0,
                        what='the flood to start')
        flood_start = peer.now_ns()
        rss = [rss_before]
        while flood.process.poll() is None:
            peer.spin_for(0.2)
            rss.append(rss_mb(pid))
        rss_peak = max(rss)
        flood_end = peer.now_ns()
        sent = flood.result(timeout=30.0)
        # a flood's 1 MiB messages may be overwritten in DDS's history before they leave
        # under load; one more, alone, reaches the node
        peer.release(BIG)
        peer.spin_for(0.5)
        lines_before = node.output.count('\n')
        peer.spin_for(1.0)
        assert node.alive(), node.output
    finally:
        status = node.stop(signal.SIGINT)
    assert status == 0, node.output[-3000:]
    output = node.output

    # poses received in every whole second of the flood
    arrivals = np.array(peer.arrivals['bodies/store/pose'])
    bins = [int(((arrivals >= a) & (arrivals < a + 1_000_000_000)).sum())
            for a in range(flood_start, flood_end - 1_000_000_000 + 1, 1_000_000_000)]
    refused_lines = [line for line in output.splitlines() if 'message not applied' in line]
    print(f"flood: {sent['sent']} messages in {sent['seconds']:.2f} s "
          f"({sent['rate_hz']:.0f}/s), {len(sent['good_forces'])} good; poses per second "
          f'{bins}; node RSS {rss_before:.0f} -> peak {rss_peak:.0f} MB; '
          f'{len(refused_lines)} warning lines, longest {max(map(len, refused_lines))} chars; '
          f'recording {recording.stat().st_size / 1e6:.1f} MB')
    assert len(bins) >= int(SECONDS) - 1
    # the flood never starved the node a whole second (the rate held is a figure of load:
    # printed above, not asserted)
    assert min(bins) >= 1, bins
    # memory: DDS takes some for 1 MiB messages (at most 10 kept per topic, and
    # fragment buffers), then it levels off: nothing piles up
    print('RSS, MB, every 0.2 s:', [round(r) for r in rss])
    # (measured: +115 MB in 3 s; +224 MB over 10 s, level for the last 2 s)
    assert rss_peak - rss_before <= 300.0, (rss_before, rss_peak)
    if LONG:
        assert rss[-1] - rss[-11] <= 20.0, rss

    # warnings: at most one line per topic and reason per second (plus the summaries)
    kinds = {re.sub(r"'.*?'|\(\d+ more.*\)|[\d.]+", '', line.split(']: ', 1)[1])
             for line in refused_lines}
    assert len(refused_lines) <= len(kinds) * (sent['seconds'] + 3), len(refused_lines)
    assert max(map(len, refused_lines)) <= 1000
    assert 'not shown' in output
    assert output.count('\n') - lines_before <= len(kinds) + 10   # quiet once it is over
    assert re.search(r'messages refused: \d+ on /cfem/bodies/store/wrench, '
                     r'\d+ on /cfem/release', output)

    # the recording: complete after SIGINT; refused strings bounded, good messages exact
    _, summary, messages = read_checked(recording)
    releases = [m.data for topic, _, _, m in messages if topic == '/cfem/release']
    wrenches = [m for topic, _, _, m in messages if topic == '/cfem/bodies/store/wrench']
    limit = REFUSED_STRING_BYTES + len('... [1048576 bytes, truncated]')
    assert releases.count('pivot') >= 1 and max(map(len, releases)) <= limit
    assert any(r.endswith('[1048576 bytes, truncated]') for r in releases)
    assert max(len(m.header.frame_id) for m in wrenches) <= limit
    sent_good = set(sent['good_forces'])
    recorded_good = [m.wrench.force.x for m in wrenches if m.header.frame_id == 'world'
                     and math.isfinite(m.wrench.force.x)
                     and math.isfinite(m.wrench.torque.y)]
    assert recorded_good and set(recorded_good) <= sent_good
    assert all(m.wrench.torque.y == m.wrench.force.x for m in wrenches
               if m.header.frame_id == 'world' and math.isfinite(m.wrench.force.x))
    assert recorded_good == sorted(recorded_good)   # in the order sent
    events = [m.data for topic, _, _, m in messages if topic == '/cfem/events']
    assert len(events) == 1 and '"cause": "command"' in events[0]

    # no bad message applied, every good one taken applied: the node's motion is a
    # run with only the good inputs it recorded
    inputs, released = [], False
    for item in read_inputs(str(recording)):
        if good(item, released):
            inputs.append(item)
            released = released or item.kind is InputKind.RELEASE
    assert len(inputs) == len(recorded_good) + 1
    samples = [(topic, log, m) for topic, log, _, m in messages
               if topic.endswith(('/pose', '/twist'))]
    start_ns = min(log for _, log, _ in samples)
    last = max(log for _, log, _ in samples) - start_ns
    sim = Simulator(load_scenario(str(scenario)))
    out = tmp_path / 'good_only.mcap'
    with Recorder(str(out)) as recorder:
        assert offline.run(sim, StateRecorder(recorder, sim), rate_hz=RATE_HZ,
                           duration=last / 1e9, inputs=inputs)
    _, _, theirs = read_checked(out)
    reference = {(topic, log): m for topic, log, _, m in theirs}
    worst = max(np.abs(numbers(m) - numbers(reference[(topic, log - start_ns)])).max()
                for topic, log, m in samples)
    assert worst <= 1e-9, worst
