# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""cfem-sim sweep --method / --design: refusals before any run, and a design on Dask."""

import json
import os

from cfem_ros import cli
import pandas as pd
import pytest
from sweeps import STORE, write_sweep

MASS = 'bodies.store.mass'
ANGLE = 'joints.pivot.release.angle_deg'


@pytest.mark.parametrize('args,extra,message', [
    (['--method', 'form'], {}, 'criteria: missing; --method form estimates P(a criterion '
     'fails)'),
    (['--method', 'nais'], {'vary': {MASS: {'grid': [900, 910]}},
                            'criteria': {'c': 'release_pivot_time <= 1'}},
     f'vary.{MASS}: is a grid, which a rare-event method cannot draw from'),
    (['--method', 'subset'], {'vary': {MASS: {'normal': [907, 10]}, ANGLE: {'normal': [10, 1]}},
                              'correlate': [[MASS, ANGLE, 1.0]],
                              'criteria': {'c': 'release_pivot_time <= 1'}},
     'correlate: makes a singular correlation matrix'),
    (['--design', 'sobol'], {'vary': {MASS: {'normal': [907, 10]}, ANGLE: {'normal': [10, 1]}},
                             'correlate': [[MASS, ANGLE, 0.5]]},
     'correlate: --design sobol needs independent inputs'),
    (['--design', 'morris', '--method', 'form'], {}, '--method form and --design morris: '
     'expected one of them'),
])
def test_a_study_that_cannot_run_is_refused_with_one_error_line(tmp_path, capsys, args, extra,
                                                                message):
    vary = extra.pop('vary', {MASS: {'normal': [907, 10]}})
    path = write_sweep(tmp_path, vary=vary, **extra)
    out = str(tmp_path / 'out')
    assert cli.main(['sweep', path, '-o', out] + args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith('ERROR: '), err
    assert message in err, err
    assert not os.path.exists(out)


def test_a_design_runs_its_points_on_the_dask_cluster(tmp_path, capsys):
    path = write_sweep(tmp_path, runs=2, scenario=dict(STORE, duration=0.4),
                       vary={MASS: {'normal': [907.1848, 10.0]}, ANGLE: {'normal': [10, 1]}},
                       metrics={'at': [{'time': 0.4, 'body': 'store'}]})
    out = str(tmp_path / 'morris')
    assert cli.main(['sweep', path, '-o', out, '--design', 'morris', '--workers', '1']) == 0
    printed = capsys.readouterr().out
    table = pd.read_parquet(os.path.join(out, 'results.parquet'))
    assert len(table) == 2 * 3 and (table['status'] == 'ok').all()
    indices = pd.read_parquet(os.path.join(out, 'sensitivity.parquet'))
    release = indices[indices['metric'] == 'release_pivot_time'].set_index('parameter')
    # the release angle sets the release time; the mass barely does (a pendulum's period)
    assert release.loc[ANGLE, 'mu_star'] > 10 * release.loc[MASS, 'mu_star']
    assert 'release_pivot_time:' in printed
    with open(os.path.join(out, 'sweep.json')) as stream:
        assert json.load(stream)['method'] == 'morris'


def test_ctrl_c_stops_a_rare_event_study_and_keeps_its_runs(tmp_path):
    """Exit 130 on Ctrl-C: OpenTURNS' own SIGINT handler crashed the process in a call."""
    import signal
    import subprocess
    import sys
    import time
    path = write_sweep(tmp_path, runs=20, scenario=dict(STORE, duration=0.4),
                       vary={MASS: {'normal': [907.1848, 10.0]}, ANGLE: {'normal': [10, 0.5]}},
                       metrics={'at': []}, criteria={'late': 'release_pivot_time <= 0.31'})
    out = str(tmp_path / 'form')
    command = os.path.join(os.path.dirname(sys.executable), 'cfem-sim')
    process = subprocess.Popen([command, 'sweep', path, '-o', out, '--method', 'form',
                                '--workers', '1'],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        parts = os.path.join(out, 'parts')
        while not (os.path.isdir(parts) and os.listdir(parts)):   # a batch is saved
            assert process.poll() is None, process.communicate()
            assert time.monotonic() < deadline
            time.sleep(0.2)
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 130, err
    assert 'interrupted by SIGINT: the runs done are saved in' in err
    assert os.listdir(os.path.join(out, 'parts'))
