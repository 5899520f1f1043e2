# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
cfem-sim run and its recordings (SPEC sections 2 and 4).

Every recording is read back twice, with the mcap reader (and mcap_ros2's
decoder) and with rosbags' own MCAP reader and CDR deserializer, and the two
must agree message by message.
"""

import json
import pathlib
import subprocess
import sys

from cfem_ros import cli, load_scenario, Simulator
from cfem_ros.core.run.inputs import release_input, wrench_input
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.recorder import StateRecorder
from doctor import diagnose
import numpy as np
import pytest
from recordings import fields, read_checked, read_mcap, read_rosbags
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'


@pytest.fixture(scope='module')
def store_run(tmp_path_factory):
    out = tmp_path_factory.mktemp('run') / 'store.mcap'
    assert cli.main(['run', str(CONFIG / 'store_separation.yaml'), '-o', str(out),
                     '--rate', '30']) == 0
    return out


def test_recording_follows_the_ros2_profile(store_run):
    header, summary, messages = read_mcap(store_run)
    assert header.profile == 'ros2'
    assert summary.statistics.message_count == len(messages) > 0
    assert summary.chunk_indexes, 'indexed'
    for schema in summary.schemas.values():
        assert schema.encoding == 'ros2msg'
    for channel in summary.channels.values():
        assert channel.message_encoding == 'cdr'
        # the integer form rosbag2 writes, which every distro's ros2 bag play reads
        qos = yaml.safe_load(channel.metadata['offered_qos_profiles'])
        depth, durability = {'/cfem/events': (100, 1), '/tf_static': (1, 1),
                             '/cfem/markers': (1, 1)}.get(channel.topic, (10, 2))
        assert qos == [{'history': 1, 'depth': depth, 'reliability': 1,
                        'durability': durability,
                        'deadline': {'sec': 0, 'nsec': 0}, 'lifespan': {'sec': 0, 'nsec': 0},
                        'liveliness': 1,
                        'liveliness_lease_duration': {'sec': 0, 'nsec': 0},
                        'avoid_ros_namespace_conventions': False}]
    topics = {c.topic for c in summary.channels.values()}
    assert topics == {'/cfem/bodies/pylon/pose', '/cfem/bodies/pylon/twist',
                      '/cfem/bodies/store/pose', '/cfem/bodies/store/twist',
                      '/cfem/joints/pivot/wrench', '/cfem/joints/pivot/wrench_world',
                      '/cfem/events', '/cfem/markers', '/cfem/load_markers', '/tf',
                      '/tf_static'}


def test_both_readers_agree_message_by_message(store_run):
    _, _, ours = read_mcap(store_run)
    theirs, msgtypes = read_rosbags(store_run)
    assert len(ours) == len(theirs)
    for (topic, log_time, publish_time, a), (topic_b, time_b, b) in zip(ours, theirs):
        assert topic == topic_b and log_time == time_b == publish_time
        assert list(map(repr, fields(a))) == list(map(repr, fields(b)))
        headers = [a.header] if hasattr(a, 'header') else [
            t.header for t in getattr(a, 'transforms', [])]
        for header in headers:
            assert header.stamp.sec * 10 ** 9 + header.stamp.nanosec == log_time
    assert msgtypes == {
        'geometry_msgs/msg/PoseStamped', 'geometry_msgs/msg/TwistStamped',
        'geometry_msgs/msg/WrenchStamped', 'std_msgs/msg/String', 'tf2_msgs/msg/TFMessage',
        'visualization_msgs/msg/MarkerArray'}


def test_samples_lie_on_exact_multiples_of_the_period(store_run):
    _, _, messages = read_mcap(store_run)
    stamps = [t for topic, t, _, _ in messages if topic == '/cfem/bodies/store/pose']
    expected = [round(k * 1e9 / 30) for k in range(int(1.5 * 30) + 1)]
    assert stamps == expected
    # and the state at each stamp is the state at that exact time
    sim = Simulator(load_scenario(str(CONFIG / 'store_separation.yaml')))
    poses = [m for topic, _, _, m in messages if topic == '/cfem/bodies/store/pose']
    for k in (7, 8, 44):
        assert sim.advance_to(k / 30)
        p = poses[k].pose.position
        assert np.allclose([p.x, p.y, p.z], sim.position[1], rtol=0, atol=1e-12)


def test_event_and_wrench_topics(store_run):
    _, _, messages = read_mcap(store_run)
    events = [(t, json.loads(m.data)) for topic, t, _, m in messages if topic == '/cfem/events']
    assert len(events) == 1
    stamp, event = events[0]
    assert event['joint'] == 'pivot' and event['cause'] == 'angle'
    assert stamp == round(event['time'] * 1e9)
    wrenches = [(t, m.wrench.force) for topic, t, _, m in messages
                if topic == '/cfem/joints/pivot/wrench']
    # published while active, then zero once at the release
    assert wrenches and max(t for t, _ in wrenches[:-1]) < stamp == wrenches[-1][0]
    assert (wrenches[-1][1].x, wrenches[-1][1].y, wrenches[-1][1].z) == (0, 0, 0)
    poses = [m for topic, _, _, m in messages if topic == '/cfem/bodies/store/pose']
    assert poses[0].header.frame_id == 'world'
    twists = [m for topic, _, _, m in messages if topic == '/cfem/bodies/store/twist']
    assert twists[0].header.frame_id == 'store'


def test_existing_output_is_not_overwritten(store_run, capsys):
    before = store_run.read_bytes()
    assert cli.main(['run', str(CONFIG / 'store_separation.yaml'), '-o', str(store_run)]) == 2
    assert 'already exists' in capsys.readouterr().err
    assert store_run.read_bytes() == before


def test_overwrite_replaces(tmp_path):
    out = tmp_path / 'x.mcap'
    out.write_bytes(b'old')
    assert cli.main(['run', str(CONFIG / 'joints' / 'fixed.yaml'), '-o', str(out),
                     '--duration', '0.1', '--overwrite']) == 0
    assert read_checked(out)[0].profile == 'ros2'


def test_failed_run_exits_1_and_keeps_a_complete_recording(tmp_path, capsys):
    doc = yaml.safe_load((CONFIG / 'joints' / 'hinge.yaml').read_text())
    # a hinge spun fast with a coarse step: its constraint drifts until the run stops, after
    # many good steps (a run failing within its first step is refused as bad input, exit 2)
    doc['bodies']['rod']['angular_velocity'] = [0, 40.0, 0]
    doc['bodies']['rod']['velocity'] = [0, 0, -20.0]
    doc['dt'] = 0.02
    doc['baumgarte'] = 1.0
    scenario = tmp_path / 'diverge.yaml'
    scenario.write_text(yaml.safe_dump(doc))
    out = tmp_path / 'diverge.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out)]) == 1
    err = capsys.readouterr().err
    assert 'run failed at t = ' in err and ('diverged' in err or 'singular' in err)
    _, summary, messages = read_checked(out)
    assert summary.statistics.message_count == len(messages) > 0
    failed_at = float(err.split('run failed at t = ')[1].split(' s')[0])
    poses = [m for topic, _, _, m in messages if topic == '/cfem/bodies/rod/pose']
    last = poses[-1].header.stamp.sec + poses[-1].header.stamp.nanosec * 1e-9
    assert failed_at > 10 * doc['dt'] and last >= failed_at - 0.01   # kept up to the failure


def test_inputs_replay_applies_wrenches_and_releases(tmp_path):
    # a recording with inputs: the spec's own topics, from a cfem-sim run
    from cfem_ros.recording.container import Recorder
    from cfem_ros.recording.recorder import StateRecorder
    model = load_scenario(str(CONFIG / 'store_separation.yaml'))
    log = tmp_path / 'inputs.mcap'
    with Recorder(str(log), metadata={'start_stamp_ns': 0}) as recorder:
        state = StateRecorder(recorder, Simulator(model))
        state.received(wrench_input('store', [0, 0, 5000.0], [0, 0, 0], 'world'), 0.05)
        state.received(release_input('pivot'), 0.1)
    read_checked(log)
    out = tmp_path / 'replay.mcap'
    assert cli.main(['run', str(CONFIG / 'store_separation.yaml'), '-o', str(out),
                     '--inputs', str(log), '--duration', '0.5']) == 0
    _, _, messages = read_checked(out)
    events = [json.loads(m.data) for topic, _, _, m in messages if topic == '/cfem/events']
    assert events == [{'event': 'release', 'joint': 'pivot', 'time': 0.1, 'cause': 'command'}]
    topics = {topic for topic, _, _, _ in messages}
    assert {'/cfem/bodies/store/wrench', '/cfem/release'} <= topics
    # the same inputs through the API give the same final state
    sim = Simulator(model)
    assert sim.advance_to(0.05)
    sim.set_wrench('store', [0, 0, 5000.0], [0, 0, 0])
    assert sim.advance_to(0.1)
    sim.release('pivot')
    assert sim.advance_to(0.5)
    last = [m for topic, _, _, m in messages if topic == '/cfem/bodies/store/pose'][-1]
    p = last.pose.position
    assert np.allclose([p.x, p.y, p.z], sim.position[1], rtol=0, atol=1e-12)


def test_console_script_and_help():
    exe = pathlib.Path(sys.executable).parent / 'cfem-sim'
    result = subprocess.run([str(exe), 'run', '--help'], capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 0 and '--overwrite' in result.stdout
    result = subprocess.run([str(exe), 'run'], capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and 'Traceback' not in result.stderr


def test_inputs_after_the_run_are_named_and_foreign_logs_refused_clearly(tmp_path, capsys):
    log = tmp_path / 'late.mcap'
    sim = Simulator(load_scenario(str(CONFIG / 'store_release_on_command.yaml')))
    with Recorder(str(log), metadata={'start_stamp_ns': 0}) as recorder:   # t = 0 at stamp 0
        StateRecorder(recorder, sim).received(release_input('pivot'), 5.0)
    out = tmp_path / 'short.mcap'
    assert cli.main(['run', str(CONFIG / 'store_release_on_command.yaml'), '-o', str(out),
                     '--inputs', str(log), '--duration', '1']) == 0
    captured = capsys.readouterr()
    assert '1 input(s)' in captured.err and 't = 5 s' in captured.err
    assert 'no joint released' in captured.out
    # a scenario given as the log, and a cut log: the words of info and plot
    for bad, words in ((CONFIG / 'store_separation.yaml', 'not an MCAP file'),):
        assert cli.main(['run', str(CONFIG / 'store_separation.yaml'), '-o',
                         str(tmp_path / 'x.mcap'), '--inputs', str(bad)]) == 2
        assert words in capsys.readouterr().err
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(log.read_bytes()[:len(log.read_bytes()) // 2])
    assert cli.main(['run', str(CONFIG / 'store_separation.yaml'), '-o',
                     str(tmp_path / 'y.mcap'), '--inputs', str(cut)]) == 2
    assert 'cfem-sim recover' in capsys.readouterr().err


def test_mcap_doctor_finds_nothing_in_a_run(store_run):
    assert diagnose(store_run) == []
