# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Sweeps bounded like ``cfem-sim run``: refused before anything runs, in one short line.

``runs`` (in the file, even when ``--runs`` overrides it, and ``--runs``),
the total of runs with the grids, ``rate_hz`` and the size of each run it
implies, draws whose arithmetic overflows, ``at`` entries given twice, and
key paths of any length: exit 2, one ``ERROR:`` line of bounded length, no
cluster started and no output folder made.
"""

from cfem_ros import cli
import pytest
from sweeps import write_sweep

AT = {'at': [{'time': 0.1, 'body': 'store'}]}


@pytest.mark.parametrize('settings, argv, words', [
    ({'runs': 10 ** 12}, [], 'runs: is 1,000,000,000,000; expected at most 1,000,000 runs'),
    ({'runs': 3}, ['--runs', str(10 ** 12)], '--runs: is 1,000,000,000,000'),
    ({'runs': -3}, ['--runs', '5'], 'runs: is -3'),
    ({'runs': 'many'}, ['--runs', '5'], "runs: is 'many'"),
    ({'runs': 600_000, 'vary': {'dt': {'grid': [0.001, 0.0005]}}}, [],
     'give 1,200,000 runs'),
    ({'rate_hz': 1e9}, [], 'rate_hz: is 1e+09; expected a sample rate from 0.01 to 100000'),
    ({'rate_hz': 1e5, 'scenario_duration': 1000.0}, [], 'samples'),
    ({'vary': {'bodies.store.mass': {'uniform': [-1e308, 1e308]}}}, [],
     'its draws overflow'),
    ({'vary': {'bodies.store.mass': {'normal': [0.0, 1e307]}}}, [], 'its draws overflow'),
    ({'metrics': {'at': [{'time': 0.1, 'body': 'store'}, {'time': 0.1, 'body': 'store'}]}},
     [], 'metrics.at[1]: is the same as metrics.at[0]'),
    ({'vary': {'bodies.store.' + 'x' * 500: {'uniform': [1.0, 2.0]}}}, [], 'bodies.store.x'),
    ({'metrics': {'at': [{'time': 1e308, 'body': 'store'}]}}, [],
     'metrics.at[0].time: is 1e+308 s, sample inf'),
])
def test_sweep_limits_are_refused_before_anything_runs(tmp_path, capsys, settings, argv, words):
    settings = dict(settings)
    scenario = None
    duration = settings.pop('scenario_duration', None)
    if duration is not None:
        from sweeps import STORE
        scenario = dict(STORE, duration=duration)
    runs = settings.pop('runs', 3)
    path = write_sweep(tmp_path, runs=runs, scenario=scenario,
                       **{'metrics': AT, **settings})
    outdir = tmp_path / 'out'
    assert cli.main(['sweep', path, '-o', str(outdir), '--workers', '1', *argv]) == 2
    captured = capsys.readouterr()
    error = [line for line in captured.err.splitlines() if line.startswith('ERROR: ')]
    assert len(error) == 1 and words in error[0], captured.err
    assert len(error[0]) < 600 and 'Traceback' not in captured.err
    assert not outdir.exists()
