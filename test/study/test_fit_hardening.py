# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
``cfem-sim fit`` fed bad data and bad folders (issue 52 items 3, 7, 8), and release groups.

Each case of the attack campaign is reproduced first: a measured sample far
past the window (the fit simulated up to it), values of 1e300, 1e308 and
NaN, a NaN or zero quaternion in a PoseStamped topic, a finite-difference
step wider than the bounds, one key path written two ways, an output folder
that cannot take the outputs (found only after the whole fit), and a write
interrupted half-way (the figures are drawn in forked processes). A
measured CSV reads as pandas reads it, and names a line it cannot read. A
window may name a release group (issue 48).
"""

import copy
import functools
import json
import os
import signal

from cfem_ros import cli
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.schema import POSE_TYPE
from cfem_ros.study.fit import figures, outputs
from cfem_ros.study.fit.forked import Forked
from cfem_ros.study.fit.run import observed_flights
from cfem_ros.study.fit.solve import Fit
from cfem_ros.study.fit.spec import load_fit
import fitflights as ff
import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

AFT = {'wrenches[1].force[2]': {'start': 38000, 'bounds': [30000, 50000],
                                'name': 'aft ejector force', 'unit': 'N'}}


@pytest.fixture(scope='module')
def flight(tmp_path_factory):
    """Record the ejection at the true forces; return (folder, scenario, poses)."""
    folder = tmp_path_factory.mktemp('flight')
    poses = ff.truth(folder, 'truth')
    return folder, ff.write(folder / 'scenario.yaml', ff.EJECTED), poses


def _refused(capsys, fit, out, *key_and_words):
    assert cli.main(['fit', fit, '-o', str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith('ERROR: ') and err.count('\n') == 1, err
    for words in key_and_words:
        assert words in err, err
    assert not out.exists()
    return err


def test_a_sample_far_past_the_window_is_neither_simulated_nor_read(flight, tmp_path):
    # one sample 11.6 days after the others: the fit once simulated up to it (7.7 GB)
    _, scenario, (time, position, attitude) = flight
    far = (np.append(time, 1e6), np.vstack([position, position[-1]]),
           Rotation.concatenate([attitude, attitude[-1:]]))
    measured = ff.csv(tmp_path / 'far.csv', *far)
    for window, end in (({'from': 0.0, 'to': 0.1}, 0.1), (None, time[-1])):
        spec = load_fit(ff.fit_file(tmp_path, scenario, ff.measured_entry(measured, window),
                                    AFT))
        fit = Fit(spec, observed_flights(spec), threads=2, log=lambda line: None)
        flight_fit = fit.flights[0]
        # the window ends at its end (or the last sample within the scenario's duration)
        assert flight_fit.window[1] == pytest.approx(end)
        assert flight_fit.data.time.max() <= end and 1e6 not in flight_fit.data.time
        run = flight_fit.trajectories.run(spec.x0)
        assert run.end <= end + 3 * flight_fit.dt + 1e-9, run.end
    result = fit.solve()
    # noise-free poses: the true force itself
    assert result.values[0] == pytest.approx(ff.AFT, rel=1e-6)


def test_a_window_end_far_past_the_samples_simulates_nothing_more(flight, tmp_path, capsys):
    # a window to 1e6 s (11.6 days of simulation) ends, for the runs, at the last sample
    _, scenario, poses = flight
    measured = ff.csv(tmp_path / 'poses.csv', *poses)
    spec = load_fit(ff.fit_file(tmp_path, scenario, ff.measured_entry(
        measured, {'from': 0.0, 'to': 1e6}), AFT))
    fit = Fit(spec, observed_flights(spec), threads=2, log=lambda line: None)
    flight_fit = fit.flights[0]
    assert flight_fit.last == pytest.approx(poses[0][-1])
    assert flight_fit.trajectories.duration == pytest.approx(poses[0][-1] + 3 * flight_fit.dt)
    assert flight_fit.start_run.end <= poses[0][-1] + 3 * flight_fit.dt + 1e-9
    # a window starting after the last sample: refused at once, nothing simulated past it
    fit = ff.fit_file(tmp_path, scenario, ff.measured_entry(measured, {'from': 1e6}), AFT)
    _refused(capsys, fit, tmp_path / 'out', ': measured.window: ', 'runs from 1e+06 s to 0.2 s')


def _poses_csv(tmp_path, flight, row, column, value):
    table = pd.read_csv(ff.csv(tmp_path / 'poses.csv', *flight[2]))
    table.loc[row, column] = value
    table.to_csv(tmp_path / 'poses.csv', index=False)
    return str(tmp_path / 'poses.csv')


@pytest.mark.parametrize('column, value, problem', [
    ('store_z', 1e300, 'a position beyond 1e+06 m of pylon'),
    ('store_x', 1e308, 'a position beyond 1e+06 m of pylon'),
    ('store_y', float('nan'), 'a position that is not finite'),
    ('store_pitch_deg', float('nan'), 'an angle that is not finite'),
    ('store_roll_deg', 1e300, 'an angle beyond 1e+06 deg'),
])
def test_a_measured_value_that_is_no_pose_is_refused_with_its_line(
        flight, tmp_path, capsys, column, value, problem):
    # the first data line of a CSV is line 2: row 7 is line 9
    measured = _poses_csv(tmp_path, flight, 7, column, value)
    fit = ff.fit_file(tmp_path, flight[1], ff.measured_entry(measured), AFT)
    _refused(capsys, fit, tmp_path / 'out', ': measured.file: ', f'poses.csv line 9 holds '
             f'{problem}', 'finite measured poses')


@pytest.mark.parametrize('header, found, want', [
    ('store_x [mm]', 'mm', 'm'), ('store_pitch_deg [rad]', 'rad', 'deg'),
    ('time [ms]', 'ms', 's')])
def test_a_measured_csv_column_in_another_unit_is_refused(
        flight, tmp_path, capsys, header, found, want):
    # a header 'name [unit]' (as export writes it) is read as name only in export's unit
    table = pd.read_csv(ff.csv(tmp_path / 'poses.csv', *flight[2]))
    units = {'time': 's', 'store_x': 'm', 'store_y': 'm', 'store_z': 'm'}
    good = [f'{c} [{units.get(c, "deg")}]' for c in table.columns]
    table.columns = good
    table.to_csv(tmp_path / 'poses.csv', index=False, float_format='%.17g')
    fit = ff.fit_file(tmp_path, flight[1], ff.measured_entry(str(tmp_path / 'poses.csv')), AFT)
    chosen = observed_flights(load_fit(fit))[0].measured   # the units export writes: taken
    np.testing.assert_array_equal(chosen.time, flight[2][0])
    np.testing.assert_allclose(chosen.position, flight[2][1], rtol=0, atol=1e-12)
    name = header.split(' ')[0]
    table.columns = [header if c.startswith(name + ' ') else c for c in good]
    table.to_csv(tmp_path / 'poses.csv', index=False)
    _refused(capsys, fit, tmp_path / 'out', ': measured.file: ', 'poses.csv: column '
             f"'{header}' is in {found}; expected {want} ('{name} [{want}]' or '{name}')")


def test_a_measured_csv_reads_as_pandas_reads_it_and_a_bad_line_is_named(
        flight, tmp_path, capsys):
    # the same numbers as pandas (an independent reader) to the bit, blank lines, quoted
    # fields and a BOM as pandas takes them; a field that is no number, or a line wider
    # than the header, refused with its line (the header is line 1)
    lines = open(ff.csv(tmp_path / 'poses.csv', *ff.noisy(flight[2], 4))).read().splitlines()
    odd = ['\ufeff' + lines[0]] + lines[1:5] + [''] + ['"' + lines[5].replace(',', '","') + '"']
    (tmp_path / 'odd.csv').write_text('\n'.join(odd + lines[6:]) + '\n', encoding='utf-8')
    fit = ff.fit_file(tmp_path, flight[1], ff.measured_entry(str(tmp_path / 'odd.csv')), AFT)
    read = observed_flights(load_fit(fit))[0].measured
    table = pd.read_csv(tmp_path / 'odd.csv', encoding='utf-8-sig')
    np.testing.assert_array_equal(read.time, table['time'])
    np.testing.assert_array_equal(read.position, table[['store_x', 'store_y', 'store_z']])
    fields = lines[7].split(',')
    for k, (line, problem) in enumerate((
            (','.join(fields[:2] + ['abc'] + fields[3:]),
             "poses.csv line 8 holds 'abc', not a number"),
            (lines[7] + ',1', 'poses.csv line 8 has 8 fields, the header 7'))):
        (tmp_path / 'poses.csv').write_text('\n'.join(lines[:7] + [line] + lines[8:]))
        fit = ff.fit_file(tmp_path, flight[1], ff.measured_entry(str(tmp_path / 'poses.csv')),
                          AFT)
        _refused(capsys, fit, tmp_path / f'out{k}', ': measured.file: ', problem,
                 'expected numbers, one per column of the header')


def test_forked_jobs_run_once_each_in_other_processes_and_the_first_error_is_raised(
        tmp_path):
    def job(k, fail=False):
        (tmp_path / f'{k}.pid').write_text(str(os.getpid()))
        if fail:
            raise OSError(28, f'job {k} failed')
    with Forked([functools.partial(job, k) for k in range(5)], 2):
        pass
    pids = [int((tmp_path / f'{k}.pid').read_text()) for k in range(5)]
    assert os.getpid() not in pids and len(set(pids)) <= 2
    with pytest.raises(OSError, match='job 1 failed'):   # job 3 fails too: the first said
        with Forked([functools.partial(job, k, k in (1, 3)) for k in range(4)], 2):
            pass
    with Forked([functools.partial(job, 9)], 2):   # one job: in the parent, at the end
        assert not (tmp_path / '9.pid').exists()
    assert int((tmp_path / '9.pid').read_text()) == os.getpid()


def _pose_log(path, poses, bad_row, position=None, quaternion=None):
    time, xyz, attitude = poses
    quaternions = attitude.as_quat()
    with Recorder(str(path), overwrite=True) as rec:
        for k, t in enumerate(time):
            p, q = xyz[k], quaternions[k]
            if k == bad_row:
                p = position if position is not None else p
                q = quaternion if quaternion is not None else q
            t_ns = 10 ** 9 + round(t * 1e9)
            rec.write('/photogrammetry/store', POSE_TYPE, {
                'header': {'stamp': {'sec': t_ns // 10 ** 9, 'nanosec': t_ns % 10 ** 9},
                           'frame_id': 'pylon'},
                'pose': {'position': dict(zip('xyz', map(float, p))),
                         'orientation': dict(zip('xyzw', map(float, q)))}}, t_ns)
    return str(path)


@pytest.mark.parametrize('position, quaternion, problem', [
    ([0.0, float('nan'), 0.0], None, 'a position that is not finite'),
    (None, [0.0, float('nan'), 0.0, 1.0], 'a quaternion that is not finite'),
    (None, [0.0, 0.0, 0.0, 0.0], 'a quaternion of length 0 (no attitude)'),
])
def test_a_pose_message_that_is_no_pose_is_refused_with_its_number(
        flight, tmp_path, capsys, position, quaternion, problem):
    log = _pose_log(tmp_path / 'poses.mcap', flight[2], 11, position, quaternion)
    fit = ff.fit_file(tmp_path, flight[1], ff.measured_entry(
        log, topic='/photogrammetry/store'), AFT)
    _refused(capsys, fit, tmp_path / 'out', ': measured.file: ',
             f'poses.mcap message 12 holds {problem}')


def test_a_step_wider_than_the_bounds_and_a_key_path_given_twice_are_refused(
        flight, tmp_path, capsys):
    measured = ff.csv(tmp_path / 'poses.csv', *flight[2])
    wide = {'wrenches[1].force[2]': {'start': 38000, 'bounds': [37000, 39000], 'step': 1500}}
    fit = ff.fit_file(tmp_path, flight[1], ff.measured_entry(measured), wide)
    _refused(capsys, fit, tmp_path / 'out', ': parameters.wrenches[1].force[2].step: ',
             'is 1500, wider than half the bounds', 'a step <= 1000')
    twice = dict(AFT)
    twice['wrenches[1].force[02]'] = {'start': 40000, 'bounds': [30000, 50000]}
    fit = ff.fit_file(tmp_path, flight[1], ff.measured_entry(measured), twice)
    _refused(capsys, fit, tmp_path / 'out', ': parameters.wrenches[1].force[02]: ',
             'is wrenches[1].force[2], as parameters.wrenches[1].force[2] is',
             'each key path once')


@pytest.fixture
def no_fit(monkeypatch):
    """Make any fit that starts fail the test: the refusals come before it."""
    def solve(self):
        raise AssertionError('the fit started before its folder was checked')
    monkeypatch.setattr(Fit, 'solve', solve)


def test_a_folder_that_cannot_take_the_outputs_is_refused_before_the_fit(
        flight, tmp_path, capsys, no_fit):
    measured = ff.csv(tmp_path / 'poses.csv', *flight[2])
    fit = ff.fit_file(tmp_path, flight[1], ff.measured_entry(measured), AFT)
    a_file = tmp_path / 'a_file'
    a_file.write_text('not a folder')
    held = tmp_path / 'held'
    held.mkdir()
    (held / 'fitted.yaml').write_text('a former fit')
    for out, words in ((a_file, 'is not a folder'),
                       ('/sys/cfem_fit_out', '/sys cannot be written'),
                       (held, 'already holds fitted.yaml; pass --overwrite')):
        assert cli.main(['fit', fit, '-o', str(out)]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f'ERROR: -o {out}: ') and words in err, err
    assert a_file.read_text() == 'not a folder'
    assert sorted(os.listdir(held)) == ['fitted.yaml']


def _interrupt():
    os.kill(os.getpid(), signal.SIGINT)


def _full():
    raise OSError(28, 'No space left on device')


@pytest.mark.parametrize('failure, status', [(_full, 1), (_interrupt, 130)])
def test_a_write_that_fails_half_way_leaves_the_folder_as_it_was(
        flight, tmp_path, capsys, monkeypatch, failure, status):
    # a former fit's outputs, replaced with --overwrite: all or none of them
    measured = ff.csv(tmp_path / 'poses.csv', *flight[2])
    fit = ff.fit_file(tmp_path, flight[1], ff.measured_entry(measured, {'from': 0, 'to': 0.1}),
                      AFT)
    out = tmp_path / 'out'
    out.mkdir()
    former = {name: f'former {name}' for name in outputs.output_names(1)}
    for name, text in former.items():
        (out / name).write_text(text)

    def draw(*args):   # in a forked process, fitted.mcap recorded meanwhile
        failure()
    monkeypatch.setattr(figures, 'draw_residuals', draw)
    assert cli.main(['fit', fit, '-o', str(out), '--overwrite', '--threads', '2']) == status
    capsys.readouterr()
    assert sorted(os.listdir(out)) == sorted(former)   # no staging folder left either
    for name, text in former.items():
        assert (out / name).read_text() == text


def test_a_window_may_name_a_release_group(tmp_path):
    # two hooks let go as one station at 0.05 s; the ejectors start at its release
    scenario = copy.deepcopy(ff.EJECTED)
    scenario['duration'] = 0.25
    scenario['joints'] = {
        'fwd_hook': {'type': 'ball', 'parent': 'pylon', 'child': 'store',
                     'anchor': [0.5, 0, -0.25]},
        'aft_hook': {'type': 'ball', 'parent': 'pylon', 'child': 'store',
                     'anchor': [-0.5, 0, -0.25]}}
    scenario['release_groups'] = {'station_1': {'joints': ['fwd_hook', 'aft_hook'],
                                                'release': {'time': 0.05}}}
    for wrench in scenario['wrenches']:
        wrench['start'] = {'release': 'station_1', 'delay': 0.0}
    poses = ff.truth(tmp_path, 'grouped', scenario=scenario)
    measured = ff.csv(tmp_path / 'grouped.csv', *poses)
    window = {'from': {'release': 'station_1'}, 'to': {'release': 'station_1', 'delay': 0.1}}
    fit = ff.fit_file(tmp_path, str(tmp_path / 'grouped.yaml'),
                      ff.measured_entry(measured, window), AFT)
    out = tmp_path / 'out'
    assert cli.main(['fit', fit, '-o', str(out), '--threads', '2']) == 0
    found = json.loads((out / 'fit.json').read_text())
    far = ff.fit_file(tmp_path, str(tmp_path / 'grouped.yaml'), ff.measured_entry(
        measured, {'from': window['from'], 'to': {'release': 'station_1', 'delay': 1e6}}),
        AFT, name='far.yaml')
    spec = load_fit(far)   # a delay of 1e6 s after the release: the runs end at the samples'
    flight_fit = Fit(spec, observed_flights(spec), log=lambda line: None).flights[0]
    assert flight_fit.window[1] == pytest.approx(1e6 + 0.05)
    assert flight_fit.trajectories.duration == pytest.approx(0.25 + 3 * flight_fit.dt)
    assert found['window']['release'] == pytest.approx(0.05)
    assert found['window']['from'] == pytest.approx(0.05)
    assert found['window']['to'] == pytest.approx(0.15)
    assert found['samples'] == 51   # 0.05 to 0.15 s at 500 Hz, both ends
    value = found['parameters']['wrenches[1].force[2]']['value']
    assert value == pytest.approx(ff.AFT, rel=1e-6)   # noise-free: the value itself


def test_a_parameter_without_bounds_is_written_and_predicted_from(flight, tmp_path, capsys):
    # its bounds are [-inf, inf]: fit.json (JSON has no infinity) once failed after the fit
    measured = ff.csv(tmp_path / 'poses.csv', *ff.noisy(flight[2], 6))
    fit = ff.fit_file(tmp_path, flight[1], ff.measured_entry(measured, {'from': 0, 'to': 0.1}),
                      {'wrenches[1].force[2]': {'start': 38000}})
    out = tmp_path / 'out'
    assert cli.main(['fit', fit, '-o', str(out), '--threads', '2']) == 0
    found = json.loads((out / 'fit.json').read_text())
    entry = found['parameters']['wrenches[1].force[2]']
    assert entry['bounds'] == [None, None] and entry['determined'] is True
    assert abs(entry['value'] - ff.AFT) < 4 * entry['standard_error_scaled']
    capsys.readouterr()
    assert cli.main(['predict', str(out), flight[1], '-o', str(tmp_path / 'next'),
                     '--draws', '10', '--threads', '2']) == 0
    summary = json.loads((tmp_path / 'next' / 'prediction.json').read_text())
    assert summary['parameters']['wrenches[1].force[2]']['outside_bounds'] == 0


@pytest.mark.parametrize('sigma, key, words', [
    ({'position': 1e-300, 'attitude_deg': 0.3}, 'position', 'from 1e-09 to 10 m'),
    ({'position': 1e300, 'attitude_deg': 0.3}, 'position', 'from 1e-09 to 10 m'),
    ({'position': 0.005, 'attitude_deg': 1e-300}, 'attitude_deg', 'from 1e-09 to 90 deg'),
    ({'position': 0.005, 'attitude_deg': 720}, 'attitude_deg', 'from 1e-09 to 90 deg'),
])
def test_a_sigma_no_measurement_has_is_refused(flight, tmp_path, capsys, sigma, key, words):
    # 1e-300 made the residuals infinite (a traceback inside the optimiser); 1e300 made
    # every parameter "not determined: the poses do not change with it", which is false
    measured = ff.csv(tmp_path / 'poses.csv', *flight[2])
    fit = ff.fit_file(tmp_path, flight[1], dict(ff.measured_entry(measured), sigma=sigma), AFT)
    _refused(capsys, fit, tmp_path / 'out', f': measured.sigma.{key}: ', words)


def test_a_key_path_set_by_a_flight_and_fitted_is_refused(flight, tmp_path, capsys):
    # the flight's value was silently overwritten by the fitted one
    measured = ff.csv(tmp_path / 'poses.csv', *flight[2])
    entry = ff.measured_entry(measured, set={'wrenches[1].force[02]': 40000.0})
    fit = ff.fit_file(tmp_path, flight[1], [entry], AFT)
    _refused(capsys, fit, tmp_path / 'out', ': parameters.wrenches[1].force[2]: ',
             'is also set by measured[0].set (wrenches[1].force[02]: 40000.0)')


def test_predict_refuses_more_draws_than_it_keeps(tmp_path, capsys):
    assert cli.main(['predict', str(tmp_path), 'next.yaml', '-o', str(tmp_path / 'out'),
                     '--draws', '1000000000']) == 2
    err = capsys.readouterr().err
    assert err.startswith('ERROR: --draws: is 1000000000; expected at most 100,000')
