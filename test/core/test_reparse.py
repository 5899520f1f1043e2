# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""scenario.reparse and the parts it is quick with: the whole parse's model, to the bit."""

import copy
import os

from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio.messages import show as _show
from cfem_ros.core.fileio.textfile import read_text
from cfem_ros.core.fileio.yamlfile import load_yaml
from cfem_ros.core.model.joints import triad_from_axes
from cfem_ros.core.scenario.bodies import INERTIA_RANGE, parse_inertia
from cfem_ros.core.scenario.checker import Checker
from cfem_ros.core.scenario.parse import parse_scenario, reparse
import numpy as np
import pytest

CONFIG = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__)))), 'config')


def base():
    path = os.path.join(CONFIG, 'store_separation.yaml')
    return load_yaml(read_text(path), source=path)


def test_a_body_and_a_joint_parsed_again_are_the_whole_parse():
    document = base()
    model = parse_scenario(document, source='base.yaml')
    edited = copy.deepcopy(document)
    edited['bodies']['store']['mass'] = 950.0
    edited['bodies']['store']['orientation_rpy_deg'] = [0, 3, 0]
    edited['joints']['pivot']['anchor'] = [-0.3, 0, -0.25]
    edited['joints']['pivot']['release'] = {'angle_deg': 11, 'time': 0.2}
    whole = parse_scenario(edited, source='run.yaml')
    again = reparse(model, edited, bodies=['store'], joints=['pivot'], source='run.yaml')
    assert repr(again) == repr(whole)   # every field, arrays printed in full below
    for mine, theirs in ((again.bodies[1], whole.bodies[1]),
                         (again.joints[0], whole.joints[0])):
        for name in vars(mine):
            a, b = getattr(mine, name), getattr(theirs, name)
            if isinstance(a, np.ndarray):
                assert a.tobytes() == b.tobytes(), name
    assert again.bodies[1].mass == 950.0 and again.joints[0].release.time == 0.2
    assert again.bodies[0] is model.bodies[0]   # the pylon was not parsed again
    assert again.name == 'store_separation'


def test_what_reparse_cannot_do_is_refused_with_the_key():
    document = base()
    model = parse_scenario(document, source='base.yaml')
    edited = copy.deepcopy(document)
    edited['bodies']['store']['fixed'] = True
    with pytest.raises(ScenarioError, match='bodies.store.fixed'):
        reparse(model, edited, bodies=['store'], source='run.yaml')
    edited = copy.deepcopy(document)
    edited['bodies']['store']['mass'] = -1.0
    with pytest.raises(ScenarioError, match='bodies.store.mass: is -1'):
        reparse(model, edited, bodies=['store'], source='run.yaml')


def numpy_triad(axis):
    """Return the joint triad as numpy computes it (the reference for the plain-float one)."""
    u1 = np.asarray(axis, dtype=float)
    u1 = u1 / np.linalg.norm(u1)
    helper = np.zeros(3)
    helper[int(np.argmin(np.abs(u1)))] = 1.0
    u2 = helper - u1 * (helper @ u1)
    u2 = u2 / np.linalg.norm(u2)
    return np.array([u1, u2, np.cross(u1, u2)])


def test_a_joint_triad_is_numpys_to_the_bit():
    rng = np.random.default_rng(5)
    axes = [[0, 1, 0], [0, -1, 0], [1, 1, 0], [1, 1, 1], [-0.0, 0.0, 2.0], [3e-12, 0, 0],
            [1e100, -1e99, 0]]
    for scale in (1e-9, 1.0, 1e9):
        for _ in range(3000):
            axis = rng.normal(size=3) * scale
            axis[rng.random(3) < 0.2] = rng.choice([0.0, -0.0, scale, -scale])  # ties, zeros
            if np.any(axis):
                axes.append(axis)
    for axis in axes:
        axis = np.asarray(axis, dtype=float)
        mine = triad_from_axes(axis)
        assert mine.dtype == np.float64 and mine.shape == (3, 3)
        assert mine.tobytes() == numpy_triad(axis).tobytes(), axis
        # any other array_like takes numpy's path: the same triad
        assert triad_from_axes(list(axis)).tobytes() == mine.tobytes()
    with np.errstate(invalid='ignore', divide='ignore'):
        assert np.isnan(triad_from_axes(np.zeros(3))).all()   # as numpy's path gives


def test_a_diagonal_inertia_is_checked_as_its_eigenvalues_are():
    # [a, b, c] is checked without eigvalsh, [a, b, c, 0, 0, 0] with it: the same verdicts
    # at the edges of the triangle inequality and of the range, the same tensor
    rng = np.random.default_rng(6)
    check = Checker('inertia.yaml')
    low, high = INERTIA_RANGE
    cases = [[1, 1, 2], [1, 2, 3.000000003], [1, 2, 3.000000004], [low, low, low],
             [low * 0.999, 1, 1], [high, high, high], [1e17, 1e17, high], [0, 1, 1],
             [27.1164, 488.0944, 488.0944]]
    for _ in range(3000):
        a, b = 10.0 ** rng.uniform(-12.2, 18.1, 2)
        c = (a + b) * rng.choice([1.0, 1 + 1e-9, 1 + 1.000001e-9, 1 + 0.999999e-9,
                                  rng.uniform(0.0, 1.0)])
        cases.append(list(rng.permutation([a, b, min(c, 2e18)])))
    accepted = 0
    for case in cases:
        outcomes = []
        for value in (case, case + [0.0, 0.0, 0.0]):
            try:
                outcomes.append(parse_inertia(check, value, 'bodies.store.inertia').tobytes())
            except ScenarioError as err:   # the message but for how the value is shown
                outcomes.append(str(err).replace(_show(value), 'the value'))
        assert outcomes[0] == outcomes[1], case
        accepted += isinstance(outcomes[0], bytes)
    assert 1000 < accepted < len(cases) - 500   # both verdicts, many times


def test_vectors_are_the_numbers_given_and_bad_ones_are_named_as_one_by_one():
    check = Checker('vectors.yaml')
    items = [0, -0.0, 1, 2.5, -1e9, 1e9, 10 ** 9, 1e-300, 0.1, 10 ** 10, 1e9 * (1 + 1e-15),
             10 ** 400, float('nan'), float('inf'), True, None, '1', np.float64(0.3),
             np.int64(4)]
    rng = np.random.default_rng(7)
    for _ in range(2000):
        value = [items[i] if i < len(items) else float(rng.normal() * 1e3)
                 for i in rng.integers(0, len(items) + 8, 3)]
        for limit in (1e9, None):
            try:
                expected = np.array([check.number(v, f'v[{i}]', limit=limit)
                                     for i, v in enumerate(value)])
            except ScenarioError as err:
                with pytest.raises(ScenarioError) as caught:
                    check.vector(value, 'v', limit=limit)
                assert str(caught.value) == str(err)
                continue
            got = check.vector(value, 'v', limit=limit)
            assert got.dtype == np.float64 and got.tobytes() == expected.tobytes(), value
            if limit is None and np.max(np.abs(got)) >= 1e-12:
                assert check.direction(value, 'v').tobytes() == expected.tobytes()
