# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Property-based tests: any document or file is a Model or one clear ScenarioError.

Hypothesis generates malformed and borderline scenarios (wrong types and
lengths, NaN, huge and tiny numbers, hostile names, YAML aliases, garbage
bytes, redundant joints, parallel axes, masses far apart). The default run is
bounded for ``make test``; ``CFEM_LONG_TESTS=1`` runs many more examples.
"""

import copy
import os
import pathlib
import warnings

from cfem_ros import parse_scenario, Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio import yamlfile
from cfem_ros.core.model.joints import JOINT_TABLE
from cfem_ros.core.scenario import parse as scenario
from hypothesis import given, HealthCheck, settings, strategies as st
import pytest
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
SOURCES = [CONFIG / 'double_pendulum.yaml', CONFIG / 'store_separation.yaml',
           CONFIG / 'joints' / 'universal.yaml', CONFIG / 'joints' / 'planar.yaml']
TEXTS = [path.read_text() for path in SOURCES]
DOCS = [yaml.safe_load(text) for text in TEXTS]

LONG = os.environ.get('CFEM_LONG_TESTS') == '1'


def examples(n: int) -> settings:
    """Return bounded settings: n examples, 50 n with CFEM_LONG_TESTS=1."""
    return settings(max_examples=50 * n if LONG else n, deadline=None, derandomize=not LONG,
                    suppress_health_check=[HealthCheck.too_slow,
                                           HealthCheck.function_scoped_fixture])


def assert_clean(call):
    """Call; return the Model, or None after checking the ScenarioError's message."""
    with warnings.catch_warnings():
        warnings.simplefilter('error')            # no numpy RuntimeWarning may print
        try:
            return call()
        except ScenarioError as err:
            message = str(err)
    assert '\n' not in message and '\r' not in message, message
    assert len(message) <= 600, message
    return None


# ---------------------------------------------------------------- documents

numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e-320, 5e-324, 1e-12, 1e-7, 1e-6, 1e12, 1.1e12, 1e18,
                     1e19, 1e200, 1e308, 1.7976931348623157e308, 1e9, 1.000001e9]),
    st.integers(min_value=-10 ** 400, max_value=10 ** 400),
    st.integers(min_value=-3, max_value=3),
)
names = st.one_of(
    st.text(max_size=20),
    st.sampled_from(['world', 'A\n', 'A\r\n', 'O', 'A', 'B', 'pylon', 'store', 'x' * 65,
                     'x' * 300, '', '1a', 'a/b', 'a b', '_a']),
)
leaves = st.one_of(numbers, names, st.none(), st.booleans(), st.binary(max_size=8),
                   st.sampled_from(list(JOINT_TABLE) + ['weld', 'Hinge']))
values = st.recursive(
    leaves,
    lambda inner: st.one_of(st.lists(inner, max_size=7),
                            st.dictionaries(st.one_of(names, numbers, st.none()), inner,
                                            max_size=4)),
    max_leaves=12)


def paths(node, prefix=()):
    """Yield the path of every entry in a document."""
    items = node.items() if isinstance(node, dict) else (
        enumerate(node) if isinstance(node, list) else ())
    for key, child in items:
        yield prefix + (key,)
        yield from paths(child, prefix + (key,))


@st.composite
def mutated_documents(draw):
    """Return a shipped scenario with one to four entries replaced, removed or added."""
    doc = copy.deepcopy(draw(st.sampled_from(DOCS)))
    for _ in range(draw(st.integers(1, 4))):
        where = sorted(paths(doc), key=repr)
        if not where:
            break
        path = draw(st.sampled_from(where))
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        action = draw(st.sampled_from(['set', 'set', 'set', 'delete', 'add', 'deep']))
        if action == 'set':
            parent[path[-1]] = draw(values)
        elif action == 'delete':
            del parent[path[-1]]
        elif action == 'add' and isinstance(parent, dict):
            parent[draw(names)] = draw(values)
        elif action == 'deep':
            nested = draw(values)
            for _ in range(draw(st.integers(1, 200))):
                nested = [nested]
            parent[path[-1]] = nested
    return doc


@examples(200)
@given(doc=mutated_documents())
def test_parse_scenario_returns_a_model_or_one_clear_error(doc):
    assert_clean(lambda: parse_scenario(doc, source='fuzz.yaml'))


@examples(100)
@given(doc=st.one_of(values, st.dictionaries(st.sampled_from(scenario.TOP_KEYS), values)))
def test_arbitrary_values_as_documents(doc):
    assert_clean(lambda: parse_scenario(doc, source='fuzz.yaml'))


# -------------------------------------------------------------------- files

fragments = st.sampled_from([
    '&a ', '*a', '&b [*a, *a, *a, *a]', '<<: *a', '[', ']', '{', '}', ': ', '\n', '\n  ',
    '- ', '? ', '!!binary ', '!!set ', '!!python/object ', '.nan', '.inf', '-.inf', '1e999',
    '9' * 500, '2001-13-45', '~', '"\\x00"', '\t', '#', '---\n', '...', '%YAML 1.1\n',
    "'", '"', '|', '>', '\\', 'world', 'A\n', '0x1f', '0o17', '1_000', '::',
])


@st.composite
def mutated_texts(draw):
    """Return the bytes of a shipped scenario file with fragments and bytes spliced in."""
    text = draw(st.sampled_from(TEXTS))
    for _ in range(draw(st.integers(1, 6))):
        at = draw(st.integers(0, len(text)))
        cut = draw(st.integers(0, 12))
        piece = draw(st.one_of(fragments, st.text(max_size=6)))
        text = text[:at] + piece + text[at + cut:]
    data = text.encode('utf-8', 'surrogatepass')
    if draw(st.integers(0, 9)) == 0:
        at = draw(st.integers(0, len(data)))
        data = data[:at] + draw(st.binary(min_size=1, max_size=4)) + data[at:]
    return data


def alias_bomb(width: int, depth: int) -> bytes:
    lines = ['a0: &a0 [' + ', '.join(['x'] * width) + ']']
    for i in range(1, depth):
        lines.append(f'a{i}: &a{i} [' + ', '.join([f'*a{i - 1}'] * width) + ']')
    return ('\n'.join(lines) + '\nbodies: {}\n').encode()


files = st.one_of(
    mutated_texts(),
    st.binary(max_size=200),
    st.just(b''),
    st.builds(alias_bomb, st.integers(2, 12), st.integers(1, 12)),
    st.builds(lambda n, c: ('bodies: ' + c * n).encode(), st.integers(1, 3000),
              st.sampled_from(['[', '{a: ', '- ', '  - '])),
)


@pytest.fixture(scope='module')
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp('fuzz')


@examples(300)
@given(data=files)
def test_load_scenario_returns_a_model_or_one_clear_error(folder, data):
    path = folder / 'fuzz.yaml'
    path.write_bytes(data)
    assert_clean(lambda: scenario.load_scenario(str(path)))


@examples(100)
@given(data=files)
def test_both_loaders_agree(data):
    outcomes = []
    for loader in yamlfile.LOADERS:
        try:
            outcomes.append(('ok', yamlfile.load_yaml(data.decode('utf-8'), loader=loader)))
        except UnicodeDecodeError:
            return
        except ScenarioError as err:
            assert '\n' not in str(err) and len(str(err)) <= 600, str(err)
            outcomes.append(('error', None))
    # a document both accept is the same document; a bound refused by one is refused by both
    if all(kind == 'ok' for kind, _ in outcomes):
        assert all(repr(doc) == repr(outcomes[0][1]) for _, doc in outcomes)


# ------------------------------------------- accepted models run or fail cleanly

masses = st.one_of(st.sampled_from([1e-6, 1e-3, 1.0, 907.0, 1e6, 1e12]),
                   st.floats(1e-6, 1e12))
directions = st.one_of(
    st.sampled_from([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 1e200, 0], [1e-11, 0, 0],
                     [1, 1, 0], [0, 1, 1e-7]]),
    st.lists(st.floats(-1e3, 1e3), min_size=3, max_size=3))
coordinates = st.lists(st.floats(-10, 10), min_size=3, max_size=3)


@st.composite
def plausible_documents(draw):
    """Return a scenario of 2-4 bodies and 1-5 joints between random pairs: loops welcome."""
    count = draw(st.integers(2, 4))
    bodies = {'G': {'fixed': True}}
    for i in range(1, count):
        small, large = sorted(draw(st.lists(st.floats(1e-12, 1e6), min_size=2, max_size=2)))
        inertia = [small, large, large] if draw(st.booleans()) else [large, large, large]
        bodies[f'B{i}'] = {'mass': draw(masses), 'inertia': inertia,
                           'position': draw(coordinates),
                           'velocity': draw(coordinates),
                           'angular_velocity_deg': draw(coordinates)}
    names = list(bodies)
    joints = {}
    for j in range(draw(st.integers(1, 5))):
        parent, child = draw(st.lists(st.sampled_from(names), min_size=2, max_size=2,
                                      unique=True))
        kind = draw(st.sampled_from(sorted(JOINT_TABLE)))
        joint = {'type': kind, 'parent': parent, 'child': child,
                 'anchor': draw(coordinates), 'axis': draw(directions)}
        if kind == 'universal':
            joint['axis2'] = draw(st.one_of(directions, st.just(joint['axis'])))
        if draw(st.booleans()):
            joint['release'] = {'time': draw(st.floats(0, 0.06))}
        joints[f'J{j}'] = joint
    dt = draw(st.sampled_from([1e-4, 1e-3, 1e-2]))
    doc = {'duration': 0.05, 'dt': dt, 'bodies': bodies, 'joints': joints}
    if draw(st.booleans()):
        doc['baumgarte'] = draw(st.floats(0, 3.0)) / dt
    return doc


@examples(40)
@given(doc=plausible_documents())
def test_accepted_models_run_or_fail_cleanly(doc):
    model = assert_clean(lambda: parse_scenario(doc, source='fuzz.yaml'))
    if model is None:
        return
    sim = Simulator(model)
    ok = sim.advance_to(0.05)
    if ok:
        assert sim.status == 'running' and sim.t == pytest.approx(0.05, abs=1e-12)
    else:
        assert sim.status == 'failed' and sim.message, sim.message
