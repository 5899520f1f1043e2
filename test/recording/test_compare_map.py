# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""``cfem-sim compare --map``: a run against a flight log with other topic names."""

import math

from cfem_ros import cli
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.recording.analysis import compare_runs, open_run
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.offline import run
from cfem_ros.recording.recorder import StateRecorder
from cfem_ros.recording.schema import POSE_TYPE
import numpy as np
from scipy.spatial.transform import Rotation

OFFSET = np.array([0.0, 0.0, 0.01])   # the flight store sits 1 cm lower, carrier axes
SCENARIO = {
    'name': 'carrier', 'dt': 0.001, 'duration': 0.5,
    'bodies': {'aircraft': {'motion': {'velocity': [250, 0, 0],
                                       'angular_velocity': [0, -0.04, 0]}},
               'store': {'mass': 200.0, 'inertia': [5.0, 60.0, 60.0], 'position': [0, 0, -1]}},
    'joints': {'hook': {'type': 'hinge', 'parent': 'aircraft', 'child': 'store',
                        'anchor': [0.5, 0, -0.6], 'axis': [0, 1, 0]}},
}


def _pose(t_ns, position, quat):
    return {'header': {'stamp': {'sec': t_ns // 10 ** 9, 'nanosec': t_ns % 10 ** 9},
                       'frame_id': 'world'},
            'pose': {'position': dict(zip('xyz', map(float, position))),
                     'orientation': dict(zip('xyzw', map(float, quat)))}}


def _recordings(tmp_path):
    sim = Simulator(parse_scenario(SCENARIO))
    simulated = str(tmp_path / 'sim.mcap')
    with Recorder(simulated) as recorder:
        assert run(sim, StateRecorder(recorder, sim), rate_hz=100.0, duration=0.5)
    a = open_run(simulated)
    flight = str(tmp_path / 'flight.mcap')
    aircraft, store = a.bodies['aircraft'], a.bodies['store']
    with Recorder(flight) as recorder:
        for k, t_ns in enumerate(aircraft.stamp_ns):
            turn = Rotation.from_quat(aircraft.quaternion[k])
            recorder.write('/flight/aircraft/pose', POSE_TYPE, _pose(
                int(t_ns), aircraft.position[k], aircraft.quaternion[k]), int(t_ns))
            recorder.write('/flight/store/pose', POSE_TYPE, _pose(
                int(t_ns), store.position[k] + turn.apply(OFFSET), store.quaternion[k]),
                int(t_ns))
    return simulated, flight


def test_compare_maps_topics_and_measures_in_the_carrier_frame(tmp_path):
    simulated, flight = _recordings(tmp_path)
    a = open_run(simulated)
    b = open_run(flight, topic_map={'/flight/store/pose': '/cfem/bodies/store/pose',
                                    '/flight/aircraft/pose': '/cfem/bodies/aircraft/pose'})
    assert set(b.bodies) == {'aircraft', 'store'}
    rows = {r.quantity: r for r in compare_runs(a, b)[0]}
    # exactly the offset, in the carrier's axes, at every sample
    relative = rows['store position in aircraft axes']
    assert abs(relative.max_abs - 0.01) < 1e-9
    assert relative.samples == len(a.bodies['store'].time)
    assert abs(rows['store position'].max_abs - 0.01) < 1e-9
    assert rows['aircraft position'].max_abs < 1e-9
    assert rows['store attitude'].max_abs < 1e-6


def test_cli_compare_with_maps(tmp_path, capsys):
    simulated, flight = _recordings(tmp_path)
    assert cli.main(['compare', simulated, flight,
                     '--map', '/cfem/bodies/store/pose=/flight/store/pose',
                     '--map', '/cfem/bodies/aircraft/pose=/flight/aircraft/pose']) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.startswith('store position in aircraft axes'))
    assert math.isclose(float(line.split()[5]), 0.01, rel_tol=1e-6)
    assert cli.main(['compare', simulated, flight, '--map', 'store=/flight/store/pose']) == 2
    err = capsys.readouterr().err
    assert '--map' in err and 'A_TOPIC=B_TOPIC' in err and err.count('\n') == 1


def test_quantities_missing_from_b_are_named_not_printed_as_nan(tmp_path, capsys):
    # regression: a log with poses and no twists gave rows of nan for rates and velocity
    simulated, flight = _recordings(tmp_path)
    assert cli.main(['compare', simulated, flight,
                     '--map', '/cfem/bodies/store/pose=/flight/store/pose',
                     '--map', '/cfem/bodies/aircraft/pose=/flight/aircraft/pose']) == 0
    out = capsys.readouterr().out
    assert 'nan' not in out.lower()
    for body in ('store', 'aircraft'):
        for quantity in ('rates', 'velocity'):
            assert f'only in A: {body} {quantity} (no twist in B)' in out
    assert 'store position' in out and 'store attitude' in out


def _photogrammetry(tmp_path, with_aircraft: bool):
    """Return the run and a log of the store's pose relative to the aircraft (frame_id)."""
    simulated, _ = _recordings(tmp_path)
    a = open_run(simulated)
    aircraft, store = a.bodies['aircraft'], a.bodies['store']
    photo = str(tmp_path / f'photo_{with_aircraft}.mcap')
    with Recorder(photo) as recorder:
        for k, t_ns in enumerate(store.stamp_ns):
            turn = Rotation.from_quat(aircraft.quaternion[k])
            relative = turn.inv().apply(store.position[k] - aircraft.position[k]) + OFFSET
            attitude = (turn.inv() * Rotation.from_quat(store.quaternion[k])).as_quat()
            message = _pose(int(t_ns), relative, attitude)
            message['header']['frame_id'] = 'aircraft'
            recorder.write('/photo/store/pose', POSE_TYPE, message, int(t_ns))
            if with_aircraft:
                recorder.write('/flight/aircraft/pose', POSE_TYPE, _pose(
                    int(t_ns), aircraft.position[k], aircraft.quaternion[k]), int(t_ns))
    return simulated, photo


def _row(out: str, quantity: str) -> float:
    line = next(x for x in out.splitlines() if x.startswith(quantity + '  '))
    return float(line[len(quantity):].split()[0])


def test_a_pose_in_the_aircraft_frame_is_composed_not_read_as_a_world_pose(tmp_path, capsys):
    # the case: --map read a pose relative to the aircraft as a world pose (a 250 m
    # "difference"); its frame_id names a body of A: it is composed with B's aircraft pose
    simulated, photo = _photogrammetry(tmp_path, with_aircraft=True)
    maps = ['--map', '/cfem/bodies/store/pose=/photo/store/pose',
            '--map', '/cfem/bodies/aircraft/pose=/flight/aircraft/pose']
    assert cli.main(['compare', simulated, photo] + maps) == 0
    out = capsys.readouterr().out
    assert math.isclose(_row(out, 'store position'), 0.01, rel_tol=1e-9)
    assert _row(out, 'store attitude') < 1e-6
    assert math.isclose(_row(out, 'store position in aircraft axes'), 0.01, rel_tol=1e-9)
    b = open_run(photo, topic_map={'/photo/store/pose': '/cfem/bodies/store/pose',
                                   '/flight/aircraft/pose': '/cfem/bodies/aircraft/pose'},
                 frames={'aircraft', 'store'})
    assert b.relative['store'].reference == 'aircraft'
    assert len(b.bodies['store'].time) == len(open_run(simulated).bodies['store'].time)


def test_compare_relative_to_the_carrier_without_its_pose_in_b(tmp_path, capsys):
    # photogrammetry alone: the store relative to the aircraft, and no aircraft pose
    simulated, photo = _photogrammetry(tmp_path, with_aircraft=False)
    maps = ['--map', '/cfem/bodies/store/pose=/photo/store/pose']
    figures = tmp_path / 'figures'
    assert cli.main(['compare', simulated, photo, '--relative-to', 'aircraft', '-o',
                     str(figures)] + maps) == 0
    out = capsys.readouterr().out
    assert math.isclose(_row(out, 'store position in aircraft axes'), 0.01, rel_tol=1e-9)
    assert _row(out, 'store attitude in aircraft axes') < 1e-6
    assert 'store position  ' not in out and 'only in A: store\n' not in out + '\n'
    assert (figures / 'compare_store_in_aircraft.png').stat().st_size > 10_000
    # without it: no world pose of the store in B to compare (never a 250 m difference); A's
    # recorded relative pose (the store hangs on the aircraft) against B's
    assert cli.main(['compare', simulated, photo] + maps) == 0
    out = capsys.readouterr().out
    assert 'store position  ' not in out
    assert math.isclose(_row(out, 'store position in aircraft axes'), 0.01, rel_tol=1e-9)
    assert cli.main(['compare', simulated, photo, '--relative-to', 'pylon'] + maps) == 2
    line, = capsys.readouterr().err.splitlines()
    assert line.startswith('ERROR: --relative-to pylon: not a body of') and 'aircraft' in line
