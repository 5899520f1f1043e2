# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
``cfem-sim export`` and ``plot --relative-to`` (SPEC section 12) against independent figures.

The exported relative poses against the recorded poses composed by scipy's
``Rotation``; a store released from a carrier flying at 250 m/s against the
same store released from a fixed carrier (Galilean invariance: the relative
trajectory is the same); the aero columns against the documented
definitions of alpha, Mach and dynamic pressure.
"""

import math

from cfem_ros import cli
from cfem_ros.recording.analysis import open_run
from cfem_ros.recording.units import read_csv, read_units
import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation
import yaml

#: A store on two hooks of a pylon fixed under a carrier; the carrier moves as given.
SCENARIO = {
    'name': 'drop', 'frame_id': 'world', 'gravity': [0, 0, 9.80665], 'duration': 0.3,
    'dt': 0.001,
    'bodies': {
        'aircraft': {'shape': {'box': [6.0, 4.0, 1.0]}},
        'pylon': {'mass': 150.0, 'inertia': [5.0, 60.0, 60.0], 'position': [0, 0, 1.0],
                  'shape': {'box': [2.0, 0.3, 0.4]}},
        'store': {'mass': 900.0, 'inertia': [27.0, 480.0, 480.0], 'position': [0, 0, 1.5],
                  'shape': {'cylinder': [0.25, 2.5]}}},
    'joints': {
        'mount': {'type': 'fixed', 'parent': 'aircraft', 'child': 'pylon',
                  'anchor': [0, 0, 0.5]},
        'fwd': {'type': 'ball', 'parent': 'pylon', 'child': 'store', 'anchor': [0.4, 0, 1.25]},
        'aft': {'type': 'ball', 'parent': 'pylon', 'child': 'store', 'anchor': [-0.4, 0, 1.25]}},
    'release_groups': {'station_1': {'joints': ['fwd', 'aft'], 'release': {'time': 0.05}}},
    'wrenches': [{'name': 'aft_ejector', 'body': 'store', 'point': [-0.33, 0, -0.25],
                  'force': [0, 0, 40000], 'frame': 'pylon', 'stroke': 0.1,
                  'reacts_on': 'pylon', 'start': {'release': 'station_1'}}]}


def _carried(velocity=None, rates_deg=None) -> dict:
    """Return the scenario with the carrier fixed, or moving (its payload moving with it)."""
    doc = yaml.safe_load(yaml.safe_dump(SCENARIO, sort_keys=False))
    if velocity is None and rates_deg is None:
        doc['bodies']['aircraft']['fixed'] = True
        return doc
    motion = {'velocity': list(velocity or [0, 0, 0])}
    if rates_deg is not None:
        motion['angular_velocity_deg'] = list(rates_deg)
    doc['bodies']['aircraft']['motion'] = motion
    for name in ('pylon', 'store'):   # carried along (a turning carrier's are corrected)
        doc['bodies'][name]['velocity'] = list(velocity or [0, 0, 0])
    return doc


def _run(tmp_path, doc, name, rate=100) -> str:
    scenario = tmp_path / f'{name}.yaml'
    scenario.write_text(yaml.safe_dump(doc, sort_keys=False))
    out = tmp_path / f'{name}.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out), '--rate', str(rate)]) == 0
    return str(out)


def _export(tmp_path, recording, name, *extra) -> pd.DataFrame:
    path = tmp_path / name
    assert cli.main(['export', recording, '-o', str(path), *extra]) == 0
    return read_csv(str(path)) if name.endswith('.csv') else pd.read_parquet(path)


@pytest.fixture(scope='module')
def turning(tmp_path_factory):
    """Record a carrier flying at 250 m/s and pitching up at 10 deg/s."""
    tmp = tmp_path_factory.mktemp('turning')
    return tmp, _run(tmp, _carried([250.0, 0, 0], [0, 10.0, 0]), 'turning')


def test_export_composes_the_recorded_poses_as_scipy_does(turning):
    tmp, recording = turning
    table = _export(tmp, recording, 'rel.parquet', '--relative-to', 'aircraft')
    run = open_run(recording)
    body = ['x', 'y', 'z', 'roll_deg', 'pitch_deg', 'yaw_deg', 'u', 'v', 'w', 'p', 'q', 'r']
    loads = ['fx', 'fy', 'fz', 'mx', 'my', 'mz']
    want = (['time', 'time_from_release'] + [f'{b}_{c}' for b in ('pylon', 'store')
                                             for c in body + ['u_rel', 'v_rel', 'w_rel']]
            + [f'{j}_{c}' for j in ('mount', 'fwd', 'aft') for c in loads])
    assert list(table.columns) == want
    ref, store = run.bodies['aircraft'], run.bodies['store']
    assert np.array_equal(table['time'], store.time) and len(store.time) == 31
    turn = Rotation.from_quat(ref.quaternion).inv()
    position = turn.apply(store.position - ref.position)
    euler = (turn * Rotation.from_quat(store.quaternion)).as_euler('ZYX', degrees=True)[:, ::-1]
    got = table[['store_x', 'store_y', 'store_z']].to_numpy()
    np.testing.assert_allclose(got, position, rtol=0, atol=1e-12)
    np.testing.assert_allclose(table[['store_roll_deg', 'store_pitch_deg', 'store_yaw_deg']],
                               euler, rtol=0, atol=1e-12)
    assert np.ptp(euler[:, 1]) > 2.0 and np.ptp(position[:, 2]) > 0.3   # it separated
    # velocities and rates as recorded (body axes; rates in deg/s)
    np.testing.assert_array_equal(table[['store_u', 'store_v', 'store_w']], store.velocity)
    np.testing.assert_allclose(table[['store_p', 'store_q', 'store_r']],
                               np.degrees(store.rates), rtol=1e-15, atol=0)
    # the CG's velocity seen from the turning carrier, its axes: R^T (v - v_c - w_c x d)
    omega = Rotation.from_quat(ref.quaternion).apply(ref.rates)   # world
    seen = turn.apply(store.velocity_world - ref.velocity_world
                      - np.cross(omega, store.position - ref.position))
    np.testing.assert_allclose(table[['store_u_rel', 'store_v_rel', 'store_w_rel']], seen,
                               rtol=0, atol=1e-9)
    assert np.abs(seen - turn.apply(store.velocity_world - ref.velocity_world)).max() > 0.01
    # time from the group's release; NaN before it
    release = run.releases()[0][0]
    assert release == pytest.approx(0.05)
    since = table['time_from_release'].to_numpy()
    assert np.isnan(since[store.time < release]).all()
    np.testing.assert_allclose(since[store.time >= release],
                               store.time[store.time >= release] - release, atol=1e-15)
    # a hook's load in its frame (the store's axes) is its world load turned; NaN once released
    world = run.joints['fwd']
    k = np.searchsorted(store.time, world.time)
    turned = Rotation.from_quat(store.quaternion[k]).inv().apply(world.force)
    np.testing.assert_allclose(table[['fwd_fx', 'fwd_fy', 'fwd_fz']].to_numpy()[k], turned,
                               rtol=0, atol=1e-9 * np.abs(world.force).max())
    assert table['fwd_fz'][store.time > release + 1e-9].isna().all()


def test_csv_holds_the_same_numbers_and_rate_keeps_recorded_samples(turning, capsys):
    tmp, recording = turning
    parquet = _export(tmp, recording, 'all.parquet')
    csv = _export(tmp, recording, 'all.csv')
    assert list(csv.columns) == list(parquet.columns)
    with open(tmp / 'all.csv') as stream:   # each header says its unit (a CSV has no metadata)
        header = stream.readline().strip().split(',')
    units = read_units(str(tmp / 'all.parquet'))
    assert header == [f'{c} [{units[c] or 1}]' for c in parquet.columns]
    assert 'aircraft_q [deg/s]' in header and 'store_roll_deg [deg]' in header
    assert 'aircraft_x' in csv and 'time_from_release' not in csv   # no reference
    np.testing.assert_array_equal(csv.to_numpy(), parquet.to_numpy())   # 17 digits: exact
    coarse = _export(tmp, recording, 'coarse.parquet', '--rate', '20')
    np.testing.assert_array_equal(coarse.to_numpy(), parquet.to_numpy()[::5])
    capsys.readouterr()
    assert cli.main(['export', recording, '-o', str(tmp / 'x.csv'), '--rate', '30']) == 2
    assert cli.main(['export', recording, '-o', str(tmp / 'all.csv')]) == 2   # exists
    assert cli.main(['export', recording, '-o', str(tmp / 'x.txt')]) == 2
    assert cli.main(['export', recording, '-o', str(tmp / 'y.csv'), '--relative-to',
                     'wing']) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 4 and all(line.startswith('ERROR: ') for line in lines)
    assert 'divides' in lines[0] and 'already exists' in lines[1] and 'wing' in lines[3]


def test_a_carrier_at_250_m_s_gives_the_fixed_carrier_s_relative_trajectory(tmp_path):
    fixed = _export(tmp_path, _run(tmp_path, _carried(), 'fixed'), 'fixed.parquet',
                    '--relative-to', 'aircraft')
    moving = _export(tmp_path, _run(tmp_path, _carried([250.0, 0, 0]), 'moving'),
                     'moving.parquet', '--relative-to', 'aircraft')
    columns = [f'store_{c}' for c in ('x', 'y', 'z')]
    assert np.ptp(fixed['store_z']) > 0.3   # it fell away
    np.testing.assert_allclose(moving[columns], fixed[columns], rtol=0, atol=1e-9)
    angles = [f'store_{c}_deg' for c in ('roll', 'pitch', 'yaw')]
    np.testing.assert_allclose(moving[angles], fixed[angles], rtol=0, atol=1e-9)
    np.testing.assert_allclose(moving['store_u'] - 250.0 * np.cos(
        np.radians(moving['store_pitch_deg'])), fixed['store_u'], atol=1e-9)


def isa(altitude: float) -> tuple:
    """Return the ISA troposphere's (density kg/m^3, speed of sound m/s) at altitude (m)."""
    gas, lapse = 8314.32 / 28.9644, 0.0065   # U.S. Standard Atmosphere 1976: R*, M0
    temperature = 288.15 - lapse * altitude
    pressure = 101325.0 * (temperature / 288.15) ** (9.80665 / (gas * lapse))
    return pressure / (gas * temperature), math.sqrt(1.4 * gas * temperature)


def test_aero_columns_are_alpha_mach_and_dynamic_pressure_of_the_recorded_state(tmp_path):
    doc = _carried([250.0, 0, 0])
    doc['aero'] = {'store': {'area': 0.2, 'length': 0.5, 'altitude': 7925.0,
                             'alpha_deg': [-30, 0, 30], 'CX': -0.3, 'CZ': [1.0, 0.0, -1.0],
                             'Cm': [0.5, 0.0, -0.5], 'zero': ['CY', 'Cl', 'Cn']}}
    table = _export(tmp_path, _run(tmp_path, doc, 'aero'), 'aero.csv')
    u, v, w = (table[f'store_{c}'].to_numpy() for c in 'uvw')
    speed = np.sqrt(u ** 2 + v ** 2 + w ** 2)   # the air is at rest in the world
    np.testing.assert_allclose(table['store_alpha_deg'], np.degrees(np.arctan2(w, u)),
                               atol=1e-9)
    assert np.ptp(table['store_alpha_deg']) > 1.0
    altitude = 7925.0 - table['store_z'].to_numpy()   # z down, gravity +z
    density, sound = np.transpose([isa(h) for h in altitude])
    np.testing.assert_allclose(table['store_mach'], speed / sound, rtol=1e-12)
    np.testing.assert_allclose(table['store_dynamic_pressure'], 0.5 * density * speed ** 2,
                               rtol=1e-12)
    assert math.isclose(table['store_mach'][0], 250.0 / isa(7925.0 - 1.5)[1], rel_tol=1e-12)


def test_plot_relative_to_draws_the_sheet_and_snapshots_of_a_store_on_a_pylon(
        turning, capsys):
    tmp, recording = turning
    run = open_run(recording)
    # the store hangs from the pylon, which hangs from the aircraft: both in its frame
    assert sorted(run.relative) == ['pylon', 'store']
    from cfem_ros.separation.commands import plot_relative
    from cfem_ros.separation.figures import free_bodies
    assert [t.name for t in free_bodies(run, 'aircraft')] == ['store']   # the pylon is still
    paths = plot_relative(run, 'aircraft', str(tmp / 'figures'), '0.1,0.2')
    assert [p.rsplit('/', 1)[1] for p in paths] == ['separation_aircraft.png',
                                                    'snapshots_aircraft.png']
    capsys.readouterr()
    for bad in (['--snapshots', '0.1,-1'], ['--relative-to', 'wing']):
        options = ['--relative-to', 'aircraft'] + bad
        assert cli.main(['plot', recording, '-o', str(tmp / 'none'), *options]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 2 and '--snapshots 0.1,-1' in lines[0] and 'wing' in lines[1]


def test_outlines_of_a_turned_box_a_cylinder_and_a_compound_shape_are_exact():
    from cfem_ros.core.model.shapes import Shape
    from cfem_ros.separation import outlines
    box = Shape('box', (2.0, 0.4, 0.5), offset=(0.1, 0.0, -0.2))
    pitch = Rotation.from_euler('y', 30, degrees=True)
    [ring] = outlines.placed_outlines(outlines.shape_parts(box), [1.0, 0.0, 2.0],
                                      pitch.as_quat(), 'side')
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-0.2, 0.2) for z in (-0.25, 0.25)])
    seen = pitch.apply(corners + [0.1, 0.0, -0.2]) + [1.0, 0.0, 2.0]
    want = {tuple(np.round(p, 12)) for p in seen[:, [0, 2]]}
    assert len(ring) == 5 and {tuple(np.round(p, 12)) for p in ring[:-1]} == want
    cylinder = Shape('cylinder', (0.25, 2.5))
    [front] = outlines.placed_outlines(outlines.shape_parts(cylinder), [0, 0, 0],
                                       [0, 0, 0, 1], 'front')
    np.testing.assert_allclose(np.hypot(front[:, 0], front[:, 1]), 0.25, atol=1e-12)
    assert len(front) == outlines.CIRCLE_POINTS + 1
    # a compound shape (SPEC section 11): each part placed in the body's axes, drawn alone
    compound = Shape('compound', (), parts=(Shape('box', (3.0, 0.4, 0.5), offset=(0, 0, -0.35)),
                                            Shape('sphere', (0.3,), offset=(0, 0, -1.4))))
    rings = outlines.placed_outlines(outlines.shape_parts(compound), [0, 0, 0], [0, 0, 0, 1],
                                     'top')
    assert len(rings) == 2
    np.testing.assert_allclose(np.ptp(rings[0], axis=0), [3.0, 0.4], rtol=1e-12)
    np.testing.assert_allclose(np.hypot(*rings[1].T), 0.3, atol=1e-12)
    # a mesh by its convex hull's vertices (here a wedge): its outline in the side view
    wedge = ((0, -0.1, 0), (1.0, -0.1, 0), (0, -0.1, 0.5), (0, 0.1, 0), (1.0, 0.1, 0),
             (0, 0.1, 0.5))
    [side] = outlines.placed_outlines(outlines.shape_parts(Shape('mesh', (1, 1, 1), hull=wedge)),
                                      [0, 0, 0], [0, 0, 0, 1], 'side')
    assert {tuple(p) for p in side[:-1]} == {(0.0, 0.0), (1.0, 0.0), (0.0, 0.5)}
