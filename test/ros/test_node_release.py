# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Release groups over the node's topics, with ``cfem_pub`` (SPEC sections 3 and 7).

The two-hook example as the user guide runs it: the node, a wrench at a point
with ``cfem_pub wrench --frame body@x,y,z``, ``cfem_pub release station_1``,
then the node's recording replayed offline with ``cfem-sim run --inputs``.
"""

import json
import pathlib
import signal
import subprocess
import sys

from cfem_ros import cli
from cfem_ros.recording.analysis import open_run
import numpy as np
from rosharness import NodeProcess

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
PUB = str(pathlib.Path(sys.executable).parent / 'cfem_pub')


def cfem_pub(*args):
    return subprocess.run([PUB, *args], capture_output=True, text=True, timeout=60)


def printed_events(result):
    return [json.loads(line.split(': ', 1)[1]) for line in result.stdout.splitlines()
            if line.startswith('/cfem/events: ')]


def test_cfem_pub_releases_the_station_in_one_instant_and_the_replay_agrees(tmp_path):
    record = tmp_path / 'two_hooks.mcap'
    # a quarter of real time: a loaded test machine keeps up, so the release takes
    # effect at once (a node that lags applies it where the clock says it is)
    node = NodeProcess(tmp_path, CONFIG / 'store_release_two_hooks.yaml', duration=0.0,
                       real_time_factor=0.25, record=str(record))
    try:
        # a force at a point of the store, in its axes: accepted by cfem_pub and the node
        result = cfem_pub('wrench', 'store', '--force', '0', '0', '-100', '--frame',
                          'store@0.18,0,-0.25')
        assert result.returncode == 0, result.stderr
        result = cfem_pub('wrench', 'store', '--frame', 'store@0.18,0')
        assert result.returncode == 2 and 'three finite numbers' in result.stderr
        result = cfem_pub('release', 'station_1')
        assert result.returncode == 0, result.stderr + node.output
        events = printed_events(result)
        assert [e['joint'] for e in events] == ['fwd_hook', 'aft_hook']
        assert events[0]['time'] == events[1]['time'] > 0.0
        assert all(e['group'] == 'station_1' and e['cause'] == 'command' for e in events)
        assert 'frame_id' not in node.output   # the wrench at a point was applied
    finally:
        assert node.stop(signal.SIGINT) == 0, node.output
    run = open_run(str(record))
    strokes = run.stroke_ends()
    assert set(strokes) == {'forward_ejector', 'aft_ejector'}
    # the sway braces: each one's push on the store and on the pylon, the preload while
    # the store is carried, nothing once its pad let go after the release
    for brace in ('fwd_left', 'fwd_right', 'aft_left', 'aft_right'):
        push, back = run.applied[f'store/{brace}'], run.applied[f'pylon/{brace}']
        np.testing.assert_allclose(np.linalg.norm(push.force[0]), 2000.0, rtol=1e-9)
        np.testing.assert_allclose(back.force, -push.force, rtol=0, atol=1e-9)
        assert np.all(push.force[push.time > events[0]['time'] + 0.01] == 0.0)
    lets_go = [e for e in run.events if e['event'] == 'brace_contact']
    assert len(lets_go) == 4 and not any(e['contact'] for e in lets_go)
    assert all(s['time'] > events[0]['time'] for s in strokes.values())
    # the same run offline, from the node's recording
    replay = tmp_path / 'replay.mcap'
    assert cli.main(['run', str(CONFIG / 'store_release_two_hooks.yaml'), '-o', str(replay),
                     '--inputs', str(record), '--duration', str(run.duration)]) == 0
    again = open_run(str(replay))
    assert again.releases() == run.releases()
    # (the release's time goes through the recording's whole nanoseconds: to rounding)
    for name, figures in strokes.items():
        assert abs(again.stroke_ends()[name]['time'] - figures['time']) < 1e-12
        np.testing.assert_allclose(again.stroke_ends()[name]['velocity'],
                                   figures['velocity'], rtol=0, atol=1e-9)
        np.testing.assert_allclose(again.stroke_ends()[name]['rates'], figures['rates'],
                                   rtol=0, atol=1e-9)


def test_cfem_pub_sends_several_names_in_one_message():
    from cfem_ros.ros import publish
    args = publish.build_parser().parse_args(['release', 'fwd_hook', 'aft_hook'])
    kind, topic, message = publish._message(args)
    assert (topic, message.data) == ('release', 'fwd_hook aft_hook')
