# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""A sweep's aero scales and deltas, set on tables read once, give the whole parse to the bit."""

import copy
import os

from cfem_ros.core.scenario import aeroparse
from cfem_ros.study import Sweep
from cfem_ros.study.runmodels import Models
from cfem_ros.study.runs import run_rows
import pandas as pd
from test_sweep_models import check_models
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
NEAR_PYLON = os.path.join(ROOT, 'config', 'store_release_near_pylon.yaml')


def near_pylon(folder, vary, runs=4, change=None, seed=3):
    """Write a sweep of the near-pylon store (its scenario changed by change) in folder."""
    scenario = NEAR_PYLON
    if change is not None:
        with open(NEAR_PYLON) as stream:
            document = yaml.safe_load(stream)
        proximity = document['aero']['store']['proximity']
        proximity['table'] = os.path.join(os.path.dirname(NEAR_PYLON), proximity['table'])
        change(document)
        scenario = os.path.join(str(folder), 'scenario.yaml')
        with open(scenario, 'w') as stream:
            yaml.safe_dump(document, stream)
    path = os.path.join(str(folder), 'sweep.yaml')
    with open(path, 'w') as stream:
        yaml.safe_dump({'scenario': scenario, 'runs': runs, 'seed': seed, 'vary': vary,
                        'metrics': {'distance': [{'bodies': ['store', 'pylon']}]}}, stream)
    return Sweep.from_file(path).spec


def test_the_shipped_near_pylon_sweep_reads_its_tables_once_per_base(monkeypatch):
    spec = Sweep.from_file(os.path.join(ROOT, 'config', 'sweeps',
                                        'store_release_near_pylon_sweep.yaml'), runs=6).spec
    reads = []
    read = aeroparse.read_columns
    monkeypatch.setattr(aeroparse, 'read_columns', lambda *a: reads.append(a) or read(*a))
    models = Models(spec)
    assert ('aero', 'store') in models.touched and [v.path for v in models.slow] == ['dt']
    for k in range(spec.total):
        models.model(k, spec.run_values(k))
    # the base per dt, parsed and its aero read unscaled: 2 reads each, not one per run
    assert len(models._bases) == 2 and len(reads) == 4 < spec.total
    check_models(spec)


def test_scales_deltas_and_a_moved_cg_give_the_whole_parse(tmp_path):
    def change(document):
        entry = document['aero']['store']
        entry['reference_point'] = [0.2, 0.0, 0.0]
        entry['delta'] = {'Cm': 0.0}
        entry['Cmq'] = -0.0   # a signed zero scaled and shifted as the whole parse does
        entry['scale'] = {'Cm': 1.0, 'dCX': 1.0, 'Cmq': 1.0}
        document['bodies']['store']['cg_offset'] = [0.0, 0.0, 0.0]

    vary = {'aero.store.scale.Cm': {'uniform': [-1.0, 2.0]},
            'aero.store.scale.dCX': {'normal': [1.0, 0.3]},
            'aero.store.scale.Cmq': {'choice': [0.5, -2.0]},
            'aero.store.delta.Cm': {'uniform': [-0.01, 0.01]},
            'bodies.store.cg_offset[0]': {'uniform': [-0.05, 0.05]}}
    models = check_models(near_pylon(tmp_path, vary, runs=12, change=change))
    assert models.touched == []   # a CG offset drawn: every run parsed whole
    vary['bodies.store.cg_offset[0]'] = {'choice': [-0.05, 0.05]}
    spec = near_pylon(tmp_path, vary, runs=12, change=change)
    models = check_models(spec)
    assert models.touched == [('aero', 'store')]
    assert [v.path for v in models.slow] == ['bodies.store.cg_offset[0]']
    cg = spec.run_values(0)['bodies.store.cg_offset[0]']
    model = models.model(0, spec.run_values(0))
    assert model.aero[0].reference_from_cg[0] == 0.2 - cg   # the CG moved, the point kept


def test_a_refused_value_and_an_altitude_beyond_the_atmosphere_are_the_whole_parse_s(tmp_path):
    # the store moved out of ISA (z down: -1e6 m is up), then an increment scaled
    # without a proximity table: each refused with the whole parse's message
    spec = near_pylon(tmp_path, {'aero.store.scale.dCZ': {'choice': [2.0]},
                                 'bodies.store.position[2]': {'choice': [0.0, -1e6]}},
                      runs=2)
    assert check_models(spec).touched == [('aero', 'store'), ('bodies', 'store')]
    rows = run_rows(spec, range(spec.total))
    assert [r['status'] for r in rows].count('ok') == 1
    assert 'puts store at 1.00792e+06 m' in ''.join(r['message'] for r in rows)

    def change(document):
        del document['aero']['store']['proximity']
        document['aero']['store']['scale'] = {'Cm': 1.0}

    spec = near_pylon(tmp_path, {'aero.store.scale.dCZ': {'choice': [1.0]},
                                 'aero.store.scale.Cm': {'uniform': [0.0, 1.0]}},
                      runs=2, change=change)
    check_models(spec)
    rows = run_rows(spec, range(spec.total))
    assert all('aero.store.scale.dCZ: scales an increment' in r['message'] for r in rows)


def test_a_near_pylon_sweep_s_rows_are_those_of_its_runs_parsed_whole(tmp_path, monkeypatch):
    spec = near_pylon(tmp_path, {'aero.store.scale.Cm': {'uniform': [0.5, 1.5]},
                                 'aero.store.scale.dCm': {'uniform': [0.0, 3.0]},
                                 'wrenches[1].force[2]': {'uniform': [0, 48000]},
                                 'dt': {'grid': [0.001, 0.002]}}, runs=3)
    fast = pd.DataFrame(run_rows(spec, range(spec.total)))
    monkeypatch.setattr(Models, 'model', Models.full)
    whole = pd.DataFrame(run_rows(copy.deepcopy(spec), range(spec.total)))
    assert (fast['status'] == 'ok').sum() >= 1
    pd.testing.assert_frame_equal(fast, whole, check_exact=True)
