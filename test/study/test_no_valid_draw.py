# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A sweep whose every draw is invalid (issue 52 item 9): said, never a traceback or exit 0.

Every draw of a negative store mass is refused by the scenario's checks:
no run is made, there is nothing to estimate, plot or report. ``sweep``
(with criteria and a target, or without), ``plot`` and ``report`` each
end with one ``ERROR:`` line naming the sweep's ``vary`` and the check's
reason, exit 2, and no estimate is written.
"""

import os

from cfem_ros import cli
from cfem_ros.study import Sweep
import pandas as pd
import pytest
from sweeps import write_sweep

NEGATIVE = {'bodies.store.mass': {'uniform': [-10.0, -5.0]}}


def _folder(tmp_path, **extra):
    """Return (sweep file, its folder with every run done: all invalid)."""
    path = write_sweep(tmp_path, runs=3, vary=NEGATIVE, **extra)
    out = str(tmp_path / 'out')
    table = Sweep.from_file(path).run(None, out)
    assert (table['status'] == 'invalid').all() and len(table) == 3
    return path, out


def _said(capsys, code):
    printed = capsys.readouterr()
    lines = [line for line in printed.err.splitlines() if line.startswith('ERROR:')]
    assert code == 2, printed
    assert len(lines) == 1, printed.err
    assert 'Traceback' not in printed.err
    return lines[0]


@pytest.mark.parametrize('extra', [{'criteria': {'miss': 'clearance_store_pylon_min >= 0.01'},
                                    'target': 1e-3}, {}], ids=['criteria', 'none'])
def test_sweep_plot_and_report_say_no_draw_is_valid(tmp_path, capsys, extra):
    path, out = _folder(tmp_path, **extra)
    # the sweep again: every run is in the folder, the table is printed, then the refusal
    line = _said(capsys, cli.main(['sweep', path, '-o', out, '--workers', '1']))
    assert 'vary' in line and 'no valid draw' in line and 'mass' in line, line
    assert line.count('3') >= 1 and 'bodies.store.mass' in line, line
    assert not os.path.exists(os.path.join(out, 'estimate.json'))
    assert len(pd.read_parquet(os.path.join(out, 'results.parquet'))) == 3   # kept
    for argv in (['plot', out, '-o', str(tmp_path / 'figures')],
                 ['report', out, '-o', str(tmp_path / 'report.html')]):
        line = _said(capsys, cli.main(argv))
        assert 'no valid draw' in line and 'mass' in line, (argv, line)
    assert not os.path.exists(tmp_path / 'report.html')
