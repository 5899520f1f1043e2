# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""A task's models, parsed once and varied in place, are the whole parse's to the bit."""

import copy
import dataclasses
import os

from cfem_ros.core.rotations import from_rpy_deg
from cfem_ros.study import Sweep
from cfem_ros.study.runmodels import full_model, Models
from cfem_ros.study.runs import run_rows
import numpy as np
import pandas as pd
import pytest
from sweeps import STORE, write_sweep

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def same(a, b, where='model'):
    """Assert two parsed models (dataclasses, arrays, tuples) are equal to the bit."""
    assert type(a) is type(b), where
    if dataclasses.is_dataclass(a):
        for f in dataclasses.fields(a):
            same(getattr(a, f.name), getattr(b, f.name), f'{where}.{f.name}')
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, where
        assert a.tobytes() == b.tobytes(), where
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f'{where}[{i}]')
    elif isinstance(a, dict):
        assert list(a) == list(b), where
        for key in a:
            same(a[key], b[key], f'{where}.{key}')
    elif isinstance(a, float):
        assert np.float64(a).tobytes() == np.float64(b).tobytes(), where
    else:
        assert a == b, where


def check_models(spec):
    models = Models(spec)
    for k in range(spec.total):
        values = spec.run_values(k)
        try:
            whole = full_model(spec, k, values)
        except Exception as err:   # noqa: B902
            with pytest.raises(type(err)) as caught:
                models.model(k, values)
            assert str(caught.value) == str(err)
            continue
        same(models.model(k, values), whole)
    return models


def test_varied_bodies_and_joints_are_parsed_alone_and_give_the_whole_parse(tmp_path):
    # mass, a joint's anchor and release angle in place; dt by a whole parse per value
    spec = Sweep.from_file(write_sweep(tmp_path, runs=4)).spec
    models = check_models(spec)
    assert models.touched == [('bodies', 'store'), ('joints', 'pivot')]
    assert [v.path for v in models.slow] == ['dt']
    assert len(models._bases) == 2   # one whole parse per dt


def test_the_example_sweep_and_the_ejectors_give_the_whole_parse(tmp_path):
    spec = Sweep.from_file(os.path.join(ROOT, 'config', 'sweeps',
                                        'store_separation_sweep.yaml'), runs=3).spec
    check_models(spec)
    scenario = os.path.join(ROOT, 'config', 'store_separation_ejectors.yaml')
    sweep = tmp_path / 'ejectors.yaml'
    sweep.write_text(
        f'scenario: {scenario}\nruns: 3\nvary:\n'
        '  bodies.store.inertia[1]: {uniform: [480, 500]}\n'
        '  bodies.store.orientation_rpy_deg: {choice: [[0, 1, 0], [0, -1, 0]]}\n'
        '  wrenches[1].force[2]: {normal: [42703, 500]}\n'
        'metrics: {clearance: [{bodies: [store, pylon]}]}\n')
    models = check_models(Sweep.from_file(str(sweep)).spec)
    # a force drawn: the wrenches parsed again with the body, no whole parse
    assert models.touched == [('bodies', 'store'), ('wrenches', '')]
    assert len(models._bases) == 1
    sweep.write_text(sweep.read_text().replace('{normal: [42703, 500]}',
                                               '{choice: [42000, 43000]}'))
    models = check_models(Sweep.from_file(str(sweep)).spec)
    assert models.touched == [('bodies', 'store'), ('wrenches', '')]
    # a wrench's body, frame and table too; a value the wrench refuses gets the whole
    # parse's message
    sweep.write_text(sweep.read_text().replace(
        '  wrenches[1].force[2]: {choice: [42000, 43000]}\n',
        '  wrenches[1].force[2]: {choice: [42000, 43000]}\n'
        '  wrenches[0].frame: {choice: [store, world, pylon]}\n'
        '  wrenches[0].force[0]: {grid: [0.0, 1.0e3, .nan]}\n'))
    spec = Sweep.from_file(str(sweep)).spec
    models = check_models(spec)
    assert models.touched == [('bodies', 'store'), ('wrenches', '')]
    messages = {r['message'] for r in run_rows(spec, range(spec.total)) if r['message']}
    assert any('wrenches[0].force' in m for m in messages), messages


def test_random_masses_inertias_anchors_axes_and_forces_give_the_whole_parse(tmp_path):
    # the quick checks (plain floats, the triad, a diagonal inertia without eigvalsh, the
    # attitude computed once) on many random draws: field for field, bit for bit
    scenario = copy.deepcopy(STORE)
    store = scenario['bodies']['store']
    store.update(orientation_rpy_deg=[0, 2, 0], angular_velocity_deg=[0, 1, 0],
                 shape={'cylinder': [0.25, 2.5]})
    scenario['wrenches'] = [
        {'name': 'forward', 'body': 'store', 'point': [0.1798, 0, -0.25],
         'force': [0, 0, 10676], 'frame': 'pylon', 'stroke': 0.1006, 'reacts_on': 'pylon'},
        {'name': 'aft', 'body': 'store', 'point': [-0.3292, 0, -0.25],
         'force': [0, 0, 42703], 'moment': [0, 10, 0], 'start': 0.01, 'end': 0.3}]
    path = write_sweep(tmp_path, runs=300, scenario=scenario, vary={
        'bodies.store.mass': {'normal': [907.1848, 10.0]},
        'bodies.store.inertia[0]': {'uniform': [20, 30]},
        'bodies.store.inertia[2]': {'normal': [488.0944, 5.0]},
        'bodies.store.orientation_rpy_deg[1]': {'choice': [-2, 0, 2.5]},
        'joints.pivot.anchor[0]': {'truncnormal': [-0.3292, 0.01, -0.35, -0.31]},
        'joints.pivot.anchor[2]': {'uniform': [-0.26, -0.24]},
        'joints.pivot.axis[0]': {'normal': [0.0, 0.5]},
        'joints.pivot.axis[1]': {'normal': [1.0, 0.5]},
        'joints.pivot.axis[2]': {'normal': [0.0, 0.5]},
        'wrenches[0].force[2]': {'normal': [10676, 500]},
        'wrenches[1].force[0]': {'normal': [0.0, 100.0]},
        'wrenches[1].force[2]': {'normal': [42703, 2000]}})
    spec = Sweep.from_file(path).spec
    models = Models(spec)
    assert models.touched == [('bodies', 'store'), ('joints', 'pivot'), ('wrenches', '')]
    assert not models.slow
    models.full = None   # every run parsed in place: no whole parse to fall back on
    triads = set()
    for k in range(spec.total):
        values = spec.run_values(k)
        model = models.model(k, values)
        same(model, full_model(spec, k, values), f'run {k}')
        rpy = [0, values['bodies.store.orientation_rpy_deg[1]'], 0]   # not the cached one
        assert model.bodies[1].orientation_xyzw.tobytes() == from_rpy_deg(rpy).tobytes()
        triads.add(int(np.argmin(np.abs(model.joints[0].triad[0]))))
    assert triads == {0, 1, 2}   # the helper axis of the triad took every world axis
    assert len(models._bases) == 1


def test_invalid_values_give_the_whole_parse_message(tmp_path):
    scenario = copy.deepcopy(STORE)
    path = write_sweep(tmp_path, runs=1, scenario=scenario, vary={
        'bodies.store.mass': {'grid': [907.1848, -5.0, 'heavy']},
        'joints.pivot.axis': {'grid': [[0, 1, 0], [0, 0, 0]]},
        'bodies.store.fixed': {'grid': [False, True]}})
    spec = Sweep.from_file(path).spec
    check_models(spec)
    rows = run_rows(spec, range(spec.total), threads=2)
    assert [r['status'] for r in rows].count('ok') == 1
    assert 'bodies.store.mass: is -5' in rows[4]['message']
    assert 'joints.pivot.axis: has zero length' in rows[2]['message']


def test_a_run_the_sweep_does_not_have_is_said_as_such_not_as_a_full_disk(tmp_path):
    # only a recording that cannot be written is "could not be written ... free some space"
    spec = Sweep.from_file(write_sweep(tmp_path, runs=1)).spec
    with pytest.raises(IndexError):
        run_rows(spec, [spec.total + 5])


def test_the_table_is_the_same_on_any_number_of_threads(tmp_path):
    sweep = Sweep.from_file(write_sweep(tmp_path, runs=5))
    one = sweep.run(None, str(tmp_path / 'one'), threads=1)
    two = sweep.run(None, str(tmp_path / 'two'), threads=3)
    pd.testing.assert_frame_equal(one, two, check_exact=True)
    single = pd.DataFrame.from_records([sweep.run_one(k) for k in range(sweep.total)],
                                       columns=sweep.columns())
    pd.testing.assert_frame_equal(one, single, check_exact=True)


def test_a_value_set_where_an_alias_points_shows_in_both_places(tmp_path):
    # one list in two places (written as a YAML anchor and alias): the whole parse
    # sets both, so every run is parsed whole
    scenario = copy.deepcopy(STORE)
    store, pivot = scenario['bodies']['store'], scenario['joints']['pivot']
    store['velocity'] = store['position']
    store['angular_velocity'] = pivot['axis']
    for vary in ({'bodies.store.position[0]': {'uniform': [0.0, 0.01]}},
                 {'joints.pivot.axis[2]': {'uniform': [0.0, 0.01]}}):
        path = write_sweep(tmp_path, runs=2, scenario=scenario, vary=vary)
        assert '&' in (tmp_path / 'scenario.yaml').read_text()
        models = check_models(Sweep.from_file(path).spec)
        assert models.touched == []
    values = models.spec.run_values(0)
    model = models.model(0, values)
    assert model.bodies[1].rates_body[2] == values['joints.pivot.axis[2]'] != 0.0
    assert model.joints[0].triad[0, 2] > 0.0


def test_a_varied_value_is_set_on_copies_and_the_base_document_is_kept(tmp_path):
    spec = Sweep.from_file(write_sweep(tmp_path, runs=3, vary={
        'joints.pivot.anchor[0]': {'uniform': [-0.34, -0.32]},
        'joints.pivot.release.angle_deg': {'choice': [8, 12]},
        'bodies.store.inertia': {'choice': [[27, 488, 488], [28, 490, 490]]}})).spec
    base = copy.deepcopy(spec.document)
    models = check_models(spec)
    assert models.touched == [('bodies', 'store'), ('joints', 'pivot')]
    assert spec.document == base
    [(document, _)] = models._bases.values()   # the task's parsed base: kept as it was
    assert document == base
