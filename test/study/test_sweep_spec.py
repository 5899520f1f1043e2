# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Sweep files: key paths, seeded draws, grids, and bad files refused with exit 2."""

import copy
import math
import os

from cfem_ros import cli
from cfem_ros.study.keypaths import parse_key_path, resolve
from cfem_ros.study.spec import load_sweep
import numpy as np
import pytest
from sweeps import STORE, VARY, write_sweep


def test_key_paths_address_dicts_by_key_and_lists_by_index():
    assert parse_key_path('wrenches[1].force[2]') == ('wrenches', 1, 'force', 2)
    assert parse_key_path('bodies.store.mass') == ('bodies', 'store', 'mass')
    for bad in ('', '.a', 'a..b', 'a[x]', '[1]', 'a b'):
        with pytest.raises(ValueError):
            parse_key_path(bad)
    document = {'wrenches': [{'force': [0, 0, 1]}, {'force': [0, 0, 2]}]}
    container, last, value, exists = resolve(document, parse_key_path('wrenches[1].force[2]'))
    assert (value, exists, last) == (2, True, 2)
    assert container is document['wrenches'][1]['force']


def test_values_go_into_a_copy_of_the_document(tmp_path):
    spec = load_sweep(write_sweep(tmp_path, runs=1, vary={
        'joints.pivot.anchor[2]': {'grid': [-0.3]},
        'joints.pivot.release.time': {'grid': [0.1]}}))   # a new key in a mapping
    out = spec.run_document(0)
    assert out['joints']['pivot']['anchor'] == [-0.3292, 0, -0.3]
    assert out['joints']['pivot']['release'] == {'angle_deg': 10, 'time': 0.1}
    assert spec.document == STORE


def test_draws_are_seeded_and_grids_multiply_the_runs(tmp_path):
    spec = load_sweep(write_sweep(tmp_path, runs=5, seed=3))
    assert spec.total == 10
    again = load_sweep(write_sweep(tmp_path, runs=5, seed=3))
    assert spec.values == again.values
    other = load_sweep(write_sweep(tmp_path, runs=5, seed=4))
    assert spec.values['bodies.store.mass'] != other.values['bodies.store.mass']
    # every grid point sees the same random draws
    assert spec.values['dt'] == [0.002] * 5 + [0.001] * 5
    mass = spec.values['bodies.store.mass']
    assert mass[:5] == mass[5:]
    # a variable's draws do not depend on the others
    alone = load_sweep(write_sweep(tmp_path, runs=5, seed=3, vary={
        'bodies.store.mass': VARY['bodies.store.mass']}))
    assert alone.values['bodies.store.mass'] == mass[:5]


def test_distributions_have_their_moments_and_bounds(tmp_path):
    n = 20000
    spec = load_sweep(write_sweep(tmp_path, runs=n, vary={
        'bodies.store.mass': {'normal': [900.0, 10.0]},
        'joints.pivot.release.angle_deg': {'uniform': [8, 12]},
        'joints.pivot.anchor[0]': {'truncnormal': [-0.33, 0.01, -0.335, -0.31]},
        'duration': {'choice': [0.5, 0.6]}}))
    mass = np.array(spec.values['bodies.store.mass'])
    assert abs(mass.mean() - 900.0) < 5 * 10.0 / np.sqrt(n)
    assert abs(mass.std() - 10.0) < 0.05 * 10.0
    angle = np.array(spec.values['joints.pivot.release.angle_deg'])
    assert angle.min() >= 8 and angle.max() < 12
    assert abs(angle.mean() - 10.0) < 5 * (4 / np.sqrt(12)) / np.sqrt(n)
    anchor = np.array(spec.values['joints.pivot.anchor[0]'])
    assert anchor.min() >= -0.335 and anchor.max() <= -0.31
    assert anchor.min() < -0.334   # the lower bound is where the density is highest
    choice = np.array(spec.values['duration'])
    assert set(choice) == {0.5, 0.6}
    assert abs((choice == 0.5).mean() - 0.5) < 0.02


@pytest.mark.parametrize('change, key', [
    ({'vary': {'bodies.rocket.mass': {'normal': [1, 1]}}}, 'vary.bodies.rocket.mass'),
    ({'vary': {'bodies.store.mas': {'normal': [900, 1]}}}, 'vary.bodies.store.mas'),   # typo
    ({'vary': {'joints.pivot.anchor[5]': {'grid': [0]}}}, 'vary.joints.pivot.anchor[5]'),
    ({'vary': {'bodies.store.mass': {'normal': [900, -1]}}}, 'vary.bodies.store.mass.normal'),
    ({'vary': {'bodies.store.mass': {'gauss': [900, 1]}}}, 'vary.bodies.store.mass.gauss'),
    ({'vary': {'joints.pivot.type': {'uniform': [0, 1]}}}, 'vary.joints.pivot.type'),
    ({'vary': {'a..b': {'grid': [1]}}}, 'vary.a..b'),
    ({'metrics': {'at': [{'time': 0.005, 'body': 'store'}]}}, 'metrics.at[0].time'),
    ({'metrics': {'clearance': [{'bodies': ['store', 'wing']}]}},
     'metrics.clearance[0].bodies[1]'),
    ({'runs': 0}, 'runs'),
    ({'rate': 50}, 'rate'),
])
def test_bad_sweep_files_exit_2_naming_the_key_path(tmp_path, capsys, change, key):
    path = write_sweep(tmp_path, **{k: v for k, v in change.items()
                                    if k in ('vary', 'metrics', 'runs')},
                       **{k: v for k, v in change.items()
                          if k not in ('vary', 'metrics', 'runs')})
    out = str(tmp_path / 'out')
    assert cli.main(['sweep', path, '-o', out]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith(f'ERROR: {path}: {key}:'), err
    assert 'expected' in err
    assert not os.path.exists(os.path.join(out, 'results.parquet'))


def test_an_invalid_base_scenario_is_refused_before_any_run(tmp_path, capsys):
    scenario = copy.deepcopy(STORE)
    scenario['bodies']['store']['mass'] = -1
    path = write_sweep(tmp_path, scenario=scenario)
    assert cli.main(['sweep', path, '-o', str(tmp_path / 'out')]) == 2
    err = capsys.readouterr().err
    assert 'scenario.yaml: bodies.store.mass: is -1' in err


def test_every_shipped_sweep_file_loads():
    folder = os.path.join(os.path.dirname(__file__), '..', '..', 'config', 'sweeps')
    paths = sorted(os.listdir(folder))
    assert paths
    for name in paths:
        spec = load_sweep(os.path.join(folder, name))
        grids = [len(v.params) for v in spec.variables if v.kind == 'grid']
        assert spec.total == spec.runs * math.prod(grids)
        # each shipped sweep varies its scenario: some of its first runs differ from it
        assert any(spec.run_document(k) != spec.document for k in range(min(spec.total, 3)))


@pytest.mark.parametrize('path, missing, there', [
    ('bodies.stor.mass', 'bodies.stor', 'bodies.pylon, bodies.store'),
    ('joints.pivot.relase.angle_deg', 'joints.pivot.relase',
     'joints.pivot.anchor, joints.pivot.axis, joints.pivot.child, joints.pivot.parent, '
     'joints.pivot.release, joints.pivot.type'),
])
def test_a_typo_inside_a_key_path_names_the_keys_there_are(tmp_path, capsys, path,
                                                           missing, there):
    sweep = write_sweep(tmp_path, vary={path: {'uniform': [1, 2]}})
    assert cli.main(['sweep', sweep, '-o', str(tmp_path / 'out')]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f'ERROR: {sweep}: vary.{path}: {missing} does not exist in the scenario; '
                   f'expected one of {there} (a key path to a value of the base scenario, '
                   'or a new key under one of its mappings)')


def test_a_sweep_file_that_is_not_yaml_points_to_section_6(tmp_path, capsys):
    write_sweep(tmp_path)
    bad = tmp_path / 'bad.yaml'
    bad.write_text('scenario: scenario.yaml\nvary:\n  a: {uniform: [1, 2]}\n  - x\n')
    assert cli.main(['sweep', str(bad), '-o', str(tmp_path / 'out')]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith(f'ERROR: {bad}: line 4, column 3: not valid YAML'), err
    assert err.endswith('expected a YAML mapping as in SPEC section 6 (key paths with '
                        "brackets in a [...] list must be quoted: ['wrenches[1].force[2]', "
                        'dt])'), err
    assert 'section 1' not in err


def test_summarize_names_an_unreadable_file_once(tmp_path, capsys):
    sweep = write_sweep(tmp_path)
    foreign = tmp_path / 'flight.mcap'
    foreign.write_text('not a recording')
    out = str(tmp_path / 'table.parquet')
    assert cli.main(['summarize', str(foreign), '--metrics', sweep, '-o', out]) == 1
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if str(foreign) in line]
    assert len(lines) == 1 and lines[0].count(str(foreign)) == 1, err
    assert lines[0].strip().startswith(f'{foreign}: '), err
