# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Reading recordings as arrays, and cfem-sim info, plot and compare.

Known motions (a free body in uniform gravity with a constant spin) give
exact arrays to compare with; a third-party writer (rosbags) writes the same
topics to check the reader does not depend on how cfem_ros writes them.
"""

import math
import pathlib
import subprocess
import sys

from cfem_ros import cli, load_scenario, plots, Simulator
from cfem_ros.core.run.inputs import release_input
from cfem_ros.recording import analysis
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.errors import RecordingError
from cfem_ros.recording.recorder import StateRecorder
import matplotlib.image
import numpy as np
import pytest
from recordings import read_mcap
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import get_typestore, Stores
from scipy.spatial.transform import Rotation
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
G = 9.80665

TUMBLER = {
    'name': 'tumbler', 'gravity': [0, 0, -G], 'duration': 2.5, 'dt': 0.001,
    'bodies': {
        'ground': {'fixed': True},
        'store': {'mass': 10.0, 'inertia': [1.0, 2.0, 2.0], 'velocity': [3.0, 0.0, 4.0],
                  'angular_velocity_deg': [0, 60, 0]},
    },
}


def run_to(tmp_path, document, name, *extra):
    """Write a scenario, run cfem-sim on it, return the recording's path."""
    scenario = tmp_path / f'{name}.yaml'
    scenario.write_text(yaml.safe_dump(document, sort_keys=False))
    out = tmp_path / f'{name}.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out), *extra]) == 0
    return out


@pytest.fixture(scope='module')
def tumbler(tmp_path_factory):
    return run_to(tmp_path_factory.mktemp('tumbler'), TUMBLER, 'tumbler')


@pytest.fixture(scope='module')
def store(tmp_path_factory):
    out = tmp_path_factory.mktemp('store') / 'store.mcap'
    assert cli.main(['run', str(CONFIG / 'store_separation.yaml'), '-o', str(out)]) == 0
    return out


def test_arrays_of_a_known_motion(tumbler):
    run = analysis.open_run(str(tumbler))
    assert run.namespace == '/cfem' and run.start_ns == 0
    assert list(run.bodies) == ['ground', 'store'] and run.joints == {} and run.events == []
    assert [b.name for b in run.moving_bodies()] == ['store']
    track = run.bodies['store']
    n = 251
    assert track.time.shape == (n,) and track.position.shape == (n, 3)
    assert track.quaternion.shape == (n, 4) and track.euler_deg.shape == (n, 3)
    assert track.rates.shape == track.velocity.shape == track.velocity_world.shape == (n, 3)
    t = track.time
    assert np.array_equal(track.stamp_ns, np.arange(n) * 10_000_000)
    assert np.allclose(t, np.arange(n) / 100.0, rtol=0, atol=1e-15)
    # ballistic CG (RK4 is exact for a quadratic, up to rounding: 2500 steps of a few
    # ulps of 20 m is ~1e-11 m) and a constant spin about y
    expected = np.column_stack([3.0 * t, 0 * t, 4.0 * t - G * t ** 2 / 2])
    assert np.allclose(track.position, expected, rtol=0, atol=1e-10)
    assert np.allclose(track.velocity_world, np.column_stack([3.0 + 0 * t, 0 * t, 4.0 - G * t]),
                       rtol=0, atol=1e-10)
    assert np.allclose(track.rates, [0, math.radians(60), 0], rtol=0, atol=1e-12)
    # pitch through 90 deg and on to 150 deg: continuous angles are exactly 60 t
    continuous = track.euler_continuous_deg
    assert np.allclose(continuous[:, 1], 60.0 * t, rtol=0, atol=1e-8)
    assert np.allclose(continuous[:, [0, 2]], 0.0, rtol=0, atol=1e-8)
    # the principal angles hold pitch within +-90 deg, roll and yaw flip to 180 deg
    principal = track.euler_deg
    beyond = 60.0 * t > 90.0 + 1e-6
    assert np.allclose(principal[beyond, 1], 180.0 - 60.0 * t[beyond], rtol=0, atol=1e-8)
    assert np.allclose(np.abs(principal[beyond][:, [0, 2]]), 180.0, rtol=0, atol=1e-8)
    # both are the recorded attitude
    for angles in (principal, continuous):
        rebuilt = Rotation.from_euler('ZYX', angles[:, ::-1], degrees=True).as_quat()
        assert np.allclose(np.abs(np.sum(rebuilt * track.quaternion, axis=1)), 1.0,
                           rtol=0, atol=1e-12)
    # body-axes velocity is the world velocity turned into the body
    body = Rotation.from_quat(track.quaternion).inv().apply(track.velocity_world)
    assert np.allclose(track.velocity, body, rtol=0, atol=1e-12)


def test_euler_continuous_unwraps_yaw_and_pitch():
    yaw = np.linspace(0, 400, 81)
    pitch = np.concatenate([np.linspace(0, 89, 40), np.linspace(89, 0, 41)])
    principal = Rotation.from_euler('ZYX', np.column_stack(
        [yaw, pitch, 0 * yaw]), degrees=True).as_euler('ZYX', degrees=True)[:, ::-1]
    continuous = analysis.euler_continuous(principal)
    assert np.allclose(continuous[:, 2], yaw, atol=1e-9)
    assert np.allclose(continuous[:, 1], pitch, atol=1e-9)


def test_joints_and_events_of_the_store(store):
    run = analysis.open_run(str(store))
    (t_release, joint, cause), = run.releases()
    assert (joint, cause) == ('pivot', 'angle') and 0.27 < t_release < 0.29
    pivot = run.joints['pivot']
    assert pivot.force.shape == pivot.moment.shape == (len(pivot.time), 3)
    assert pivot.time[-1] <= t_release < pivot.time[-1] + 0.01
    # before the release the pivot carries the weight's share: |F| near m g at t = 0
    assert abs(np.linalg.norm(pivot.force[0]) - 907.1848 * G) < 0.25 * 907.1848 * G
    assert run.duration == 1.5
    assert not run.bodies['pylon'].moves


def _rosbags_copy(source, directory, plant=None):
    """Write the messages of a recording with rosbags' MCAP writer (a third party)."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    types = store.types
    Time, Header = types['builtin_interfaces/msg/Time'], types['std_msgs/msg/Header']
    Vector3 = types['geometry_msgs/msg/Vector3']

    def convert(msgtype, m):
        if msgtype == 'std_msgs/msg/String':
            return types[msgtype](data=m.data)
        header = Header(stamp=Time(sec=m.header.stamp.sec, nanosec=m.header.stamp.nanosec),
                        frame_id=m.header.frame_id)
        if msgtype.endswith('PoseStamped'):
            p, q = m.pose.position, m.pose.orientation
            pose = types['geometry_msgs/msg/Pose'](
                position=types['geometry_msgs/msg/Point'](x=p.x, y=p.y, z=p.z),
                orientation=types['geometry_msgs/msg/Quaternion'](x=q.x, y=q.y, z=q.z, w=q.w))
            return types[msgtype](header=header, pose=pose)
        if msgtype.endswith('TwistStamped'):
            a, b = m.twist.linear, m.twist.angular
            return types[msgtype](header=header, twist=types['geometry_msgs/msg/Twist'](
                linear=Vector3(x=a.x, y=a.y, z=a.z), angular=Vector3(x=b.x, y=b.y, z=b.z)))
        a, b = m.wrench.force, m.wrench.torque
        return types[msgtype](header=header, wrench=types['geometry_msgs/msg/Wrench'](
            force=Vector3(x=a.x, y=a.y, z=a.z), torque=Vector3(x=b.x, y=b.y, z=b.z)))

    _, summary, messages = read_mcap(source)
    kinds = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()
             if not c.topic.startswith('/tf') and not c.topic.endswith('markers')}
    bag = pathlib.Path(directory) / 'bag'
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {topic: writer.add_connection(topic, kind, typestore=store)
                       for topic, kind in sorted(kinds.items())}
        for topic, log_time, _, m in messages:
            if topic not in kinds:
                continue   # what the analysis does not read (tf, markers)
            msg = convert(kinds[topic], m)
            if plant is not None:
                msg = plant(topic, log_time, msg)
            writer.write(connections[topic], log_time,
                         store.serialize_cdr(msg, kinds[topic]))
    return next(bag.glob('*.mcap'))


def test_a_third_party_recording_reads_the_same(store, tmp_path):
    ours = analysis.open_run(str(store))
    theirs = analysis.open_run(str(_rosbags_copy(store, tmp_path)))
    assert list(theirs.bodies) == sorted(ours.bodies)
    assert theirs.metadata == {} and theirs.start_ns == ours.start_ns == 0
    for name, track in ours.bodies.items():
        other = theirs.bodies[name]
        for attribute in ('time', 'position', 'quaternion', 'euler_continuous_deg', 'rates',
                          'velocity'):
            assert np.array_equal(getattr(track, attribute), getattr(other, attribute))
    assert np.array_equal(ours.joints['pivot'].force, theirs.joints['pivot'].force)
    assert ours.events == theirs.events


def test_reading_needs_no_rclpy(store, tmp_path):
    code = (
        "import sys; sys.modules['rclpy'] = None\n"
        'from cfem_ros import cli\n'
        'from cfem_ros.recording import analysis\n'
        f'run = analysis.open_run({str(store)!r})\n'
        "assert run.releases()[0][1] == 'pivot'\n"
        f"assert cli.main(['plot', {str(store)!r}, '-o', {str(tmp_path / 'plots')!r}]) == 0\n"
        "assert not [m for m in sys.modules if m.startswith('rcl') and sys.modules[m]]\n"
    )
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / 'plots' / 'body_store.png').is_file()


def test_plot_writes_every_figure_with_labelled_axes(store, tmp_path, capsys):
    out = tmp_path / 'figures'
    assert cli.main(['plot', str(store), '-o', str(out)]) == 0
    names = sorted(p.name for p in out.iterdir())
    assert names == ['body_store.png', 'joint_pivot.png', 'trajectories_3d.png']
    for path in out.iterdir():
        image = matplotlib.image.imread(path)
        assert image.shape[0] > 400 and image.shape[1] > 400
        assert image[..., :3].std() > 0.05  # not blank
    run = analysis.open_run(str(store))
    release = run.releases()[0][0]
    fig = plots.body_figure(run, 'store')
    axes = fig.axes
    assert [ax.get_ylabel() for ax in axes] == ['position [m]', 'angle [deg]', 'rate [deg/s]']
    assert axes[-1].get_xlabel() == 'time [s]'
    for ax in axes:
        assert ax.get_title(loc='left') and ax.get_legend() is not None
        marks = [line for line in ax.get_lines() if line.get_linestyle() == '--']
        assert [line.get_xdata()[0] for line in marks] == [release]
    labels = [t.get_text() for t in axes[1].get_legend().get_texts()]
    assert labels == ['roll', 'pitch', 'yaw']
    fig = plots.joint_figure(run, 'pivot')
    assert [ax.get_ylabel() for ax in fig.axes] == ['force [N]', 'moment [N m]']
    fig = plots.trajectory_figure(run)
    ax = fig.axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()) == ('x [m]', 'y [m]', 'z [m]')
    assert ax.zaxis_inverted()  # gravity +z: z down
    assert any('pivot released' in t.get_text() for t in ax.get_legend().get_texts())


def test_figures_replace_same_named_files_only_with_overwrite(store, tmp_path, capsys):
    # issue 41: plot and compare -o DIR replaced figures there without being told
    out = tmp_path / 'figures'
    out.mkdir()
    (out / 'joint_pivot.png').write_bytes(b'mine')
    (out / 'notes.txt').write_text('kept')
    assert cli.main(['plot', str(store), '-o', str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f'ERROR: {out}: already holds joint_pivot.png; pass --overwrite')
    assert sorted(p.name for p in out.iterdir()) == ['joint_pivot.png', 'notes.txt']
    assert (out / 'joint_pivot.png').read_bytes() == b'mine'
    assert cli.main(['plot', str(store), '-o', str(out), '--overwrite']) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        'body_store.png', 'joint_pivot.png', 'notes.txt', 'trajectories_3d.png']
    assert (out / 'joint_pivot.png').read_bytes()[:4] == b'\x89PNG'
    assert cli.main(['compare', str(store), str(store), '-o', str(out)]) == 0
    assert cli.main(['compare', str(store), str(store), '-o', str(out)]) == 2
    assert 'already holds compare_body_store.png, compare_joint_pivot.png' in \
        capsys.readouterr().err
    assert cli.main(['compare', str(store), str(store), '-o', str(out), '--overwrite']) == 0


INTERRUPTED_DRAW = """
import os, signal, sys, time
from cfem_ros.cli.common import signals_to
from cfem_ros.cli.figures import write_figures
from cfem_ros.interrupts import exit_now, Interrupted


def draw(folder):
    open(os.path.join(folder, 'half.png'), 'wb').close()
    os.kill(os.getpid(), signal.SIGINT)   # Ctrl-C while a figure is drawn
    time.sleep(5.0)
    return []


with signals_to(exit_now):   # as cfem-sim's main: a stop elsewhere exits at once
    try:
        write_figures(sys.argv[1], False, draw)
    except Interrupted as stop:
        sys.exit(stop.exit_status)
"""


def test_an_interrupted_drawing_leaves_the_folder_as_it_was(tmp_path):
    out = tmp_path / 'figures'
    out.mkdir()
    (out / 'notes.txt').write_text('kept')
    done = subprocess.run([sys.executable, '-c', INTERRUPTED_DRAW, str(out)], timeout=60)
    assert done.returncode == 130
    assert [p.name for p in out.iterdir()] == ['notes.txt']   # no hidden staging folder


def test_info_lists_topics_counts_and_events(store, capsys):
    assert cli.main(['info', str(store)]) == 0
    out = capsys.readouterr().out
    assert '/cfem/bodies/store/pose' in out and '151' in out
    assert 'release pivot at t = 0.28' in out and '(angle)' in out and '1.5 s' in out


def test_compare_finds_a_planted_difference(store, tmp_path, capsys):
    assert cli.main(['compare', str(store), str(store)]) == 0
    same = capsys.readouterr().out
    rows = [line for line in same.splitlines() if line.startswith('store position')]
    assert rows and float(rows[0].split()[2]) == 0.0

    def plant(topic, log_time, msg):
        if topic == '/cfem/bodies/store/pose' and log_time == 500_000_000:
            msg.pose.position.x += 0.01
        return msg
    planted = _rosbags_copy(store, tmp_path, plant)
    assert cli.main(['compare', str(store), str(planted), '-o', str(tmp_path / 'cmp')]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith('store position'))
    fields = row.split()
    assert math.isclose(float(fields[2]), 0.01, rel_tol=1e-6) and fields[3] == 'm'
    assert float(fields[4]) == 0.5
    attitude = next(line for line in out.splitlines() if line.startswith('store attitude'))
    assert float(attitude.split()[4]) == 0.0
    assert (tmp_path / 'cmp' / 'compare_body_store.png').is_file()
    assert (tmp_path / 'cmp' / 'compare_joint_pivot.png').is_file()


def test_compare_resamples_other_sample_times(store, tmp_path, capsys):
    coarse = tmp_path / 'coarse.mcap'
    assert cli.main(['run', str(CONFIG / 'store_separation.yaml'), '-o', str(coarse),
                     '--rate', '30']) == 0
    capsys.readouterr()
    rows, only_a, only_b = analysis.compare_runs(analysis.open_run(str(store)),
                                                 analysis.open_run(str(coarse)))
    assert only_a == only_b == []
    position = next(r for r in rows if r.quantity == 'store position')
    # the same motion; linear interpolation of 30 Hz samples errs by ~ a dt^2 / 8
    assert 0 < position.max_abs < 12.5 * (1 / 30) ** 2 / 8 * 1.5
    release = next(r for r in rows if r.quantity == 'pivot release')
    # other sample times cut the steps elsewhere: the same release to rounding
    assert release.max_abs < 1e-9


@pytest.mark.parametrize('command', ['info', 'plot', 'compare'])
def test_bad_files_exit_2_with_a_clear_message(store, tmp_path, capsys, command):
    text = tmp_path / 'notes.mcap'
    text.write_text('not a recording\n')
    cut = tmp_path / 'cut.mcap'
    data = store.read_bytes()
    cut.write_bytes(data[:len(data) // 2])
    inputs_only = tmp_path / 'inputs.mcap'
    with Recorder(str(inputs_only)) as recorder:
        StateRecorder(recorder, Simulator(load_scenario(str(CONFIG / 'store_separation.yaml')))
                      ).received(release_input('pivot'), 0.1)
    cases = {text: 'not an MCAP file', cut: 'truncated', inputs_only: 'no <namespace>/bodies',
             tmp_path / 'missing.mcap': 'cannot read'}
    if command == 'info':   # info reads any finished MCAP file's summary
        del cases[inputs_only]
        assert cli.main(['info', str(inputs_only)]) == 0
        assert '/cfem/release         1  std_msgs/msg/String' in capsys.readouterr().out
    for path, reason in cases.items():
        args = {'info': ['info', str(path)], 'plot': ['plot', str(path), '-o', str(tmp_path)],
                'compare': ['compare', str(store), str(path)]}[command]
        assert cli.main(args) == 2
        err = capsys.readouterr().err
        assert err.startswith(f'ERROR: {path}: ') and reason in err, err
        if path == cut:
            assert f'cfem-sim recover {path} -o FIXED.mcap' in err, err
    with pytest.raises(RecordingError):
        analysis.open_run(str(cut))


def test_compare_of_runs_of_different_lengths_is_over_the_overlap_only(store, tmp_path, capsys):
    short = tmp_path / 'short.mcap'
    assert cli.main(['run', str(CONFIG / 'store_separation.yaml'), '-o', str(short),
                     '--duration', '1.0', '--rate', '30']) == 0
    a, b = analysis.open_run(str(store)), analysis.open_run(str(short))
    rows = {r.quantity: r for r in analysis.compare_runs(a, b)[0]}
    ta, tb = a.bodies['store'], b.bodies['store']
    assert ta.time[-1] == 1.5 and tb.time[-1] == 1.0
    inside = ta.time <= 1.0 + 1e-12
    assert inside.sum() == 101
    by_hand = {
        'store position': np.abs(ta.position[inside]).max(),
        'store velocity': np.abs(ta.velocity[inside]).max(),
        'store rates': np.abs(np.degrees(ta.rates[inside])).max(),
        # A's turn from its first attitude, from scipy (independent of rotations.py)
        'store attitude': np.degrees(
            (Rotation.from_quat(ta.quaternion[0]).inv()
             * Rotation.from_quat(ta.quaternion[inside])).magnitude()).max(),
    }
    for quantity, value in by_hand.items():
        assert rows[quantity].samples == 101, quantity
        assert math.isclose(rows[quantity].scale, value, rel_tol=1e-9), quantity
        assert rows[quantity].at_time <= 1.0, quantity
    # the store tumbles on after t = 1 s: the whole run's turn would be much larger
    whole = np.degrees((Rotation.from_quat(ta.quaternion[0]).inv()
                        * Rotation.from_quat(ta.quaternion)).magnitude()).max()
    assert whole > by_hand['store attitude'] + 20.0
    pivot_a, pivot_b = a.joints['pivot'], b.joints['pivot']
    joint_inside = (pivot_a.time >= pivot_b.time[0]) & (pivot_a.time <= pivot_b.time[-1])
    assert math.isclose(rows['pivot force'].scale,
                        np.abs(pivot_a.force[joint_inside]).max(), rel_tol=1e-12)
    capsys.readouterr()
    assert cli.main(['compare', str(store), str(short)]) == 0
    out = capsys.readouterr().out
    assert 'compared: t = 0 to 1 s' in out and 'velocity u, v, w: body axes' in out
    attitude = next(line for line in out.splitlines() if line.startswith('store attitude'))
    assert math.isclose(float(attitude.split()[5]), by_hand['store attitude'], rel_tol=1e-3)


def test_a_relative_pose_composed_with_its_carrier_is_the_kernels_relative_state_inverted():
    # _composed builds world poses of a body published relative to its carrier; the
    # kernel's relative state of those world poses in the carrier's must give the
    # relative poses back (the two directions of one formula), to rounding
    from cfem_ros.core.native import kernel
    rng = np.random.default_rng(46)
    stamps = np.arange(5) * 10_000_000
    quat = rng.normal(size=(5, 4))
    carrier_poses = np.hstack([rng.normal(scale=50.0, size=(5, 3)),
                               quat / np.linalg.norm(quat, axis=1)[:, None]])
    quat = rng.normal(size=(5, 4))
    relative = np.hstack([rng.normal(scale=3.0, size=(5, 3)),
                          quat / np.linalg.norm(quat, axis=1)[:, None]])
    composed = analysis._composed(
        [(int(t), tuple(r)) for t, r in zip(stamps, relative)],
        [(int(t), tuple(c)) for t, c in zip(stamps, carrier_poses)])
    world = np.array([pose for _, pose in composed])
    zeros = np.zeros((5, 3))
    back = kernel.relative_states(world[:, :3], zeros, world[:, 3:], zeros,
                                  carrier_poses[:, :3], zeros, carrier_poses[:, 3:], zeros)
    position = back[:, kernel.SAMPLE.span('O_POSITION')]
    attitude = back[:, kernel.SAMPLE.span('O_QUATERNION')]
    # positions of some 50 m: rounding of a few 1e-14 m each; q and -q are one attitude
    np.testing.assert_allclose(position, relative[:, :3], rtol=0, atol=1e-11)
    attitude *= np.sign(np.sum(attitude * relative[:, 3:], axis=1))[:, None]
    np.testing.assert_allclose(attitude, relative[:, 3:], rtol=0, atol=1e-13)
