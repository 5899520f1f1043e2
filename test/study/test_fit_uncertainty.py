# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Honest uncertainty of ``cfem-sim fit`` (SPEC section 13) on synthetic flights of known truth.

The reduced chi-square scales the standard errors exactly (a fit whose
sigmas are stated 3 times too small reports, scaled, the errors of the
fit that states them right); parameters the data cannot tell apart are
named together and keep their start values; the profile-likelihood
intervals cover the truth at their stated rate over 20 noise seeds; two
flights under different conditions fit together determine the forces they
share better than either alone, their information (inverse covariance)
the sum of each flight's.
"""

import copy
import json
import math

from cfem_ros import cli
from cfem_ros.study.fit.likelihood import profile_intervals
from cfem_ros.study.fit.measured import Measured
from cfem_ros.study.fit.run import observed_flights
from cfem_ros.study.fit.solve import Fit
from cfem_ros.study.fit.spec import load_fit
from cfem_ros.study.fit.uncertainty import residual_structure
import fitflights as ff
import numpy as np
import pytest
from scipy.stats import binom, chi2
import yaml


@pytest.fixture(scope='module')
def flight(tmp_path_factory):
    """Record the ejection at the true forces; return (folder, scenario, poses)."""
    folder = tmp_path_factory.mktemp('flight')
    poses = ff.truth(folder, 'truth')
    return folder, ff.write(folder / 'scenario.yaml', ff.EJECTED), poses


def _fit(tmp_path, name, scenario, measured, parameters, *options, sigma=1.0):
    entry = ff.measured_entry(measured)
    entry['sigma'] = {'position': sigma * ff.SIGMA_POSITION,
                      'attitude_deg': sigma * ff.SIGMA_ATTITUDE}
    path = ff.fit_file(tmp_path, scenario, entry, parameters, name=f'{name}.yaml')
    out = tmp_path / name
    assert cli.main(['fit', path, '-o', str(out), '--threads', '2', *options]) == 0
    return json.loads((out / 'fit.json').read_text()), out


def test_the_reduced_chi_square_scales_the_errors_exactly(flight, tmp_path, capsys):
    # the noise is 3 times the sigma the first fit states; the second states it right
    _, scenario, poses = flight
    measured = ff.csv(tmp_path / 'measured.csv', *ff.noisy(poses, 5, factor=3.0))
    small, _ = _fit(tmp_path, 'small', scenario, measured, ff.FORCES)
    said = capsys.readouterr()
    right, _ = _fit(tmp_path, 'right', scenario, measured, ff.FORCES, sigma=3.0)
    said_right = capsys.readouterr()
    # chi-square over its degrees of freedom, 6 residuals per pose less 2 parameters
    assert small['degrees_of_freedom'] == 6 * small['samples'] - 2
    assert small['reduced_chi2'] == pytest.approx(small['chi2'] / small['degrees_of_freedom'],
                                                  rel=1e-12)
    # the noise is 9 times the stated variance: within 5 standard deviations of chi2/dof
    spread = 9 * math.sqrt(2 / small['degrees_of_freedom'])
    assert abs(small['reduced_chi2'] - 9) < 5 * spread
    for key in ff.FORCES:
        low, good = small['parameters'][key], right['parameters'][key]
        scale = math.sqrt(max(1.0, small['reduced_chi2']))
        assert low['standard_error_scaled'] == pytest.approx(low['standard_error'] * scale,
                                                             rel=1e-12)
        # the same estimate; its scaled error is the error of the fit stated right
        assert low['value'] == pytest.approx(good['value'], abs=0.01 * good['standard_error'])
        assert low['standard_error'] * 3 == pytest.approx(good['standard_error'], rel=1e-3)
        # SE / 3 * sqrt(9 chi2 / dof) of the fit stated right: its error times its own
        # sqrt(chi2 / dof), exactly (that one is near 1, and not scaled itself)
        assert low['standard_error_scaled'] == pytest.approx(
            good['standard_error'] * math.sqrt(right['reduced_chi2']), rel=1e-3)
        assert good['standard_error_scaled'] == good['standard_error'] * math.sqrt(
            max(1.0, right['reduced_chi2']))
        # the printed error is the scaled one
        printed = f"{low['standard_error_scaled']:.0f}"
        assert f'± {printed[:2]}' in said.out, said.out
    assert 'WARNING: reduced chi-square' in said.err and '> 2' in said.err
    assert 'reduced chi-square' not in said_right.err   # about 1: no warning
    assert right['reduced_chi2'] == pytest.approx(1.0, abs=5 * math.sqrt(
        2 / right['degrees_of_freedom']))


def test_interchangeable_parameters_are_named_together_and_keep_their_start(
        flight, tmp_path, capsys):
    # a second aft ejector at the same point: only the sum of the two acts on the store;
    # a late push acts after the window: the poses there do not change with it at all
    folder, _, poses = flight
    scenario = copy.deepcopy(ff.EJECTED)
    scenario['wrenches'].append(dict(scenario['wrenches'][1], name='aft_twin',
                                     force=[0, 0, 0.0]))
    scenario['wrenches'].append({'name': 'late_push', 'body': 'store',
                                 'force': [0, 0, 100.0], 'start': 0.15})
    path = ff.write(tmp_path / 'twin.yaml', scenario)
    measured = ff.csv(tmp_path / 'measured.csv', *ff.noisy(poses, 2))
    parameters = dict(ff.FORCES)
    parameters['wrenches[2].force[2]'] = {'start': 1000, 'bounds': [-20000, 20000],
                                          'name': 'aft twin', 'unit': 'N'}
    parameters['wrenches[3].force[2]'] = {'start': 100, 'bounds': [0, 1000],
                                          'name': 'late push', 'unit': 'N'}
    fit = ff.fit_file(tmp_path, path, ff.measured_entry(measured, {'from': 0, 'to': 0.12}),
                      parameters)
    out = tmp_path / 'out'
    assert cli.main(['fit', fit, '-o', str(out), '--threads', '2']) == 0
    said = capsys.readouterr().out
    found = json.loads((out / 'fit.json').read_text())
    named = [p for p in found['problems'] if 'interchangeable' in p]
    assert len(named) == 1, found['problems']
    assert named[0].startswith('aft ejector force and aft twin are interchangeable here: '
                               'correlation -1.0000')
    assert 'fix one' in named[0] and 'do not change with it' not in named[0]
    late = [p for p in found['problems'] if p.startswith('late push')]
    assert len(late) == 1 and 'do not change with it' in late[0]
    fitted = yaml.safe_load((out / 'fitted.yaml').read_text())
    for key, index, start in (('wrenches[1].force[2]', 1, 38000.0),
                              ('wrenches[2].force[2]', 2, 1000.0),
                              ('wrenches[3].force[2]', 3, 100.0)):
        entry = found['parameters'][key]
        assert entry['determined'] is False and entry['standard_error'] is None
        assert entry['value'] == start and fitted['wrenches'][index]['force'][2] == start
    forward = found['parameters']['wrenches[0].force[2]']
    assert forward['determined'] is True and forward['standard_error'] > 0
    assert 'aft twin 1000 N (not determined)' in said


def test_profile_intervals_cover_the_truth_at_their_rate_over_20_seeds(flight, tmp_path):
    _, scenario, poses = flight
    measured = ff.csv(tmp_path / 'measured.csv', *poses)
    spec = load_fit(ff.fit_file(tmp_path, scenario, ff.measured_entry(
        measured, {'from': 0, 'to': 0.1}), ff.FORCES))
    assert spec.confidence == 0.95
    truth = np.array([ff.FORWARD, ff.AFT])
    covered = np.zeros(2, dtype=int)
    for seed in range(20):
        fit = Fit(spec, Measured(*ff.noisy(poses, 300 + seed)), threads=2,
                  log=lambda line: None)
        result = fit.solve()
        intervals = np.array(profile_intervals(fit, result))
        covered += (intervals[:, 0] <= truth) & (truth <= intervals[:, 1])
        # nearly linear here: each end near the quadratic one, value -/+ z * scaled error
        z = math.sqrt(chi2.ppf(0.95, 1))
        half = z * result.uncertainty.standard_errors_scaled
        assert np.allclose(intervals[:, 0], result.values - half, rtol=0, atol=0.1 * half)
        assert np.allclose(intervals[:, 1], result.values + half, rtol=0, atol=0.1 * half)
    # 95 % of 20: 19 expected; fewer than 16 has a probability of 0.3 % if the rate is right
    assert binom.cdf(15, 20, 0.95) < 0.003
    assert np.all(covered >= 16), covered


def test_two_flights_determine_the_shared_forces_better_than_either_alone(tmp_path, capsys):
    # the same ejectors under two conditions: a store of 907 kg and one of 1,200 kg
    heavy = {'bodies.store.mass': 1200.0}
    poses = {'light': ff.truth(tmp_path, 'light'), 'heavy': ff.truth(tmp_path, 'heavy', heavy)}
    scenario = ff.write(tmp_path / 'scenario.yaml', ff.EJECTED)
    window = {'from': 0, 'to': 0.12}
    entries = {'light': ff.measured_entry(ff.csv(tmp_path / 'light.csv',
                                                 *ff.noisy(poses['light'], 11)), window),
               'heavy': ff.measured_entry(ff.csv(tmp_path / 'heavy.csv',
                                                 *ff.noisy(poses['heavy'], 12)), window,
                                          set=heavy)}
    found = {}
    for name, measured in (('light', entries['light']), ('heavy', entries['heavy'])):
        # each flight alone: the fit itself, without its outputs
        spec = load_fit(ff.fit_file(tmp_path, scenario, measured, ff.FORCES,
                                    name=f'{name}.yaml'))
        result = Fit(spec, observed_flights(spec), threads=2, log=lambda line: None).solve()
        u = result.uncertainty
        found[name] = {'parameters': {key: {'standard_error': float(u.standard_errors[j])}
                                      for j, key in enumerate(ff.FORCES)},
                       'correlation': u.correlation.tolist()}
    path = ff.fit_file(tmp_path, scenario, [entries['light'], entries['heavy']], ff.FORCES,
                       name='both.yaml')
    assert cli.main(['fit', path, '-o', str(tmp_path / 'both'), '--threads', '2']) == 0
    found['both'] = json.loads((tmp_path / 'both' / 'fit.json').read_text())
    both = found['both']
    said = capsys.readouterr().out
    for key, flight in zip(('measured[0]', 'measured[1]'), both['flights']):   # m, as SPEC 15
        rms = flight['residual_rms']
        assert (f"{key}: residual {rms['position']:.3g} m, {rms['attitude_deg']:.3g} deg over "
                f"{flight['samples']} poses") in said, said
    assert [f['set'] for f in both['flights']] == [{}, heavy]
    assert [f['samples'] for f in both['flights']] == [61, 61]
    # the chi-square is the flights' sum; each flight's residuals are its noise
    assert both['chi2'] == pytest.approx(sum(f['chi2'] for f in both['flights']), rel=1e-12)
    for flight in both['flights']:
        assert flight['residual_rms']['position'] == pytest.approx(ff.SIGMA_POSITION, rel=0.2)
    truth = {'wrenches[0].force[2]': ff.FORWARD, 'wrenches[1].force[2]': ff.AFT}
    for key, value in truth.items():
        errors = {name: found[name]['parameters'][key]['standard_error'] for name in found}
        assert errors['both'] < min(errors['light'], errors['heavy']), errors
        estimate = both['parameters'][key]
        assert abs(estimate['value'] - value) < 3 * estimate['standard_error_scaled']

    # the information of independent flights adds: C_both^-1 = C_light^-1 + C_heavy^-1
    # (to the Jacobians' change between the three solutions, well under 5 %)
    def information(fit):
        errors = np.array([fit['parameters'][k]['standard_error'] for k in truth])
        return np.linalg.inv(np.array(fit['correlation']) * np.outer(errors, errors))
    added = information(found['light']) + information(found['heavy'])
    scale = np.sqrt(np.outer(np.diag(added), np.diag(added)))
    assert np.allclose(information(both) / scale, added / scale, rtol=0, atol=0.05)


def test_profile_on_the_command_line_writes_and_prints_the_intervals(flight, tmp_path, capsys):
    _, scenario, poses = flight
    measured = ff.csv(tmp_path / 'measured.csv', *ff.noisy(poses, 9))
    path = ff.fit_file(tmp_path, scenario, ff.measured_entry(measured, {'from': 0, 'to': 0.1}),
                       ff.FORCES, confidence=0.9)
    assert cli.main(['fit', path, '-o', str(tmp_path / 'out'), '--profile',
                     '--threads', '2']) == 0
    said = capsys.readouterr().out
    found = json.loads((tmp_path / 'out' / 'fit.json').read_text())
    assert found['confidence'] == 0.9
    z = math.sqrt(chi2.ppf(0.9, 1))
    shown = []
    for key in ff.FORCES:
        entry = found['parameters'][key]
        low, high = entry['interval']
        half = z * entry['standard_error_scaled']
        # nearly linear here: the 90 % profile interval is value -/+ 1.645 scaled errors
        assert low == pytest.approx(entry['value'] - half, abs=0.1 * half)
        assert high == pytest.approx(entry['value'] + half, abs=0.1 * half)
        shown.append(f"{entry['name']} [{low:.6g}, {high:.6g}] N")
    assert 'profile-likelihood intervals (0.9): ' + ', '.join(shown) in said
    # the profile's refits are runs too: more than the fit alone makes
    assert cli.main(['fit', path, '-o', str(tmp_path / 'plain'), '--threads', '2']) == 0
    plain = json.loads((tmp_path / 'plain' / 'fit.json').read_text())
    assert found['runs'] > plain['runs'] and f"({found['status']}, {found['runs']} runs)" in said


def test_area_and_altitude_of_the_aero_tables_are_named_interchangeable(tmp_path, capsys):
    # issue 48's case: the two-hook release with its aero table; the reference area and
    # the altitude (its air density) both scale the dynamic pressure times the area
    scenario = yaml.safe_load((ff.ROOT / 'config' / 'store_release_two_hooks.yaml').read_text())
    scenario['duration'] = 0.3
    scenario['release_groups']['station_1']['release'] = {'time': 0.05}
    truth = copy.deepcopy(scenario)
    truth['wrenches'][1]['force'][2] = 40000.0
    poses = ff.truth(tmp_path, 'flight', scenario=truth)
    path = ff.write(tmp_path / 'predicted.yaml', scenario)
    measured = ff.csv(tmp_path / 'measured.csv', *ff.noisy(poses, 4))
    window = {'from': {'release': 'station_1'}, 'to': {'release': 'station_1', 'delay': 0.2}}
    parameters = {
        'wrenches[1].force[2]': {'start': 42703, 'bounds': [30000, 55000],
                                 'name': 'aft ejector', 'unit': 'N'},
        'aero.store.area': {'start': 0.2027, 'bounds': [0.1, 0.4], 'name': 'area'},
        'aero.store.altitude': {'start': 7925, 'bounds': [0, 15000], 'name': 'altitude'}}
    fit = ff.fit_file(tmp_path, path, ff.measured_entry(measured, window), parameters)
    assert cli.main(['fit', fit, '-o', str(tmp_path / 'out'), '--threads', '2']) == 0
    said = capsys.readouterr().out
    found = json.loads((tmp_path / 'out' / 'fit.json').read_text())
    named = [p for p in found['problems'] if 'interchangeable' in p]
    assert len(named) == 1 and named[0].startswith(
        'area and altitude are interchangeable here: correlation +1.0000'), found['problems']
    assert 'do not change with it' not in ' '.join(found['problems'])
    for key, start in (('aero.store.area', 0.2027), ('aero.store.altitude', 7925)):
        assert found['parameters'][key]['determined'] is False
        assert found['parameters'][key]['value'] == start
    aft = found['parameters']['wrenches[1].force[2]']
    assert abs(aft['value'] - 40000.0) < 3 * aft['standard_error_scaled'], aft
    assert 'altitude 7925 (not determined)' in said


def test_a_flight_may_name_its_own_scenario_as_set_would_make_it(tmp_path):
    heavy = {'bodies.store.mass': 1200.0}
    poses = ff.truth(tmp_path, 'heavy', heavy)   # writes heavy.yaml, the heavy scenario
    scenario = ff.write(tmp_path / 'scenario.yaml', ff.EJECTED)
    measured = ff.csv(tmp_path / 'heavy.csv', *ff.noisy(poses, 3))
    window = {'from': 0, 'to': 0.1}
    residuals = []
    for name, extra in (('set', {'set': heavy}), ('own', {'scenario': 'heavy.yaml'})):
        spec = load_fit(ff.fit_file(tmp_path, scenario, [ff.measured_entry(measured, window,
                                                                           **extra)],
                                    ff.FORCES, name=f'{name}.yaml'))
        fit = Fit(spec, observed_flights(spec), threads=2, log=lambda line: None)
        residuals.append(fit.evaluate(spec.x0))
    assert np.array_equal(residuals[0], residuals[1])
    # and not the light store's: the flight's own scenario is the one run
    spec = load_fit(ff.fit_file(tmp_path, scenario, [ff.measured_entry(measured, window)],
                                ff.FORCES, name='light.yaml'))
    light = Fit(spec, observed_flights(spec), threads=2, log=lambda line: None)
    assert not np.allclose(light.evaluate(spec.x0), residuals[0])


def test_residuals_of_white_noise_pass_and_those_that_follow_a_trend_do_not():
    # the lag-1 test's p-value is uniform for white noise: 5 % of 400 below 0.05
    rng = np.random.default_rng(8)
    p = np.array([residual_structure(rng.standard_normal(6 * 50))['p'] for _ in range(400)])
    below = int(np.sum(p < 0.05))
    assert binom.ppf(0.0005, 400, 0.05) <= below <= binom.ppf(0.9995, 400, 0.05), below
    # an AR(1) series of coefficient 0.5 in one quantity: found at once
    series = rng.standard_normal((50, 6))
    for k in range(1, 50):
        series[k, 2] = 0.5 * series[k - 1, 2] + math.sqrt(0.75) * series[k, 2]
    found = residual_structure(series.ravel())
    assert found['p'] < 1e-3 and found['autocorrelation']['z'] > 0.3
    assert abs(found['autocorrelation']['x']) < 0.3


def test_a_parameter_held_wrong_leaves_residuals_that_are_not_noise(flight, tmp_path, capsys):
    # the forward ejector held at 7,000 N (the truth is 10,676 N): the aft one absorbs
    # what it can, and what is left follows the trajectory whatever the chi-square
    _, scenario, poses = flight
    measured = ff.csv(tmp_path / 'measured.csv', *ff.noisy(poses, 12))
    held = copy.deepcopy(ff.EJECTED)
    held['wrenches'][0]['force'][2] = 7000.0
    path = ff.fit_file(tmp_path, ff.write(tmp_path / 'held.yaml', held),
                       ff.measured_entry(measured, {'from': 0, 'to': 0.15}),
                       {'wrenches[1].force[2]': ff.FORCES['wrenches[1].force[2]']})
    assert cli.main(['fit', path, '-o', str(tmp_path / 'out'), '--threads', '2']) == 0
    said = capsys.readouterr().err
    found = json.loads((tmp_path / 'out' / 'fit.json').read_text())
    assert found['flights'][0]['residual_structure_p'] < 1e-3
    assert 'WARNING: the residuals of measured are not noise' in said
    # the right model on the same data: noise, no warning
    right = ff.fit_file(tmp_path, scenario, ff.measured_entry(measured, {'from': 0, 'to': 0.15}),
                        ff.FORCES, name='right.yaml')
    assert cli.main(['fit', right, '-o', str(tmp_path / 'right'), '--threads', '2']) == 0
    assert 'not noise' not in capsys.readouterr().err
    fine = json.loads((tmp_path / 'right' / 'fit.json').read_text())
    assert fine['flights'][0]['residual_structure_p'] > 1e-3
