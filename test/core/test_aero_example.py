# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The near-pylon example: its synthetic tables are the generator's, and it runs."""

import importlib.util
import pathlib

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.scenario.parse import load_scenario
from cfem_ros.study.spec import load_sweep
import numpy as np
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[2]
CONFIG = ROOT / 'config'


def generator():
    spec = importlib.util.spec_from_file_location(
        'make_synthetic_aero_tables', ROOT / 'examples' / 'make_synthetic_aero_tables.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_shipped_tables_are_the_generators(tmp_path, capsys):
    make = generator()
    assert make.main([str(tmp_path)]) == 0
    assert (tmp_path / make.TABLE).read_text() == (CONFIG / make.TABLE).read_text()
    aero = yaml.safe_load((CONFIG / 'store_release_near_pylon.yaml').read_text())['aero']
    for key, value in make.tables().items():
        np.testing.assert_array_equal(aero['store'][key], value, err_msg=key)
    assert 'SYNTHETIC' in (CONFIG / make.TABLE).read_text().splitlines()[0]


def test_the_example_runs_and_its_sweep_measures_after_release():
    model = load_scenario(str(CONFIG / 'store_release_near_pylon.yaml'), duration=0.3)
    a = model.aero[0]
    assert len(a.mach) == 4 and a.proximity.axes == ('dx', 'dz', 'dtheta_deg', 'mach')
    sim = Simulator(model)
    assert sim.advance_to(0.3) and sim.status == 'running'
    store = model.body_index('store')
    assert sim.position[store][2] > 0.2   # it left the pylon, no contact
    spec = load_sweep(str(CONFIG / 'sweeps' / 'store_release_near_pylon_sweep.yaml'), runs=1)
    assert [d.window.start.release for d in spec.metrics.distance] == ['hooks', 'hooks']
