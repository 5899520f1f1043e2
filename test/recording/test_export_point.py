# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
``cfem-sim export --relative-to BODY --point carriage|[x,y,z]`` and ``_u_rel`` (SPEC 15).

The pull-up example (``config/store_release_from_pullup.yaml``): a store on
one hook under an aircraft pitching up at g (n - 1) / V, released at 0.5 s.
The carriage is checked against the hook's anchor read from the YAML here;
the relative velocities against the time derivative of the relative
position in the carrier's axes, by central differences of the exported
positions (error h^2 / 6 times the third derivative, away from the
release where the relative acceleration jumps), and against the velocity
that forgets the carrier's rotation (which they must not equal).
"""

import os

from cfem_ros import cli
from cfem_ros.recording.units import read_units
import numpy as np
import pandas as pd
import pytest
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENARIO = os.path.join(ROOT, 'config', 'store_release_from_pullup.yaml')
RATE = 1000


@pytest.fixture(scope='module')
def pullup(tmp_path_factory):
    """Record the pull-up release to 0.8 s at 1 kHz; return (folder, recording, document)."""
    folder = tmp_path_factory.mktemp('pullup')
    with open(SCENARIO) as stream:
        document = yaml.safe_load(stream)
    document['duration'] = 0.8
    (folder / 'pullup.yaml').write_text(yaml.safe_dump(document))
    recording = str(folder / 'pullup.mcap')
    assert cli.main(['run', str(folder / 'pullup.yaml'), '-o', recording,
                     '--rate', str(RATE)]) == 0
    return folder, recording, document


def _export(folder, recording, name, *extra) -> pd.DataFrame:
    path = str(folder / name)
    assert cli.main(['export', recording, '-o', path, '--relative-to', 'aircraft',
                     '--overwrite', *extra]) == 0
    return pd.read_parquet(path)


def test_carriage_is_the_hook_anchor_in_the_carrier_s_axes(pullup, capsys):
    folder, recording, document = pullup
    from_cg = _export(folder, recording, 'cg.parquet')
    carriage = _export(folder, recording, 'carriage.parquet', '--point', 'carriage')
    # the anchor is a world point at t = 0; the aircraft is level then (flight_path_deg and
    # alpha 0: its axes are the world's), its CG at its YAML position
    anchor = np.array(document['joints']['hook']['anchor'], dtype=float)
    expected = anchor - np.array(document['bodies']['aircraft']['position'], dtype=float)
    assert expected.tolist() == [0.0, 0.0, 1.25]
    xyz = ['store_x', 'store_y', 'store_z']
    np.testing.assert_allclose(from_cg[xyz].to_numpy() - carriage[xyz].to_numpy(),
                               np.tile(expected, (len(from_cg), 1)), rtol=0, atol=1e-12)
    # at t = 0 the store's CG is 0.25 m below the hook (its YAML position less the anchor)
    start = np.array(document['bodies']['store']['position']) - anchor
    np.testing.assert_allclose(carriage[xyz].to_numpy()[0], start, atol=1e-12)
    # the same point given as numbers: the same table; the attitudes do not move
    given = _export(folder, recording, 'given.parquet', '--point', '[0, 0, 1.25]')
    pd.testing.assert_frame_equal(given, carriage)
    angles = ['store_roll_deg', 'store_pitch_deg', 'store_yaw_deg']
    pd.testing.assert_frame_equal(carriage[angles], from_cg[angles])
    assert read_units(str(folder / 'carriage.parquet'))['store_x'] == 'm'


def test_relative_velocity_is_the_derivative_of_the_relative_position(pullup):
    folder, recording, _ = pullup
    table = _export(folder, recording, 'velocity.parquet')
    time = table['time'].to_numpy()
    h = 1.0 / RATE
    assert np.allclose(np.diff(time), h, rtol=0, atol=1e-12)
    position = table[['store_x', 'store_y', 'store_z']].to_numpy()
    relative = table[['store_u_rel', 'store_v_rel', 'store_w_rel']].to_numpy()
    derivative = (position[2:] - position[:-2]) / (2 * h)   # central, at time[1:-1]
    inner = time[1:-1]
    release = 0.5
    away = np.abs(inner - release) > 2.5 * h   # the relative acceleration jumps there
    error = np.abs(derivative - relative[1:-1])[away]
    # h^2 / 6 |x'''|: the relative jerk is about q * n g ~ 0.04 * 20 m/s^3 -> 1e-7 m/s
    assert error.max() < 1e-5, error.max()
    # after the release the store falls away: w_rel grows to n g t-ish, not noise
    late = time > release + 0.2
    assert relative[late, 2].min() > 1.0
    # carried (before the release) the store does not move relative to the aircraft
    np.testing.assert_allclose(relative[time < release - 2 * h], 0.0, atol=1e-6)
    # the velocity that forgets w_c x (p_b - p_c) differs by more than the tolerance
    from cfem_ros.recording.analysis import open_run
    from cfem_ros.recording.relative import relative_pose
    run = open_run(recording)
    store, aircraft = run.bodies['store'], run.bodies['aircraft']
    naive, _ = relative_pose(store.position + store.velocity_world, store.quaternion,
                             aircraft.position + aircraft.velocity_world, aircraft.quaternion)
    naive -= relative_pose(store.position, store.quaternion, aircraft.position,
                           aircraft.quaternion)[0]   # R_c^T (v_b - v_c)
    assert np.abs(naive - relative).max() > 100 * error.max() + 1e-3


@pytest.mark.parametrize('point, said', [
    ('[1, 2]', "'[1, 2]' is neither carriage nor three numbers"),
    ('cariage', "'cariage' is neither carriage nor three numbers"),
    ('[0, nan, 0]', 'is not finite'),
])
def test_a_bad_point_is_refused_saying_what_a_point_is(pullup, capsys, point, said):
    folder, recording, _ = pullup
    out = folder / 'bad.csv'
    assert cli.main(['export', recording, '-o', str(out), '--relative-to', 'aircraft',
                     '--point', point]) == 2
    err = capsys.readouterr().err
    assert err.startswith('ERROR: ') and said in err, err
    assert "expected 'carriage' (the mean of the released joints' anchors) or [x, y, z]" in err
    assert not out.exists()
    assert cli.main(['export', recording, '-o', str(out), '--point', '[0, 0, 1]']) == 2
    assert 'without --relative-to' in capsys.readouterr().err


def test_at_metrics_take_the_point_as_export_does(pullup, capsys):
    # a sweep's run (the samples kept in memory) and summarize (the recording) give the
    # export's numbers at 0.7 s and 0.15 s after the release, _u_rel .. _w_rel too
    folder, recording, _ = pullup
    table = _export(folder, recording, 'at.parquet', '--point', 'carriage')
    at = [{'time': 0.7, 'body': 'store', 'relative_to': 'aircraft', 'point': 'carriage'},
          {'time': 0.15, 'after': 'hook', 'body': 'store', 'relative_to': 'aircraft',
           'point': [0, 0, 1.25]},
          {'time': 0.2, 'body': 'store', 'relative_to': 'aircraft'},
          {'time': 0.1505, 'after': 'hook', 'body': 'store', 'relative_to': 'aircraft',
           'point': 'carriage'}]
    # free fall without air: the relative motion does not depend on the mass varied
    sweep = {'scenario': 'pullup.yaml', 'runs': 1, 'seed': 1, 'rate_hz': RATE,
             'vary': {'bodies.store.mass': {'uniform': [900.0, 910.0]}},
             'metrics': {'at': at}}
    (folder / 'sweep.yaml').write_text(yaml.safe_dump(sweep))
    assert cli.main(['sweep', str(folder / 'sweep.yaml'), '-o', str(folder / 'swept')]) == 0
    assert cli.main(['summarize', recording, '--metrics', str(folder / 'sweep.yaml'), '-o',
                     str(folder / 'summary.parquet')]) == 0
    capsys.readouterr()
    xyz = ['x', 'y', 'z', 'u_rel', 'v_rel', 'w_rel']   # and the velocity seen from it
    for path in (folder / 'swept' / 'results.parquet', folder / 'summary.parquet'):
        row = pd.read_parquet(path).iloc[0]
        for when, prefix in ((0.7, 'store_at_0.7_'), (0.65, 'store_at_0.15r_'),
                             (0.2, 'store_at_0.2_')):
            k = int(np.argmin(np.abs(table['time'] - when)))
            assert abs(table['time'][k] - when) < 1e-9
            np.testing.assert_allclose([row[prefix + c] for c in xyz[3:]],
                                       [table[f'store_{c}'][k] for c in xyz[3:]], atol=1e-9)
            if when == 0.2:
                continue
            np.testing.assert_allclose([row[prefix + c] for c in xyz],
                                       [table[f'store_{c}'][k] for c in xyz], atol=1e-9)
        assert row['store_at_0.7_w_rel'] > 1.0   # falling away, not a zero
        # between two samples (0.6505 s): halfway between theirs, as the position
        k = int(np.argmin(np.abs(table['time'] - 0.65)))
        for c in xyz:
            middle = 0.5 * (table[f'store_{c}'][k] + table[f'store_{c}'][k + 1])
            assert row[f'store_at_0.1505r_{c}'] == pytest.approx(middle, abs=1e-9), c
        k = int(np.argmin(np.abs(table['time'] - 0.2)))   # no point: from the CG
        assert row['store_at_0.2_z'] == pytest.approx(table['store_z'][k] + 1.25, abs=1e-9)


@pytest.mark.parametrize('entry, said', [
    ({'point': 'carriage'}, "metrics.at[0].point: is 'carriage' without relative_to"),
    ({'relative_to': 'aircraft', 'point': [1, 2]}, 'metrics.at[0].point: is [1, 2]'),
    ({'relative_to': 'aircraft', 'point': 'hook'}, "metrics.at[0].point: is 'hook'"),
])
def test_a_bad_metric_point_is_refused_with_its_key(pullup, capsys, entry, said):
    folder, _, _ = pullup
    sweep = {'scenario': 'pullup.yaml', 'runs': 1, 'seed': 1, 'rate_hz': RATE,
             'vary': {'bodies.store.mass': {'uniform': [900.0, 910.0]}},
             'metrics': {'at': [dict({'time': 0.1, 'body': 'store'}, **entry)]}}
    (folder / 'bad.yaml').write_text(yaml.safe_dump(sweep))
    out = folder / 'refused'
    assert cli.main(['sweep', str(folder / 'bad.yaml'), '-o', str(out)]) == 2
    err = capsys.readouterr().err
    assert said in err and err.count('\n') == 1, err
    assert ("carriage' (the mean of the released joints' anchors) or [x, y, z]" in err
            or 'relative_to: the carrier the point is on' in err), err
    assert not out.exists()


def test_a_refused_export_says_its_error_alone(tmp_path, capsys):
    # relative to the store, the aircraft has no joint to it: its positions from the carriage
    # are NaN and a warning says so, but only for a table that is written; a refusal found
    # later (a rate above the recording's) is one ERROR line with no warning before it
    # (found by the campaign's sixth round)
    recording = str(tmp_path / 'two_hooks.mcap')
    assert cli.main(['run', os.path.join(ROOT, 'config', 'store_release_two_hooks.yaml'),
                     '-o', recording, '--duration', '0.02']) == 0
    capsys.readouterr()
    out = tmp_path / 'carriage.csv'
    argv = ['export', recording, '-o', str(out), '--relative-to', 'store', '--point',
            'carriage']
    assert cli.main(argv + ['--rate', '1e9']) == 2
    err = capsys.readouterr().err
    assert err.startswith('ERROR: ') and err.count('\n') == 1 and 'WARNING' not in err, err
    assert not out.exists()
    assert cli.main(argv) == 0
    err = capsys.readouterr().err
    assert err.startswith('WARNING: ') and 'aircraft has no joint to store' in err, err
    assert out.exists()
