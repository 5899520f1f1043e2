# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The README's flight-test replay: a store released from a 2 g pull-up."""

import importlib.util
import pathlib

from cfem_ros import cli
from cfem_ros.recording.analysis import open_run
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
G = 9.80665


def _script():
    spec = importlib.util.spec_from_file_location(
        'write_pullup_log', ROOT / 'examples' / 'write_pullup_log.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_replay_of_the_pullup_log(tmp_path):
    script = _script()
    log = str(tmp_path / 'flight.mcap')
    assert script.main(['-o', log]) == 0
    out = str(tmp_path / 'sim.mcap')
    assert cli.main(['run', str(ROOT / 'config' / 'store_release_from_pullup.yaml'), '-o', out,
                     '--inputs', log]) == 0
    run = open_run(out)
    assert [(round(t, 9), joint) for t, joint, _ in run.releases()] == [(0.5, 'hook')]
    # the aircraft flew the log's pull-up
    aircraft = run.bodies['aircraft']
    k = int(np.argmin(np.abs(aircraft.time - 2.0)))
    position, quat, _ = script.pullup(2.0)
    assert np.allclose(aircraft.position[k], position, rtol=0, atol=1e-6)
    # the store rode the hook, then fell away at about 2 g in the aircraft's frame:
    # it falls at g, the aircraft climbs at (n - 1) g = g (z down in both)
    store = run.relative['store']
    before = store.time <= 0.5
    # (to 1e-8 m: the scenario's motion hands over to the odometry at t = 0)
    assert np.abs(store.position[before] - [0, 0, 1.5]).max() < 1e-8
    after = store.time >= 0.5
    t = store.time[after] - 0.5
    expected = 1.5 + 0.5 * 2 * G * t ** 2
    # the frame turns 3.4 deg in the 1.5 s: the fall tilts back in x by that much
    assert np.abs(store.position[after, 2] - expected).max() < 0.01 * expected.max()
    assert store.position[-1, 0] < -0.5


def test_the_example_pulls_up_and_releases_without_its_log(tmp_path):
    # flight: flies the log's pull-up in closed form, and the hook lets go as scheduled
    script = _script()
    out = str(tmp_path / 'alone.mcap')
    assert cli.main(['run', str(ROOT / 'config' / 'store_release_from_pullup.yaml'), '-o', out,
                     '--duration', '1.0']) == 0
    run = open_run(out)
    assert [(round(t, 9), joint) for t, joint, _ in run.releases()] == [(0.5, 'hook')]
    aircraft = run.bodies['aircraft']
    for k in range(0, len(aircraft.time), 10):
        position, quat, _ = script.pullup(aircraft.time[k])
        assert np.allclose(aircraft.position[k], position, rtol=0, atol=1e-6)
        assert np.allclose(aircraft.quaternion[k], quat, rtol=0, atol=1e-9)
    # carried on the aircraft's circle (radius V / q about a centre above it, the store
    # 1.5 m further out), pitched by q t: hook load m (a - g), to 1e-3 N of 17.8 kN
    hook = run.joints['hook']
    q = G / script.SPEED
    pitch = q * hook.time
    centre = np.stack([-np.sin(pitch), 0.0 * pitch, -np.cos(pitch)], axis=1)
    load = 907.1848 * (q ** 2 * (script.SPEED / q + 1.5) * centre - [0.0, 0.0, G])
    assert np.abs(hook.force - load).max() < 1e-3
    store = run.relative['store']
    after = store.time >= 0.5
    expected = 1.5 + G * (store.time[after] - 0.5) ** 2
    assert np.abs(store.position[after, 2] - expected).max() < 0.01 * expected.max()


def _log(path, script, metadata=None, rate_hz=20.0):
    """Write the pull-up's odometry at rate_hz, with a cfem_ros metadata record if given."""
    from cfem_ros.recording.container import Recorder
    from cfem_ros.recording.schema import ODOMETRY_TYPE
    with Recorder(str(path), metadata=metadata) as rec:
        for k in range(int(round(1.0 * rate_hz)) + 1):
            t_ns = script.START_NS + round(k / rate_hz * 1e9)
            position, quat, pitch_rate = script.pullup(k / rate_hz)
            rec.write('/cfem/bodies/aircraft/odom', ODOMETRY_TYPE, {
                'header': {'stamp': {'sec': t_ns // 10 ** 9, 'nanosec': t_ns % 10 ** 9},
                           'frame_id': 'world'},
                'child_frame_id': 'aircraft',
                'pose': {'pose': {'position': dict(zip('xyz', position)),
                                  'orientation': dict(zip('xyzw', quat))}},
                'twist': {'twist': {'linear': {'x': script.SPEED},
                                    'angular': {'y': pitch_rate}}}}, t_ns)


def test_replay_interpolates_odometry_unless_the_recording_node_did_not(tmp_path):
    script = _script()
    scenario = str(ROOT / 'config' / 'store_release_from_pullup.yaml')
    plain, extrapolated = tmp_path / 'flight.mcap', tmp_path / 'node.mcap'
    _log(plain, script)
    _log(extrapolated, script, {'start_stamp_ns': script.START_NS,
                                'interpolate_odometry': 'false'})

    runs = []

    def hook_force(log, *options):
        runs.append(log)
        out = str(tmp_path / f'run{len(runs)}.mcap')
        assert cli.main(['run', scenario, '-o', out, '--inputs', str(log), '--duration', '1',
                         *options]) == 0
        return open_run(out).joints['hook'].force

    interpolated = hook_force(plain)
    assert np.array_equal(interpolated, hook_force(plain, '--odometry', 'interpolate'))
    # a node that extrapolated (its metadata says so) is replayed the same way
    assert np.array_equal(hook_force(extrapolated), hook_force(plain, '--odometry',
                                                               'extrapolate'))
    assert np.array_equal(hook_force(extrapolated, '--odometry', 'interpolate'), interpolated)
    # at 20 Hz the two differ: the extrapolated carrier's acceleration jumps at each message
    assert np.abs(hook_force(extrapolated) - interpolated).max() > 1e-3


def test_the_first_hook_load_sample_is_the_odometrys(tmp_path):
    # regression: the t = 0 sample showed the scenario's stand-in motion (1 g on the
    # hook) before the log's odometry took over (2 g); a table of the pull-up gives
    # 2 g at t = 0 too
    script = _script()
    log = str(tmp_path / 'flight.mcap')
    assert script.main(['-o', log]) == 0
    out = str(tmp_path / 'sim.mcap')
    assert cli.main(['run', str(ROOT / 'config' / 'store_release_from_pullup.yaml'), '-o', out,
                     '--inputs', log, '--duration', '0.3']) == 0
    hook = open_run(out).joints['hook']
    load = np.linalg.norm(hook.force, axis=1)
    two_g = 907.1848 * 2 * G
    assert hook.time[0] == 0.0
    assert abs(load[0] - two_g) < 1e-3 * two_g
    assert np.abs(load - two_g).max() < 1e-3 * two_g
