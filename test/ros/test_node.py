# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
cfem_node over real DDS (SPEC section 3), the node in its own process.

The test process is the other side: it publishes wrenches, release commands
and /clock, and subscribes to everything the node publishes. Physics is
checked against closed forms; a node's recording is replayed offline with
``cfem-sim run --inputs`` and must give the node's numbers.
"""

import io
import json
import math
import pathlib
import re
import signal
import subprocess
import sys
import time

from cfem_ros import cli
from cfem_ros.core import rotations
from cfem_ros.recording import analysis
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory
import numpy as np
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from recordings import read_checked, read_mcap
from rosharness import NodeProcess, Peer, stamp_ns
from visualization_msgs.msg import MarkerArray
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
T0 = 1_000_000_000_000  # /clock start in the sim-time test: 1000 s
MS = 1_000_000

FREE_BODIES = {
    'name': 'free_bodies',
    'gravity': [0, 0, 0],
    'duration': 100.0,
    'dt': 0.001,
    'bodies': {
        'ball': {'mass': 2.0, 'inertia': [0.1, 0.1, 0.1]},
        'spinner': {'mass': 3.0, 'inertia': [1.0, 1.0, 2.0],
                    'angular_velocity_deg': [0, 0, 90]},
    },
}


def write_scenario(directory, document, name='scenario.yaml'):
    """Write a scenario document; return its path."""
    path = pathlib.Path(directory) / name
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    return path


@pytest.fixture
def peer_factory():
    peers = []

    def make(*args, **kwargs):
        peers.append(Peer(*args, **kwargs))
        return peers[-1]
    yield make
    for peer in peers:
        peer.close()


def sampled_at(peer, body, stamp):
    """Tell whether the pose and twist of a body stamped exactly stamp (ns) arrived."""
    return all(any(stamp_ns(m.header) == stamp for m in peer.received[f'bodies/{body}/{kind}'])
               for kind in ('pose', 'twist'))


def latest_stamp(peer) -> int:
    """Largest stamp of anything the node published so far."""
    stamps = [stamp_ns(h) for topic, msgs in peer.received.items() if topic != 'events'
              for m in msgs for h in ([x.header for x in m.markers] if topic == 'markers'
                                      else [m.header])]
    return max(stamps, default=0)


def tick(peer, clock_ns, bodies, timeout=20.0):
    """Publish /clock (again, as it is best effort) until every body's sample at it arrives."""
    waited = 0.0
    while not all(sampled_at(peer, b, clock_ns) for b in bodies):
        assert waited < timeout, f'no sample at /clock {clock_ns} ns after {timeout:g} s'
        peer.clock(clock_ns)
        try:
            peer.spin_until(lambda: all(sampled_at(peer, b, clock_ns) for b in bodies), 0.5)
        except AssertionError:
            waited += 0.5


def offline_replay(tmp_path, scenario, recording):
    """Replay a node recording's inputs with cfem-sim run; return (node, offline) samples."""
    _, summary, node_messages = read_mcap(recording)
    start_ns = int(next(iter(
        m.metadata for m in _metadata(recording) if m.name == 'cfem_ros'))['start_stamp_ns'])
    samples = [(topic, log - start_ns, msg) for topic, log, _, msg in node_messages
               if topic.endswith(('/pose', '/twist')) or '/joints/' in topic]
    last = max(t for _, t, _ in samples)
    out = tmp_path / 'replay.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out), '--inputs', str(recording),
                     '--duration', repr(last / 1e9)]) == 0
    _, _, offline = read_checked(out)
    theirs = {(topic, log): msg for topic, log, _, msg in offline
              if topic.endswith(('/pose', '/twist')) or '/joints/' in topic}
    node_events = [json.loads(m.data) for topic, _, _, m in node_messages
                   if topic.endswith('/events')]
    offline_events = [json.loads(m.data) for topic, _, _, m in offline
                      if topic.endswith('/events')]
    return samples, theirs, node_events, offline_events


def _metadata(path):
    with open(path, 'rb') as stream:
        return list(make_reader(stream).iter_metadata())


def numbers(message):
    """Return the floating-point content of a pose, twist or wrench message."""
    if hasattr(message, 'pose'):
        p, q = message.pose.position, message.pose.orientation
        return np.array([p.x, p.y, p.z, q.x, q.y, q.z, q.w])
    if hasattr(message, 'twist'):
        a, b = message.twist.linear, message.twist.angular
    else:
        a, b = message.wrench.force, message.wrench.torque
    return np.array([a.x, a.y, a.z, b.x, b.y, b.z])


def assert_replay_matches(tmp_path, scenario, recording, tolerance=1e-9):
    """Offline replay of a node recording gives the node's samples and events."""
    samples, theirs, node_events, offline_events = offline_replay(
        tmp_path, scenario, recording)
    assert len(samples) == len(theirs)
    worst = 0.0
    for topic, t, msg in samples:
        worst = max(worst, np.abs(numbers(msg) - numbers(theirs[(topic, t)])).max())
    assert worst <= tolerance, f'offline replay differs from the node by {worst:.3g}'
    assert len(node_events) == len(offline_events)
    for a, b in zip(node_events, offline_events):
        assert (a['joint'], a['cause']) == (b['joint'], b['cause'])
        assert abs(a['time'] - b['time']) <= 1e-9
    return worst


def test_sim_time_lockstep_free_body_and_body_axes(tmp_path, peer_factory):
    scenario = write_scenario(tmp_path, FREE_BODIES)
    recording = tmp_path / 'sim.mcap'
    # input_window 0: in lockstep with /clock, each sample as soon as its /clock comes
    node = NodeProcess(tmp_path, scenario, use_sim_time=True, record=recording, duration=0.0,
                       input_window=0.0)
    try:
        peer = peer_factory(['ball', 'spinner'], [])
        peer.connected()
        tick(peer, T0, ['ball', 'spinner'])
        force, force_body = 4.0, 6.0
        t_on = 0.1
        peer.wrench('ball', [force, 0, 0], stamp=T0 + 100 * MS)
        peer.wrench('spinner', [force_body, 0, 0], frame_id='spinner', stamp=T0 + 100 * MS)
        for k in range(1, 41):
            clock = T0 + 10 * k * MS
            tick(peer, clock, ['ball', 'spinner'])
            # never ahead of /clock
            assert latest_stamp(peer) == clock
    finally:
        status = node.stop(signal.SIGINT)
    assert status == 0, node.output
    assert 'SIGINT received' in node.output

    # one pose per body per clock time, each exactly on a clock time
    ball = {stamp_ns(m.header): m for m in peer.received['bodies/ball/pose']}
    assert sorted(ball) == [T0 + 10 * k * MS for k in range(41)]
    # a constant world force on a free body: x = F (t - t_on)^2 / (2 m), exact under RK4
    for stamp, msg in ball.items():
        t = (stamp - T0) / 1e9
        expected = force * max(t - t_on, 0.0) ** 2 / (2 * 2.0)
        p = msg.pose.position
        assert abs(p.x - expected) <= 1e-12 and abs(p.y) <= 1e-15 and abs(p.z) <= 1e-15

    # a body-axes force on a body spinning at w about z turns with it
    w = math.radians(90.0)
    scale = force_body / (3.0 * w)
    twists = {stamp_ns(m.header): m for m in peer.received['bodies/spinner/twist']}
    for msg in peer.received['bodies/spinner/pose']:
        stamp = stamp_ns(msg.header)
        t = (stamp - T0) / 1e9
        s = max(t, t_on)
        x = scale * ((math.cos(w * t_on) - math.cos(w * s)) / w - math.sin(w * t_on) * (s - t_on))
        y = scale * (math.cos(w * t_on) * (s - t_on) - (math.sin(w * s) - math.sin(w * t_on)) / w)
        p, q = msg.pose.position, msg.pose.orientation
        assert np.allclose([p.x, p.y, p.z], [x, y, 0.0], rtol=0, atol=1e-10)
        half = w * t / 2
        assert np.allclose([q.x, q.y, q.z, q.w], [0, 0, math.sin(half), math.cos(half)],
                           rtol=0, atol=1e-10)
        vx, vy = scale * (math.sin(w * s) - math.sin(w * t_on)), scale * (
            math.cos(w * t_on) - math.cos(w * s))
        c, si = math.cos(w * t), math.sin(w * t)
        twist = twists[stamp].twist
        # twist: body axes
        assert np.allclose([twist.linear.x, twist.linear.y, twist.linear.z],
                           [c * vx + si * vy, -si * vx + c * vy, 0.0], rtol=0, atol=1e-10)
        assert np.allclose([twist.angular.x, twist.angular.y, twist.angular.z], [0, 0, w],
                           rtol=0, atol=1e-12)

    # the recording: both readers, inputs logged when they took effect, header as received
    _, summary, messages = read_checked(recording)
    inputs = [(log, m) for topic, log, _, m in messages if topic == '/cfem/bodies/ball/wrench']
    assert [(log, stamp_ns(m.header), m.header.frame_id) for log, m in inputs] == [
        (T0 + 100 * MS, T0 + 100 * MS, 'world')]
    assert_replay_matches(tmp_path, scenario, recording)


def test_real_time_release_bad_messages_recording_and_replay(tmp_path, peer_factory):
    scenario = CONFIG / 'store_release_on_command.yaml'
    recording = tmp_path / 'node.mcap'
    node = NodeProcess(tmp_path, scenario, record=recording, rate_hz=100.0)
    try:
        peer = peer_factory(['pylon', 'store'], ['pivot'])
        peer.connected()
        poses = peer.received['bodies/store/pose']
        peer.spin_until(lambda: len(poses) >= 10, what='the node publishing')
        peer.wrench('store', [0, 0, -2000.0])
        peer.wrench('store', [0, 0, 0], [0, 300.0, 0], frame_id='store')
        peer.spin_for(0.2)
        peer.release('pivot')
        peer.spin_until(lambda: peer.events(), what='the release event')
        event = peer.events()[0]
        assert event['event'] == 'release' and event['joint'] == 'pivot'
        assert event['cause'] == 'command' and event['time'] > 0.1

        # bad messages: refused, named, and the node lives on
        peer.wrench('store', [math.nan, 0, 0])
        peer.wrench('store', [1.0, 0, 0], frame_id='nowhere')
        peer.release('nope')
        peer.release('pivot')
        reasons = ['/cfem/bodies/store/wrench: message not applied: force and torque must be '
                   'finite', "/cfem/bodies/store/wrench: message not applied: frame_id 'nowhere'",
                   "/cfem/release: message not applied: unknown joint 'nope'",
                   "/cfem/release: message not applied: joint 'pivot' is already released"]
        peer.spin_until(lambda: all(r in node.output for r in reasons), what='the warnings')
        count = len(poses)
        peer.spin_until(lambda: len(poses) > count + 10, what='poses after the bad messages')
        assert node.alive()
        # the released joint's wrench topics are gone
        peer.spin_until(lambda: peer.node.count_publishers('/cfem/joints/pivot/wrench')
                        + peer.node.count_publishers('/cfem/joints/pivot/wrench_world') == 0,
                        what='the pivot wrench topics to go')
        # markers: each body's shape on its frame, the joint green, then red once released
        markers = peer.received['markers']
        peer.spin_until(lambda: len(markers) >= 2, what='the markers after the release')
        # a viewer that subscribes late and volatile (RViz's default) still gets them
        late = []
        peer.node.create_subscription(MarkerArray, '/cfem/markers', late.append, QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.VOLATILE))
        peer.spin_until(lambda: late, timeout=5.0, what='markers for a late volatile viewer')
        assert len(late[0].markers) == 3
        # the joint-load arrows: at the pivot while it held, then cleared
        arrows = []
        peer.node.create_subscription(MarkerArray, '/cfem/load_markers', arrows.append, 10)
        peer.spin_until(lambda: arrows, timeout=5.0, what='the joint-load arrows')
        assert [m.action for m in arrows[-1].markers] == [3]   # DELETEALL: pivot released
        held = [m for a in peer.received['load_markers'] for m in a.markers if m.action == 0]
        joints = {m.header.frame_id for m in held if m.ns == '/cfem/joint_loads'}
        inputs = {m.header.frame_id for m in held if m.ns == '/cfem/held_loads'}
        assert joints == {'pivot'} and inputs <= {'store'}   # the -2000 N, if it was drawn
    finally:
        status = node.stop(signal.SIGTERM)
    assert status == 0, node.output
    assert 'SIGTERM received' in node.output
    assert len(peer.events()) == 1
    start_ns = min(stamp_ns(m.header) for m in peer.received['bodies/store/pose'])
    release_ns = start_ns + round(event['time'] * 1e9)
    wrenches = [stamp_ns(m.header) for m in peer.received['joints/pivot/wrench']]
    assert wrenches and max(wrenches) <= release_ns  # a sample at t comes before inputs at t
    # the wrench in the joint's frame (the store's axes) is the world one turned
    store = {stamp_ns(m.header): m.pose.orientation for m in peer.received['bodies/store/pose']}
    in_world = {stamp_ns(m.header): m for m in peer.received['joints/pivot/wrench_world']}
    # (a subscriber under load may miss a message of one topic: the samples seen on all three)
    both = [m for m in peer.received['joints/pivot/wrench']
            if stamp_ns(m.header) in in_world and stamp_ns(m.header) in store]
    assert len(both) >= len(peer.received['joints/pivot/wrench']) // 2 > 0
    for message in both:
        stamp = stamp_ns(message.header)
        world, q = in_world[stamp], store[stamp]
        assert (message.header.frame_id, world.header.frame_id) == ('pivot', 'world')
        for kind in ('force', 'torque'):
            v, w = getattr(message.wrench, kind), getattr(world.wrench, kind)
            turned = rotations.to_body(np.array([[q.x, q.y, q.z, q.w]]), np.array([[w.x, w.y,
                                                                                   w.z]]))[0]
            np.testing.assert_allclose([v.x, v.y, v.z], turned, rtol=0, atol=1e-9 * max(
                1.0, abs(w.x), abs(w.y), abs(w.z)))

    first, last = markers[0].markers, markers[-1].markers
    assert [(m.ns, m.header.frame_id, m.frame_locked) for m in first] == [
        ('/cfem/bodies', 'pylon', True), ('/cfem/bodies', 'store', True),
        ('/cfem/joints', 'pylon', True)]
    assert last[2].color.a < first[2].color.a and last[2].color.r > last[2].color.g
    _, summary, messages = read_checked(recording)
    topics = {topic for topic, _, _, _ in messages}
    assert {'/cfem/bodies/store/wrench', '/cfem/release', '/cfem/events', '/tf', '/tf_static',
            '/cfem/markers'} <= topics
    releases = [m.data for topic, _, _, m in messages if topic == '/cfem/release']
    assert releases == ['pivot', 'nope', 'pivot']
    assert assert_replay_matches(tmp_path, scenario, recording) <= 1e-9


def test_hard_kill_leaves_a_readable_recording(tmp_path):
    recording = tmp_path / 'killed.mcap'
    node = NodeProcess(tmp_path, CONFIG / 'double_pendulum.yaml', record=recording,
                       real_time_factor=0.0, duration=0.0)
    try:
        deadline = 60.0
        start = time.monotonic()
        while not (recording.exists() and recording.stat().st_size > 400_000):
            assert time.monotonic() - start < deadline and node.alive(), node.output
            time.sleep(0.1)
    finally:
        status = node.stop(signal.SIGKILL)
    assert status == -signal.SIGKILL
    data = recording.read_bytes()
    decoders, schemas, channels = DecoderFactory(), {}, {}
    stamps, count = {}, 0
    try:
        for record in StreamReader(io.BytesIO(data), emit_chunks=False).records:
            kind = type(record).__name__
            if kind == 'Schema':
                schemas[record.id] = record
            elif kind == 'Channel':
                channels[record.id] = (record.topic,
                                       decoders.decoder_for('cdr', schemas[record.schema_id]))
            elif kind == 'Message':
                topic, decode = channels[record.channel_id]
                msg = decode(record.data)
                if hasattr(msg, 'header'):
                    assert stamp_ns(msg.header) == record.log_time
                    assert record.log_time >= stamps.get(topic, 0)
                    stamps[topic] = record.log_time
                count += 1
    except Exception:  # noqa: B902 - the cut-off tail; what precedes it was read
        pass
    assert count > 1000
    assert '/cfem/bodies/B/pose' in stamps


def _node_error(tmp_path, *args, **parameters):
    node = NodeProcess(tmp_path, *args, **parameters)
    status = node.wait(timeout=60)
    return status, node.output


def test_bad_scenario_or_parameter_exits_2_with_the_cli_message(tmp_path):
    doc = yaml.safe_load((CONFIG / 'store_separation.yaml').read_text())
    doc['joints']['pivot']['axis'] = [0, 0, 0]
    bad = write_scenario(tmp_path, doc, 'bad.yaml')
    status, output = _node_error(tmp_path, bad)
    check = subprocess.run([str(pathlib.Path(sys.executable).parent / 'cfem-sim'), 'check',
                            str(bad)], capture_output=True, text=True, timeout=60)
    assert status == 2 == check.returncode
    message = check.stderr.strip()
    assert message.startswith('ERROR: ') and 'joints.pivot.axis' in message
    assert message in output and 'Traceback' not in output

    status, output = _node_error(tmp_path, None)
    assert status == 2 and 'ERROR: parameter scenario: not set' in output

    status, output = _node_error(tmp_path, CONFIG / 'store_separation.yaml', rate_hz=-5.0)
    assert status == 2 and 'ERROR: parameter rate_hz:' in output and 'expected' in output

    existing = tmp_path / 'exists.mcap'
    existing.write_bytes(b'keep me')
    status, output = _node_error(tmp_path, CONFIG / 'store_separation.yaml', record=existing)
    assert status == 2 and 'already exists' in output
    assert existing.read_bytes() == b'keep me'


def test_node_runs_the_scenario_to_its_end_and_exits_0(tmp_path):
    recording = tmp_path / 'full.mcap'
    node = NodeProcess(tmp_path, CONFIG / 'store_separation.yaml', record=recording,
                       real_time_factor=0.0)
    assert node.wait(timeout=120) == 0, node.output
    assert 'run complete at t = 1.5 s' in node.output
    _, summary, messages = read_checked(recording)
    events = [json.loads(m.data) for topic, _, _, m in messages if topic == '/cfem/events']
    assert [e['cause'] for e in events] == ['angle']
    # the same run offline: the same release time (stepping is the same code)
    out = tmp_path / 'offline.mcap'
    assert cli.main(['run', str(CONFIG / 'store_separation.yaml'), '-o', str(out)]) == 0
    _, _, offline = read_checked(out)
    assert [json.loads(m.data) for topic, _, _, m in offline if topic == '/cfem/events'] == events
    # and the reading API gives the same arrays for both, times from each run's start
    node_run, offline_run = analysis.open_run(str(recording)), analysis.open_run(str(out))
    assert node_run.start_ns > 0 and offline_run.start_ns == 0
    for name, track in offline_run.bodies.items():
        other = node_run.bodies[name]
        assert np.array_equal(track.time, other.time)
        assert np.array_equal(track.position, other.position)
        assert np.array_equal(track.rates, other.rates)
    assert node_run.releases() == offline_run.releases()


def test_node_says_when_it_falls_behind_real_time(tmp_path):
    # 10^4 x real time is beyond any machine for a 1 ms step: the lag must be reported
    node = NodeProcess(tmp_path, CONFIG / 'double_pendulum.yaml', real_time_factor=1e4,
                       duration=0.0)
    try:
        start = time.monotonic()
        while 'falling behind real time' not in node.output:
            assert time.monotonic() - start < 60 and node.alive(), node.output
            time.sleep(0.1)
        assert 'lags the clock by' in node.output
    finally:
        assert node.stop(signal.SIGINT) == 0, node.output


def test_cfem_pub_releases_the_pivot_as_the_readme_says(tmp_path):
    node = NodeProcess(tmp_path, CONFIG / 'store_release_on_command.yaml')
    pub = str(pathlib.Path(sys.executable).parent / 'cfem_pub')
    try:
        result = subprocess.run([pub, 'wrench', 'store', '--force', '0', '0', '-100'],
                                capture_output=True, text=True, timeout=60)
        assert result.returncode == 0, result.stderr
        # what the node would refuse is not published
        for bad in (['--force', 'nan', '0', '0'], ['--torque', '0', 'inf', '0'],
                    ['--frame', 'nowhere']):
            result = subprocess.run([pub, 'wrench', 'store'] + bad, capture_output=True,
                                    text=True, timeout=60)
            assert result.returncode == 2 and 'nothing published' in result.stderr, bad
            assert 'published on' not in result.stdout
        result = subprocess.run([pub, 'release', 'pivot'], capture_output=True, text=True,
                                timeout=60)
        assert result.returncode == 0, result.stderr
        event = json.loads(result.stdout.splitlines()[-1].split(': ', 1)[1])
        assert (event['joint'], event['cause']) == ('pivot', 'command')
        # refused at once by the node: no event comes, --confirm 2 s is plenty to say so
        result = subprocess.run([pub, 'release', 'pivot', '--confirm', '2'], capture_output=True,
                                text=True, timeout=60)
        assert result.returncode == 1 and 'no release event' in result.stderr
        assert "joint 'pivot' is already released" in node.output
        assert 'nowhere' not in node.output and 'finite' not in node.output
    finally:
        assert node.stop(signal.SIGINT) == 0, node.output


def test_node_start_up_messages(tmp_path):
    # a name ROS 2 cannot make a topic of: one ERROR line, exit 2, no traceback, no file
    for name in ('store\n', 'b' * 300):
        doc = {'name': 'bad_name', 'duration': 1.0, 'dt': 0.001,
               'bodies': {name: {'mass': 1.0, 'inertia': [1, 1, 1]}}}
        bad = write_scenario(tmp_path, doc, 'bad_name.yaml')
        recording = tmp_path / 'never.mcap'
        status, output = _node_error(tmp_path, bad, record=recording)
        assert status == 2, output
        errors = [line for line in output.splitlines() if line.startswith('ERROR:')]
        # refused by the scenario loader (a name it cannot use), or else by the node's
        # own check of every topic it would make: one line either way, naming the file
        assert len(errors) == 1 and 'bad_name.yaml' in errors[0], output
        assert any(reason in errors[0] for reason in (
            'invalid ROS 2 topic', 'is not a usable name', 'at most 64 characters')), output
        assert 'Traceback' not in output and not recording.exists()

    # an existing record file: the node's own way to say overwrite
    existing = tmp_path / 'exists.mcap'
    existing.write_bytes(b'keep me')
    status, output = _node_error(tmp_path, CONFIG / 'store_separation.yaml', record=existing)
    assert status == 2 and '-p overwrite:=true' in output and '--overwrite' not in output

    # a mistyped parameter is named, with the ones that exist; the release is logged at INFO
    node = NodeProcess(tmp_path, CONFIG / 'store_separation.yaml', real_time_factor=0.0,
                       rate=50.0)
    assert node.wait(timeout=120) == 0, node.output
    assert "parameter 'rate' is not a parameter of cfem_node; ignored" in node.output
    assert 'rate_hz' in node.output.split("parameter 'rate'")[1].splitlines()[0]
    # the line cfem-sim run prints of the event (events.describe_event)
    assert re.search(r'\[INFO\].*release pivot at t = [\d.]+ s \(angle\)', node.output), \
        node.output
