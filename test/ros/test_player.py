# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""``cfem-sim play``: a recording published over DDS drives a use_sim_time node."""

import json
import pathlib
import signal
import subprocess
import sys
import time
import types

from cfem_ros import cli
from cfem_ros.recording.container import EVENTS_OFFERED_QOS, OFFERED_QOS, Recorder
from cfem_ros.recording.schema import STRING_TYPE, WRENCH_TYPE
from cfem_ros.ros import player
from geometry_msgs.msg import PoseStamped
import numpy as np
import pytest
from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy
from recordings import read_checked
from rosharness import NodeProcess, Peer, stamp_ns
import yaml

T0 = 2_000_000_000_000   # the log's first message: 2000 s
MS = 1_000_000
BIN = pathlib.Path(sys.executable).parent

SCENARIO = {
    'name': 'hinged_store', 'duration': 100.0, 'dt': 0.001,
    'bodies': {
        'pylon': {'fixed': True},
        'store': {'mass': 200.0, 'inertia': [5.0, 60.0, 60.0], 'position': [0.0, 0, -0.5]},
    },
    'joints': {'pivot': {'type': 'hinge', 'parent': 'pylon', 'child': 'store',
                         'anchor': [-0.4, 0, -0.3], 'axis': [0, 1, 0]}},
}


def _wrench(t_ns, force, frame='world'):
    return {'header': {'stamp': {'sec': t_ns // 10 ** 9, 'nanosec': t_ns % 10 ** 9},
                       'frame_id': frame},
            'wrench': {'force': dict(zip('xyz', map(float, force))),
                       'torque': {'x': 0.0, 'y': 0.0, 'z': 0.0}}}


def write_log(path):
    """Write a flight-test-like input log: wrenches on the store, a release command."""
    # integer-form QoS on the release channel, as older rosbag2 writes it
    integer_qos = '- history: 1\n  depth: 10\n  reliability: 1\n  durability: 2\n'
    with Recorder(str(path)) as rec:
        rec.write('/cfem/bodies/store/wrench', WRENCH_TYPE, _wrench(T0, [0, 0, 500.0]), T0)
        rec.write('/cfem/bodies/store/wrench', WRENCH_TYPE,
                  _wrench(T0 + 150 * MS, [300.0, 0, 100.0], 'store'), T0 + 150 * MS)
        rec.write('/cfem/release', STRING_TYPE, {'data': 'pivot'}, T0 + 350 * MS, qos=integer_qos)
        rec.write('/cfem/bodies/store/wrench', WRENCH_TYPE, _wrench(T0 + 500 * MS, [0, 0, 0]),
                  T0 + 500 * MS)


def test_qos_profiles_in_string_and_integer_forms():
    named = player.parse_qos(EVENTS_OFFERED_QOS)
    assert named.reliability == ReliabilityPolicy.RELIABLE
    assert named.durability == DurabilityPolicy.TRANSIENT_LOCAL
    assert named.history == HistoryPolicy.KEEP_LAST and named.depth == 100
    numbered = player.parse_qos('- history: 1\n  depth: 5\n  reliability: 2\n  durability: 1\n')
    assert numbered.reliability == ReliabilityPolicy.BEST_EFFORT
    assert numbered.durability == DurabilityPolicy.TRANSIENT_LOCAL and numbered.depth == 5
    plain = player.parse_qos(OFFERED_QOS)
    assert plain.durability == DurabilityPolicy.VOLATILE and plain.depth == 10
    assert player.parse_qos('not: [yaml').reliability == ReliabilityPolicy.RELIABLE
    assert player.parse_remaps(['/a:=/b']) == {'/a': '/b'}
    assert player.message_class('geometry_msgs/msg/WrenchStamped').__name__ == 'WrenchStamped'
    assert player.message_class('no_such_pkg/msg/X') is None


def test_play_refuses_bad_arguments(tmp_path, capsys):
    log = tmp_path / 'log.mcap'
    write_log(log)
    assert cli.main(['play', str(log), '--rate', '0']) == 2
    assert '--rate' in capsys.readouterr().err
    assert cli.main(['play', str(log), '--remap', 'nothing']) == 2
    assert 'FROM:=TO' in capsys.readouterr().err
    assert cli.main(['play', str(tmp_path / 'missing.mcap')]) == 2
    err = capsys.readouterr().err
    assert 'missing.mcap' in err and err.count('\n') == 1


def test_play_remaps_without_rcl_deprecation_warning(tmp_path):
    log = tmp_path / 'log.mcap'
    write_log(log)
    done = subprocess.run([str(BIN / 'cfem-sim'), 'play', str(log), '--remap',
                           '/cfem/release:=/other/release', '--wait', '0', '--rate', '50'],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert 'messages played' in done.stdout
    assert 'deprecated' not in done.stderr and 'remap rule' not in done.stderr, done.stderr


def wait_for_clock_subscription(node, timeout=120.0):
    """Wait (bounded) until the node says it waits for /clock: its subscription exists."""
    deadline = time.monotonic() + timeout
    while 'waiting for /clock' not in node.output:
        assert node.alive(), node.output
        assert time.monotonic() < deadline, f'node not ready after {timeout:g} s'
        time.sleep(0.1)


def _samples(path, start_ns):
    _, _, messages = read_checked(path)
    out = {}
    for topic, log, _, msg in messages:
        if topic.endswith(('/pose', '/twist')) or '/joints/' in topic:
            out[(topic, log - start_ns)] = msg
    events = [json.loads(m.data) for topic, _, _, m in messages if topic.endswith('/events')]
    return out, events, messages


def _numbers(message):
    if hasattr(message, 'pose'):
        p, q = message.pose.position, message.pose.orientation
        return np.array([p.x, p.y, p.z, q.x, q.y, q.z, q.w])
    if hasattr(message, 'twist'):
        a, b = message.twist.linear, message.twist.angular
    else:
        a, b = message.wrench.force, message.wrench.torque
    return np.array([a.x, a.y, a.z, b.x, b.y, b.z])


def test_player_with_clock_drives_a_sim_time_node_like_the_offline_replay(tmp_path):
    scenario = tmp_path / 'scenario.yaml'
    scenario.write_text(yaml.safe_dump(SCENARIO))
    log = tmp_path / 'log.mcap'
    write_log(log)
    recording = tmp_path / 'node.mcap'
    node = NodeProcess(tmp_path, scenario, use_sim_time=True, record=recording, duration=0.0)
    try:
        wait_for_clock_subscription(node)
        done = subprocess.run(
            [str(BIN / 'cfem-sim'), 'play', str(log), '--clock', '--wait', '60',
             '--topics', '/cfem/bodies/store/wrench', '/cfem/release'],
            capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
        assert '4 messages played' in done.stdout
    finally:
        status = node.stop(signal.SIGINT)
    assert status == 0, node.output

    with open(recording, 'rb') as stream:
        from mcap.reader import make_reader
        meta = {r.name: r.metadata for r in make_reader(stream).iter_metadata()}
    start_ns = int(meta['cfem_ros']['start_stamp_ns'])
    assert start_ns == T0   # the first /clock: the log's first message
    ours, our_events, messages = _samples(recording, start_ns)
    # the inputs took effect at their recorded times
    inputs = [(topic, log - start_ns) for topic, log, _, _ in messages
              if topic in ('/cfem/bodies/store/wrench', '/cfem/release')]
    assert inputs == [('/cfem/bodies/store/wrench', 0), ('/cfem/bodies/store/wrench', 150 * MS),
                      ('/cfem/release', 350 * MS), ('/cfem/bodies/store/wrench', 500 * MS)]
    last = max(t for _, t in ours)
    assert last >= 500 * MS   # the clock ran to the last message
    out = tmp_path / 'offline.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out), '--inputs', str(log),
                     '--duration', repr(last / 1e9)]) == 0
    theirs, their_events, _ = _samples(out, 0)
    assert set(ours) == set(theirs)   # every sample: the node takes each step, whatever /clock
    worst = max(np.abs(_numbers(m) - _numbers(theirs[key])).max() for key, m in ours.items())
    assert worst == 0.0   # to the bit
    assert [(e['joint'], e['cause']) for e in our_events] == [('pivot', 'command')]
    assert our_events[0]['time'] == 0.35
    assert [e['joint'] for e in their_events] == ['pivot']
    assert their_events[0]['time'] == our_events[0]['time']
    # the store moved: the test compares a motion, not a body at rest
    pose = [m for (topic, t), m in ours.items() if topic.endswith('store/pose') and t == last]
    assert abs(pose[0].pose.position.z + 0.5) > 0.05
    assert stamp_ns(pose[0].header) == start_ns + last


def _odometry(t_ns, position, quat, velocity, rates):
    return {'header': {'stamp': {'sec': t_ns // 10 ** 9, 'nanosec': t_ns % 10 ** 9},
                       'frame_id': 'world'},
            'child_frame_id': 'aircraft',
            'pose': {'pose': {'position': dict(zip('xyz', map(float, position))),
                              'orientation': dict(zip('xyzw', map(float, quat)))},
                     'covariance': [0.0] * 36},
            'twist': {'twist': {'linear': dict(zip('xyz', map(float, velocity))),
                                'angular': dict(zip('xyz', map(float, rates)))},
                      'covariance': [0.0] * 36}}


SPEED, PITCH_RATE = 250.0, -9.80665 / 250.0   # a 2 g pull-up
#: The flight log's end and the node's duration, s.
FLIGHT_END = 0.6


def _flight(directory):
    """
    Write a 0.6 s flight log and its carrier scenario; return their paths.

    A 2 g pull-up's odometry at 100 Hz, a wrench on the store at 103 ms and
    its end at 203 ms (between odometry messages), a release command at 305 ms.
    """
    from cfem_ros.recording.schema import ODOMETRY_TYPE
    from scipy.spatial.transform import Rotation
    scenario = directory / 'carrier.yaml'
    doc = {'name': 'carrier', 'duration': 100.0, 'dt': 0.001,
           'bodies': {'aircraft': {'motion': {'velocity': [SPEED, 0, 0],
                                              'angular_velocity': [0, PITCH_RATE, 0]}},
                      'store': {'mass': 200.0, 'inertia': [5.0, 60.0, 60.0],
                                'position': [0.0, 0, -1.0]}},
           'joints': {'hook': {'type': 'hinge', 'parent': 'aircraft', 'child': 'store',
                               'anchor': [0.5, 0, -0.6], 'axis': [0, 1, 0]}}}
    scenario.write_text(yaml.safe_dump(doc))
    log = directory / 'flight.mcap'
    with Recorder(str(log)) as rec:
        for k in range(61):
            t, t_ns = 0.01 * k, T0 + 10 * k * MS
            phi = PITCH_RATE * t
            position = [SPEED / PITCH_RATE * np.sin(phi), 0,
                        SPEED / PITCH_RATE * (np.cos(phi) - 1)]
            quat = Rotation.from_rotvec([0, phi, 0]).as_quat()
            rec.write('/cfem/bodies/aircraft/odom', ODOMETRY_TYPE,
                      _odometry(t_ns, position, quat, [SPEED, 0, 0], [0, PITCH_RATE, 0]), t_ns)
            if k in (10, 20):   # a wrench on the store between two odometry messages
                force = [0, 0, 800.0] if k == 10 else [0, 0, 0]
                rec.write('/cfem/bodies/store/wrench', WRENCH_TYPE, _wrench(t_ns + 3 * MS, force),
                          t_ns + 3 * MS)
            if k == 30:
                rec.write('/cfem/release', STRING_TYPE, {'data': 'hook'}, t_ns + 5 * MS)
    return scenario, log


def _replay(directory, scenario, log, watch=False, hogs=0):
    """
    Play log with --clock into a use_sim_time node recording to directory/node.mcap.

    The node runs to FLIGHT_END and ends by itself. With hogs, that many
    processes that never sleep run from the node's start to its end. Return
    the recording and, with watch, the store's relative poses it published.
    """
    directory.mkdir(exist_ok=True)
    recording = directory / 'node.mcap'
    node = NodeProcess(directory, scenario, use_sim_time=True, record=recording,
                       duration=FLIGHT_END)
    peer, busy = None, []
    if watch:
        peer = Peer(['aircraft', 'store'], ['hook'])
        peer._collect(PoseStamped, 'bodies/store/relative_pose')
    try:
        wait_for_clock_subscription(node)
        busy += [subprocess.Popen([sys.executable, '-c', 'while True: pass'])
                 for _ in range(hogs)]
        if peer is not None:
            peer.connected(60.0)
        done = subprocess.run([str(BIN / 'cfem-sim'), 'play', str(log), '--clock', '--wait',
                               '60'], capture_output=True, text=True, timeout=180)
        assert done.returncode == 0, done.stderr
        assert '64 messages played' in done.stdout
        if peer is not None:
            peer.spin_for(1.0)
        status = node.wait(120.0)
    finally:
        for hog in busy:
            hog.kill()
            hog.wait()
        node.stop(signal.SIGINT)
        published = {} if peer is None else {
            f'/cfem/{topic}': list(messages) for topic, messages in peer.received.items()
            if topic.startswith(('bodies/', 'joints/'))}
        if peer is not None:
            peer.close()
    assert status == 0, node.output
    assert 'diagnostics: late_inputs 0, dropped_inputs 0' in node.output, node.output
    return recording, published


@pytest.fixture(scope='module')
def flight(tmp_path_factory):
    """Return the flight log, its scenario and the recording of its replay (machine as it is)."""
    directory = tmp_path_factory.mktemp('flight')
    scenario, log = _flight(directory)
    recording, published = _replay(directory / 'idle', scenario, log, watch=True)
    return types.SimpleNamespace(directory=directory, scenario=scenario, log=log,
                                 recording=recording, published=published)


def test_odometry_log_drives_a_carrier_in_the_node_as_offline(flight):
    from cfem_ros.recording.analysis import open_run
    recording = flight.recording
    start_ns = T0
    ours, our_events, messages = _samples(recording, start_ns)
    odometry = [log - start_ns for topic, log, _, _ in messages
                if topic == '/cfem/bodies/aircraft/odom']
    assert odometry == [10 * k * MS for k in range(61)]   # each at its own time
    assert [log - start_ns for topic, log, _, _ in messages
            if topic in ('/cfem/bodies/store/wrench', '/cfem/release')] == [
                103 * MS, 203 * MS, 305 * MS]
    assert max(t for _, t in ours) == FLIGHT_END * 1e9
    out = flight.directory / 'offline.mcap'
    assert cli.main(['run', str(flight.scenario), '-o', str(out), '--inputs', str(flight.log),
                     '--duration', repr(FLIGHT_END)]) == 0
    theirs, their_events, _ = _samples(out, 0)
    assert set(ours) == set(theirs)   # every sample, as offline
    bad = sorted((key[1], key[0]) for key, m in ours.items()
                 if not np.array_equal(_numbers(m), _numbers(theirs[key])))
    assert bad == []   # sample by sample, to the bit
    assert [e['joint'] for e in our_events] == [e['joint'] for e in their_events] == ['hook']
    assert our_events[0]['time'] == their_events[0]['time']
    # the carrier followed the log: at 0.6 s, on the circle
    phi = PITCH_RATE * 0.6
    carrier = open_run(str(recording)).bodies['aircraft']
    k = int(np.argmin(np.abs(carrier.time - 0.6)))
    assert np.allclose(carrier.position[k], [SPEED / PITCH_RATE * np.sin(phi), 0,
                                             SPEED / PITCH_RATE * (np.cos(phi) - 1)], atol=1e-6)
    # and the store's pose in the carrier's frame was recorded
    assert open_run(str(recording)).relative['store'].reference == 'aircraft'


def test_the_node_publishes_what_it_records(flight):
    """Poses, twists, relative poses and joint loads: the same numbers, to the bit (47.3)."""
    recorded = {(topic, stamp_ns(m.header)): m for topic, _, _, m in
                read_checked(flight.recording)[2] if topic in flight.published}
    assert set(flight.published) == {
        f'/cfem/bodies/{body}/{kind}' for body in ('aircraft', 'store') for kind in (
            'pose', 'twist')} | {'/cfem/bodies/store/relative_pose', '/cfem/joints/hook/wrench',
                                 '/cfem/joints/hook/wrench_world'}
    for topic, messages in flight.published.items():
        assert len(messages) >= 30, topic   # the hook's loads until its release at 0.305 s
        for msg in messages:
            mine = recorded[(topic, stamp_ns(msg.header))]
            assert msg.header.frame_id == mine.header.frame_id
            assert np.array_equal(_numbers(msg), _numbers(mine)), (topic, msg, mine)
    assert len(flight.published['/cfem/bodies/store/pose']) == 61   # every sample


def _contents(path):
    """Return every message of a recording: (topic, log time, CDR bytes)."""
    from mcap.reader import make_reader
    with open(path, 'rb') as stream:
        return [(channel.topic, message.log_time, message.data)
                for _, channel, message in make_reader(stream).iter_messages()]


def test_a_replay_beside_four_busy_processes_records_what_the_idle_replay_did(flight):
    # four processes that never sleep, on a machine of 2 cores, for the replay's duration
    recording, _ = _replay(flight.directory / 'loaded', flight.scenario, flight.log, hogs=4)
    loaded, idle = _contents(recording), _contents(flight.recording)
    assert len(loaded) == len(idle) > 400
    differ = [(a[0], a[1] - T0) for a, b in zip(loaded, idle) if a != b]
    assert differ == []   # every message, to the byte, at the same time
