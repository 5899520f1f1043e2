# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
``cfem-sim fit`` (SPEC section 13) on synthetic flight data of known parameters.

The "flight data" are recordings of ``cfem-sim run`` at known parameter
values, turned into relative poses by scipy's ``Rotation`` (not by the
fit's code), plus seeded Gaussian noise at the stated sigmas. A fit must
find the values within three standard errors, and its standard errors
must be those the scatter of the estimates over 20 noise seeds shows.
"""

import importlib.util
import json
import pathlib

from cfem_ros import cli
from cfem_ros.recording.analysis import open_run
from cfem_ros.study.fit.measured import Measured
from cfem_ros.study.fit.solve import Fit
from cfem_ros.study.fit.spec import load_fit
import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[2]
SIGMA_POSITION = 0.005      # m
SIGMA_ATTITUDE = 0.3        # deg
FORWARD, AFT = 10676.0, 42703.0   # N, the ejector forces of the "flight"

EJECTED = {
    'name': 'fit_synthetic', 'frame_id': 'world', 'gravity': [0, 0, 9.80665],
    'duration': 0.3, 'dt': 0.002,
    'bodies': {'pylon': {'fixed': True},
               'store': {'mass': 907.1848, 'inertia': [27.1164, 488.0944, 488.0944],
                         'position': [0, 0, 0], 'orientation_rpy_deg': [0, 0, 0]}},
    'wrenches': [
        {'name': 'forward_ejector', 'body': 'store', 'point': [0.1798, 0, -0.25],
         'force': [0, 0, FORWARD], 'frame': 'pylon', 'stroke': 0.1006, 'reacts_on': 'pylon'},
        {'name': 'aft_ejector', 'body': 'store', 'point': [-0.3292, 0, -0.25],
         'force': [0, 0, AFT], 'frame': 'pylon', 'stroke': 0.1006, 'reacts_on': 'pylon'},
        # acts after the window: the measured poses cannot tell its force
        {'name': 'late_push', 'body': 'store', 'force': [0, 0, 100.0], 'start': 0.28}]}

FORCES = {
    'wrenches[0].force[2]': {'start': 9000, 'bounds': [5000, 20000],
                             'name': 'forward ejector force', 'unit': 'N'},
    'wrenches[1].force[2]': {'start': 38000, 'bounds': [30000, 50000],
                             'name': 'aft ejector force', 'unit': 'N'}}


def _write(path, document):
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    return str(path)


def _relative(run, body, reference):
    """Return time, position and Rotation of body in reference's axes (scipy, per sample)."""
    b, r = run.bodies[body], run.bodies[reference]
    turn = Rotation.from_quat(r.quaternion).inv()
    return (b.time, turn.apply(b.position - r.position),
            turn * Rotation.from_quat(b.quaternion))


@pytest.fixture(scope='module')
def flight(tmp_path_factory):
    """Record the ejection at known forces at every step; return it as relative poses."""
    folder = tmp_path_factory.mktemp('flight')
    scenario = _write(folder / 'scenario.yaml', EJECTED)
    truth = str(folder / 'truth.mcap')
    assert cli.main(['run', scenario, '-o', truth, '--rate', '500']) == 0
    return folder, scenario, _relative(open_run(truth), 'store', 'pylon')


def _noisy(flight, seed):
    """Return the flight's poses with seeded noise at the stated sigmas."""
    _, _, (time, position, attitude) = flight
    rng = np.random.default_rng(seed)
    noisy_position = position + rng.normal(0.0, SIGMA_POSITION, position.shape)
    turn = Rotation.from_rotvec(np.radians(rng.normal(0.0, SIGMA_ATTITUDE, position.shape)))
    return time, noisy_position, turn * attitude


def _fit_file(folder, scenario, measured, parameters, window=None, **extra):
    document = {'scenario': scenario, 'measured': {
        'file': measured, 'body': 'store', 'relative_to': 'pylon',
        'sigma': {'position': SIGMA_POSITION, 'attitude_deg': SIGMA_ATTITUDE}},
        'parameters': parameters}
    if window:
        document['measured']['window'] = window
    document['measured'].update(extra)
    path = folder / 'fit.yaml'
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    return str(path)


def _csv(path, time, position, attitude):
    euler = attitude.as_euler('ZYX', degrees=True)[:, ::-1]
    columns = {'time': time}
    columns.update({f'store_{q}': position[:, i] for i, q in enumerate('xyz')})
    columns.update({f'store_{q}_deg': euler[:, i]
                    for i, q in enumerate(('roll', 'pitch', 'yaw'))})
    pd.DataFrame(columns).to_csv(path, index=False)
    return str(path)


def _exported_with_noise(folder, path, seed):
    """Export the flight's recording relative to the pylon; add noise to its pose columns."""
    assert cli.main(['export', str(folder / 'truth.mcap'), '-o', str(path),
                     '--relative-to', 'pylon']) == 0
    table = pd.read_csv(path)   # the headers as export writes them, with their units
    rng = np.random.default_rng(seed)
    for q in ('x', 'y', 'z'):
        table[f'store_{q} [m]'] += rng.normal(0.0, SIGMA_POSITION, len(table))
    for q in ('roll', 'pitch', 'yaw'):
        table[f'store_{q}_deg [deg]'] += rng.normal(0.0, SIGMA_ATTITUDE, len(table))
    table.to_csv(path, index=False, float_format='%.17g')
    return str(path)


def test_fit_recovers_the_ejector_forces_and_writes_its_outputs(flight, tmp_path, capsys):
    # the measured poses in the columns of cfem-sim export, noise added to them
    folder, scenario, _ = flight
    measured = _exported_with_noise(folder, tmp_path / 'measured.csv', 1)
    parameters = dict(FORCES)
    parameters['wrenches[2].force[2]'] = {'start': 100, 'bounds': [0, 1000], 'name': 'late push'}
    fit = _fit_file(tmp_path, scenario, measured, parameters, window={'from': 0.0, 'to': 0.25})
    out = tmp_path / 'out'
    assert cli.main(['fit', fit, '-o', str(out), '--threads', '2']) == 0
    said = capsys.readouterr().out
    found = json.loads((out / 'fit.json').read_text())
    forward = found['parameters']['wrenches[0].force[2]']
    aft = found['parameters']['wrenches[1].force[2]']
    for value, truth in ((forward, FORWARD), (aft, AFT)):
        assert abs(value['value'] - truth) < 3 * value['standard_error'], value
        assert 0 < value['standard_error'] < 0.02 * truth
    # the late push acts after the window: not determined, and the fit says so
    late = found['parameters']['wrenches[2].force[2]']
    assert late['determined'] is False and late['standard_error'] is None
    assert found['status'] == 'not_determined' and 'late push' in found['problems'][0]
    assert 'late push 100 (not determined)' in said and 'aft ejector force' in said
    correlation = np.array(found['correlation'][0][:2] + found['correlation'][1][:2])
    assert np.allclose(correlation.reshape(2, 2), correlation.reshape(2, 2).T)
    assert -1 < found['correlation'][0][1] < 0   # more of one ejector, less of the other
    # the residuals are the noise: their RMS is the sigma, within the scatter of 126 x 3
    assert found['residual_rms']['position'] == pytest.approx(SIGMA_POSITION, rel=0.15)
    assert found['residual_rms']['attitude_deg'] == pytest.approx(SIGMA_ATTITUDE, rel=0.15)
    # printed in m and deg, as every length and angle the tool prints (SPEC 15), 3 digits
    rms = found['residual_rms']
    assert f"residual {rms['position']:.3g} m, {rms['attitude_deg']:.3g} deg" in said
    assert ' mm' not in said and 0.001 < float(f"{rms['position']:.3g}") < 0.01
    # fitted.yaml holds the fitted values and runs where it is; fitted.mcap is its run
    fitted = yaml.safe_load((out / 'fitted.yaml').read_text())
    assert fitted['wrenches'][1]['force'][2] == aft['value']
    run = open_run(str(out / 'fitted.mcap'))
    assert run.bodies['store'].time[-1] == pytest.approx(0.3)
    for figure in ('fit_trajectory.png', 'fit_residuals.png'):
        assert (out / figure).stat().st_size > 10_000
    # the folder is not written over without --overwrite
    assert cli.main(['fit', fit, '-o', str(out)]) == 2
    assert 'already holds fit.json' in capsys.readouterr().err


def test_standard_errors_are_the_scatter_of_the_estimates_over_20_seeds(flight, tmp_path):
    folder, scenario, (time, _, _) = flight
    measured = _csv(tmp_path / 'measured.csv', *_noisy(flight, 0))
    spec = load_fit(_fit_file(tmp_path, scenario, measured, dict(FORCES),
                              window={'from': 0.0, 'to': 0.25}))
    estimates, errors = [], []
    for seed in range(20):
        time, position, attitude = _noisy(flight, 100 + seed)
        result = Fit(spec, Measured(time, position, attitude), log=lambda line: None).solve()
        assert result.status == 'converged'
        estimates.append(result.values)
        errors.append(result.standard_errors)
    estimates, errors = np.array(estimates), np.array(errors)
    spread = estimates.std(axis=0, ddof=1)
    # the standard deviation of 20 draws scatters by about 16 % (1 / sqrt(2 * 19))
    assert np.all(np.abs(spread / errors.mean(axis=0) - 1) < 0.3), (spread, errors.mean(0))
    assert np.all(np.abs(estimates.mean(axis=0) - [FORWARD, AFT])
                  < 3 * errors.mean(axis=0) / np.sqrt(20))


def test_the_last_jacobian_is_kept_and_the_fit_is_the_same_to_the_bit(flight, tmp_path):
    # the solver's last Jacobian is at its solution, where the uncertainty asks for it
    # again: kept, it saves 2 runs per parameter and changes no number
    folder, scenario, _ = flight
    measured = _csv(tmp_path / 'measured.csv', *_noisy(flight, 3))
    spec = load_fit(_fit_file(tmp_path, scenario, measured, dict(FORCES),
                              window={'from': 0.0, 'to': 0.25}))

    class Again(Fit):
        def jacobian(self, *args, **kwargs):
            self._last_jacobian = (None, None)   # nothing kept: every Jacobian run
            return super().jacobian(*args, **kwargs)
    found = {}
    for kind in (Fit, Again):
        fit = kind(spec, Measured(*_noisy(flight, 3)), threads=2, log=lambda line: None)
        found[kind] = (fit.solve(), fit.runs)
    (kept, runs_kept), (again, runs_again) = found[Fit], found[Again]
    assert runs_again - runs_kept == 2 * len(FORCES) and kept.runs == runs_kept
    assert kept.values.tobytes() == again.values.tobytes()
    assert kept.uncertainty.covariance.tobytes() == again.uncertainty.covariance.tobytes()
    assert kept.uncertainty.chi2 == again.uncertainty.chi2 and kept.status == again.status


def test_a_bound_the_fit_ends_at_is_said(flight, tmp_path, capsys):
    folder, scenario, truth = flight
    measured = _csv(tmp_path / 'measured.csv', *truth)
    parameters = {'wrenches[1].force[2]': {'start': 38000, 'bounds': [30000, 40000]}}
    fit = _fit_file(tmp_path, scenario, measured, parameters, window={'from': 0.0, 'to': 0.2})
    assert cli.main(['fit', fit, '-o', str(tmp_path / 'out')]) == 0
    found = json.loads((tmp_path / 'out' / 'fit.json').read_text())
    assert found['status'] == 'at_bound'
    assert found['parameters']['wrenches[1].force[2]']['value'] == pytest.approx(40000)
    assert 'ended at its bound 40000' in capsys.readouterr().out


@pytest.mark.parametrize('change, key', [
    ({'body': 'tank'}, 'measured.body'),
    ({'window': {'from': 0.1, 'to': 0.102}}, 'measured.window'),
    ({'sigma': {'position': 0.0, 'attitude_deg': 0.3}}, 'measured.sigma.position'),
    ({'window': {'from': {'release': 'hook'}}}, 'measured.window.from.release'),
])
def test_a_fit_that_cannot_be_done_is_refused_with_the_key(
        flight, tmp_path, capsys, change, key):
    folder, scenario, truth = flight
    measured = _csv(tmp_path / 'measured.csv', *truth)
    fit = _fit_file(tmp_path, scenario, measured, dict(FORCES), **change)
    assert cli.main(['fit', fit, '-o', str(tmp_path / 'out')]) == 2
    err = capsys.readouterr().err
    assert err.startswith('ERROR: ') and f': {key}: ' in err and err.count('\n') == 1, err
    assert not (tmp_path / 'out' / 'fit.json').exists()


def _pullup_log(path):
    spec = importlib.util.spec_from_file_location(
        'write_pullup_log', ROOT / 'examples' / 'write_pullup_log.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(['-o', str(path), '--duration', '1.0']) == 0


def test_fit_from_a_recording_with_replayed_odometry(tmp_path):
    """A store ejected from an aircraft in a pull-up: the flight log's odometry replayed."""
    scenario = yaml.safe_load((ROOT / 'config' / 'store_release_from_pullup.yaml').read_text())
    scenario['duration'] = 1.0
    scenario['wrenches'] = [{'name': 'ejector', 'body': 'store', 'point': [0, 0, -0.25],
                             'force': [0, 0, 30000.0], 'frame': 'aircraft', 'stroke': 0.1,
                             'reacts_on': 'aircraft',
                             'start': {'release': 'hook', 'delay': 0.0}}]
    path = _write(tmp_path / 'pullup.yaml', scenario)
    log = tmp_path / 'flight.mcap'
    _pullup_log(log)
    recording = str(tmp_path / 'node.mcap')   # the replay is the node's run, to the bit
    assert cli.main(['run', path, '--inputs', str(log), '-o', recording, '--rate', '200']) == 0
    scenario['wrenches'][0]['force'][2] = 24000.0   # the prediction before the flight
    _write(tmp_path / 'pullup.yaml', scenario)
    fit = tmp_path / 'fit.yaml'
    fit.write_text(yaml.safe_dump({
        'scenario': 'pullup.yaml',
        'measured': {'file': 'node.mcap', 'topic': '/cfem/bodies/store/pose', 'body': 'store',
                     'relative_to': 'aircraft', 'inputs': 'node.mcap',
                     'window': {'from': {'release': 'hook'},
                                'to': {'release': 'hook', 'delay': 0.4}},
                     'sigma': {'position': 0.005, 'attitude_deg': 0.3}},
        'parameters': {'wrenches[0].force[2]': {'bounds': [10000, 50000]}}}))
    out = tmp_path / 'out'
    assert cli.main(['fit', str(fit), '-o', str(out)]) == 0
    found = json.loads((out / 'fit.json').read_text())
    assert found['window']['release'] == pytest.approx(0.5)
    assert found['window']['to'] == pytest.approx(0.9)
    force = found['parameters']['wrenches[0].force[2]']
    assert force['start'] == 24000.0
    assert force['value'] == pytest.approx(30000.0, rel=1e-6)   # no noise: the value itself
    assert found['residual_rms']['position'] < 1e-6
