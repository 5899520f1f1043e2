# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The study report: one self-contained page, and the worst runs' commands that reproduce them."""

import re

from cfem_ros import cli
from cfem_ros.recording.analysis import open_run
from cfem_ros.study import load_sweep, Sweep
from cfem_ros.study.methods import run_study
import numpy as np
import pytest
from sweeps import STORE, write_sweep


@pytest.fixture(scope='module')
def judged(tmp_path_factory):
    folder = tmp_path_factory.mktemp('report')
    path = write_sweep(folder, runs=6, seed=2, scenario=dict(STORE, duration=0.5),
                       vary={'joints.pivot.release.angle_deg': {'normal': [10, 1]},
                             'bodies.store.mass': {'normal': [907.1848, 10.0]}},
                       criteria={'early': 'release_pivot_time <= 0.28',
                                 'pitch': 'abs(store_at_0.5_pitch_deg) <= 60'})
    out = str(folder / 'sweep')
    table = Sweep.from_file(path).run(None, out)
    return folder, out, table


def test_the_report_is_one_page_with_the_decision_and_the_worst_runs(judged, capsys):
    folder, out, table = judged
    page = str(folder / 'report.html')
    assert cli.main(['report', out, '-o', page]) == 0
    with open(page, encoding='utf-8') as stream:
        text = stream.read()
    # self-contained: every image inline, nothing fetched from elsewhere
    images = re.findall(r'<img [^>]*src="([^"]*)"', text)
    assert images and all(src.startswith('data:image/png;base64,') for src in images)
    assert not re.search(r'(src|href)="(?!data:)', text)
    # scenario, sweep, parameters with units
    assert 'store_test' in text and 'pivot release angle [deg]' in text
    assert 'store mass [kg]' in text
    # criteria with the failures and the exact interval, as the command line prints them
    failed = int((table['release_pivot_time'] > 0.28).sum())
    assert 'release_pivot_time &lt;= 0.28' in text and 'exact 95 % interval' in text
    assert re.search(rf'<td>early</td>.*?{failed} failed' if failed else
                     r'<td>early</td>.*?none failed', text, re.S)
    # the worst run first: the latest release
    worst = int(table['run'][table['release_pivot_time'].idxmax()])
    commands = re.findall(r'<code>(cfem-sim rerun [^<]*)</code>', text)
    assert commands[0].split()[3] == str(worst)


def test_a_worst_run_s_command_reproduces_it_alone(judged, tmp_path, capsys):
    _, out, table = judged
    worst = int(table['run'][table['release_pivot_time'].idxmax()])
    recording = str(tmp_path / 'worst.mcap')
    assert cli.main(['rerun', out, str(worst), '-o', recording]) == 0
    released = [t for t, joint, _ in open_run(recording).releases() if joint == 'pivot']
    assert released[0] == pytest.approx(table.loc[worst, 'release_pivot_time'], abs=1e-9)
    assert cli.main(['rerun', out, '99', '-o', str(tmp_path / 'x.mcap')]) == 2
    assert 'no run 99' in capsys.readouterr().err


def test_the_report_shows_a_study_s_estimate_and_sensitivities(tmp_path):
    path = write_sweep(tmp_path, runs=8, seed=4, vary={
        'bodies.store.mass': {'uniform': [900.0, 910.0]},
        'bodies.store.inertia[1]': {'uniform': [480.0, 500.0]}},
        criteria={'heavy': 'bodies.store.mass <= 908'})

    def rows(spec, runs):
        from cfem_ros.study.sweep import columns
        out = []
        for k in runs:
            values = spec.run_values(k)
            row = dict.fromkeys(columns(spec), float('nan'))
            row.update(run=k, status='ok', message='', **values)
            row['clearance_store_pylon_min'] = 2.0 * values['bodies.store.mass']
            out.append(row)
        return out

    out = str(tmp_path / 'morris')
    run_study(load_sweep(path), out, design='morris', rows=rows, log=lambda line: None)
    page = str(tmp_path / 'report.html')
    assert cli.main(['report', out, '-o', page]) == 0
    with open(page, encoding='utf-8') as stream:
        text = stream.read()
    assert '<h2>Sensitivities</h2>' in text and 'Morris screening (SALib)' in text
    assert 'store inertia Iyy [kg m^2]' in text
    assert 'not P(fail)' in text   # a design's runs are not a sample of the inputs
    sensitivity = re.search(r'<h2>Sensitivities</h2>(.*?)</table>', text, re.S).group(1)
    rows_html = re.findall(r'<tr>(.*?)</tr>', sensitivity, re.S)[1:]
    mu = {re.findall(r'<td>(.*?)</td>', r)[1]: float(re.findall(
        r'<td class="num">(.*?)</td>', r)[0]) for r in rows_html
        if 'min clearance' in r}
    assert mu['store inertia Iyy [kg m^2]'] == 0.0 and mu['store mass [kg]'] > 0
    assert np.isfinite(list(mu.values())).all()
