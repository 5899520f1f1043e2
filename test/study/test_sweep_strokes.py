# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Sweeps' end-of-stroke columns (SPEC section 7)."""

import math
import pathlib

from cfem_ros import load_scenario, Simulator
from cfem_ros.core.engine.events import describe_event
from cfem_ros.recording.analysis import open_run
from cfem_ros.study import Sweep
from cfem_ros.study.labels import unit
from cfem_ros.study.metrics import compute, from_run
import numpy as np
import pytest
from sweeps import write_sweep
import yaml

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / 'config' / 'store_release_two_hooks.yaml'


def test_sweeps_add_the_end_of_stroke_columns(tmp_path):
    scenario = yaml.safe_load(EXAMPLE.read_text())
    scenario['duration'] = 0.25
    scenario['release_groups']['station_1']['release'] = {'time': 0.05}
    del scenario['aero']
    path = write_sweep(tmp_path, runs=1, vary={'bodies.store.mass': {'grid': [907.1848]}},
                       metrics={'clearance': [], 'at': []}, scenario=scenario)
    sweep = Sweep.from_file(path)
    table = sweep.run(None, str(tmp_path / 'out'), record='all')
    row = table.iloc[0]
    names = [f'stroke_aft_ejector_{s}' for s in ('time', 'u', 'v', 'w', 'p', 'q', 'r')]
    assert set(names) <= set(table.columns)
    sim = Simulator(load_scenario(path.replace('sweep.yaml', 'scenario.yaml')))
    session_events = []
    assert sim.advance_to(0.25)
    session_events = {e['wrench']: e for e in sim.events if e['event'] == 'stroke_end'}
    aft = session_events['aft_ejector']
    # the event keeps rad/s (SPEC 7); the table's rates are deg/s, as the export's _p, _q, _r
    # and the log line (the case: q in rad/s in one table and deg/s in the next)
    assert [row[n] for n in names] == pytest.approx(
        [aft['time']] + aft['velocity'] + list(np.degrees(aft['rates'])), rel=1e-12, abs=1e-12)
    assert aft['rates'][1] > 0.5 and row['stroke_aft_ejector_q'] > 0.5 * 180 / math.pi
    assert [unit(f'stroke_aft_ejector_{s}') for s in 'pqr'] == ['deg/s'] * 3
    p, q, r = (row[f'stroke_aft_ejector_{s}'] for s in 'pqr')
    line = describe_event(aft)
    assert line.endswith(f'p, q, r = {p:.2f}, {q:.2f}, {r:.2f} deg/s') and 'rad' not in line
    # the run's recording gives the same columns
    run = open_run(str(tmp_path / 'out' / 'runs' / 'run_0.mcap'))
    again = compute(from_run(run), sweep.spec.metrics)
    assert [again[n] for n in names] == [row[n] for n in names]
    # a stroke that never ends: NaN
    scenario['release_groups']['station_1']['release'] = {'time': 0.24}
    path = write_sweep(tmp_path, runs=1, vary={}, metrics={'clearance': [], 'at': []},
                       scenario=scenario)
    late = Sweep.from_file(path).run(None).iloc[0]
    assert all(math.isnan(late[n]) for n in names)
