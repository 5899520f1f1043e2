# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Hostile scenario files and values out of range are refused in one clear line, quickly."""

import copy
import logging
import os
import pathlib
import subprocess
import sys
import warnings

from cfem_ros import cli, parse_scenario
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio import textfile, yamlfile
from cfem_ros.core.scenario import bodies, checker, parse as scenario
import numpy as np
import pytest
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
BASE = yaml.safe_load((CONFIG / 'double_pendulum.yaml').read_text())


def doc_with(path, value):
    """Return a copy of the double pendulum with the entry at dotted path set to value."""
    doc = copy.deepcopy(BASE)
    *parents, last = path.split('.')
    node = doc
    for key in parents:
        node = node[key]
    node[last] = value
    return doc


def refused(document, words, **overrides):
    """Parse and return the one-line message, which must hold words."""
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(document, source='s.yaml', **overrides)
    message = str(caught.value)
    assert '\n' not in message and len(message) < 600, message
    assert words in message, message
    return message


def bomb(levels=9):
    lines = ['a0: &a0 [x, x, x, x, x, x, x, x, x]']
    for i in range(1, levels):
        lines.append(f'a{i}: &a{i} [' + ', '.join([f'*a{i - 1}'] * 9) + ']')
    return '\n'.join(lines) + '\nbodies: {}\n'


# ------------------------------------------------------------------ the loader

@pytest.mark.parametrize('loader', yamlfile.LOADERS, ids=lambda c: c.__name__)
@pytest.mark.parametrize('text, words', [
    (bomb(), 'aliases expand to more than 1,000,000 values'),
    ('bodies: ' + '[' * 100_000, 'nested deeper than 64 levels'),
    ('bodies: ' + '{a: ' * 65 + '1' + '}' * 65, 'nested deeper than 64 levels'),
    ('bodies: &x\n  A: *x\n', 'refers to a collection that contains it'),
    ('bodies:\n  ? [1]\n  : 2\n', 'a list is used as a mapping key'),
    ('bodies:\n  ? {a: 1}\n  : 2\n', 'a dict is used as a mapping key'),
    ('bodies: {}\nbodies: {}\n', "duplicate key 'bodies'"),
    ('dt: ' + '9' * 5000 + '\nbodies: {}\n', 'more than 4300 digits'),
    ('dt: 2001-13-45\nbodies: {}\n', 'a value cannot be read'),
    ('a: 1\n---\nb: 2\n', 'not valid YAML'),
    ('bodies: "\x00"\n', 'not valid YAML'),
])
def test_loader_bounds(loader, text, words):
    with pytest.raises(ScenarioError) as caught:
        yamlfile.load_yaml(text, 'f.yaml', loader=loader)
    message = str(caught.value)
    assert message.startswith('f.yaml: ') and words in message, message
    assert '\n' not in message and len(message) < 400, message


@pytest.mark.parametrize('loader', yamlfile.LOADERS, ids=lambda c: c.__name__)
def test_loaders_agree_on_a_shipped_file_and_on_bounded_aliases(loader):
    text = (CONFIG / 'store_separation.yaml').read_text()
    assert yamlfile.load_yaml(text, loader=loader) == yaml.safe_load(text)
    small = bomb(6)                           # 9^6 = 531,441 values: within the bound
    assert yamlfile.load_yaml(small, loader=loader) == yaml.safe_load(small)
    merged = 'a: &a {x: 1}\nb: {<<: *a, y: 2}\n'
    assert yamlfile.load_yaml(merged, loader=loader) == {'a': {'x': 1}, 'b': {'x': 1, 'y': 2}}


def test_files_that_are_not_readable_scenarios(tmp_path):
    def message(path):
        with pytest.raises(ScenarioError) as caught:
            scenario.load_scenario(str(path))
        text = str(caught.value)
        assert text.startswith(f'{path}: ') and '\n' not in text, text
        return text

    assert 'is a directory' in message(tmp_path)
    fifo = tmp_path / 'fifo.yaml'
    os.mkfifo(fifo)
    assert 'named pipe' in message(fifo)      # refused without opening: never blocks
    assert 'is a device' in message('/dev/zero')
    big = tmp_path / 'big.yaml'
    with open(big, 'wb') as stream:
        stream.truncate(textfile.MAX_FILE_BYTES + 1)
    assert '16 MiB' in message(big)
    binary = tmp_path / 'bin.yaml'
    binary.write_bytes(b'bodies:\n  A: \xff\xfe\n')
    assert 'line 2: byte 13 (0xff) is not UTF-8' in message(binary)
    assert 'cannot read the file' in message(tmp_path / 'missing.yaml')
    odd = tmp_path / 'new\nline.yaml'
    odd.write_text('bodies: [')
    with pytest.raises(ScenarioError) as caught:
        scenario.load_scenario(str(odd))
    assert repr(str(odd)) in str(caught.value) and '\n' not in str(caught.value)


# -------------------------------------------------------- physical plausibility

@pytest.mark.parametrize('path, value, words', [
    ('bodies.A.mass', 1e-320, 'a mass from 1e-06 to 1e+12 kg'),
    ('bodies.A.mass', 1e308, 'a mass from 1e-06 to 1e+12 kg'),
    ('bodies.A.mass', 10 ** 400, 'too large for a double'),
    ('bodies.A.inertia', [1e-13, 1e-13, 1e-13], 'principal moments from 1e-12'),
    ('bodies.A.inertia', [1e19, 1e19, 1e19], 'a magnitude of at most 1e+18'),
    ('bodies.A.inertia', [1, 1, 1, float('nan'), 0, 0], 'finite'),
    ('bodies.A.inertia', [1, 1, 1, 1, 1, 1], 'not positive definite'),
    ('bodies.B.position', [0, 1e10, 0], 'a magnitude of at most 1e+09'),
    ('bodies.B.velocity', [-1e300, 0, 0], 'a magnitude of at most 1e+09'),
    ('gravity', [0, 0, 1e300], 'a magnitude of at most 1e+09'),
    ('joints.elbow.axis', [0, float('inf'), 0], 'finite'),
    ('joints.elbow.axis', [1e-13, 0, 0], 'zero length'),
    ('dt', 1e-17, 'a step of at least 1e-09 s'),
    ('duration', 1e7, 'at most 1e+09 steps'),
    ('baumgarte', 1e308, 'stability'),
    ('name', 'two\nlines', 'printable'),
    ('name', 'x' * 201, 'at most 200'),
    ('frame_id', 'w' * 65, 'at most 64 characters'),
])
def test_out_of_range_values_are_refused(path, value, words):
    refused(doc_with(path, value), words)


def test_overrides_are_bounded_too():
    refused(BASE, '--dt: is 1e-12 s', dt=1e-12)
    refused(BASE, '--duration: is 1e+08 s', duration=1e8)
    refused(BASE, 'a number', dt='1')


def test_bounds_themselves_are_accepted():
    doc = doc_with('bodies.A.mass', bodies.MASS_RANGE[0])
    doc['bodies']['B']['mass'] = bodies.MASS_RANGE[1]
    doc['bodies']['A']['inertia'] = [1e-12, 1e-12, 1e-12]
    doc['bodies']['B']['inertia'] = [1e18, 1e18, 1e18]
    doc['dt'] = 1e-9
    doc['duration'] = 1.0
    model = parse_scenario(doc)
    assert model.bodies[1].mass == 1e-6 and model.bodies[2].mass == 1e12


def test_huge_axis_is_normalised_without_overflow():
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        model = parse_scenario(doc_with('joints.elbow.axis', [0, 1e200, 0]))
        tiny = parse_scenario(doc_with('joints.elbow.axis', [0, 3e-12, 0]))
        huge = parse_scenario(doc_with('joints.elbow.axis', [0, 1.7e308, 1.7e308]))
    np.testing.assert_array_equal(model.joints[1].triad[0], [0.0, 1.0, 0.0])
    np.testing.assert_array_equal(tiny.joints[1].triad[0], [0.0, 1.0, 0.0])
    np.testing.assert_allclose(huge.joints[1].triad[0], [0, 0.5 ** 0.5, 0.5 ** 0.5],
                               rtol=1e-15)


@pytest.mark.parametrize('name, words', [
    ('A\n', 'is not a usable name'),
    ('A\r', 'is not a usable name'),
    ('A' * 65, 'has 65 characters'),
    ('x' * 100_000, 'has 100000 characters'),
])
def test_names_the_node_cannot_use_are_refused(name, words):
    doc = copy.deepcopy(BASE)
    doc['bodies'] = {name if k == 'A' else k: v for k, v in doc['bodies'].items()}
    message = refused(doc, words)
    assert len(message) < 400
    doc = copy.deepcopy(BASE)
    doc['joints'] = {name if k == 'elbow' else k: v for k, v in doc['joints'].items()}
    refused(doc, words)


def test_longest_name_is_accepted():
    name = 'A' * checker.MAX_NAME_LENGTH
    doc = copy.deepcopy(BASE)
    doc['bodies'] = {name if k == 'A' else k: v for k, v in doc['bodies'].items()}
    for joint in doc['joints'].values():
        for end in ('parent', 'child'):
            joint[end] = name if joint[end] == 'A' else joint[end]
    assert parse_scenario(doc).bodies[1].name == name
    # the node's longest topic stays far below ROS's 247-character limit
    assert len(f'/cfem/bodies/{name}/applied/{name}') <= 150


def test_a_body_named_like_the_world_frame_is_refused():
    doc = copy.deepcopy(BASE)
    doc['bodies']['world'] = {'fixed': True}
    refused(doc, 'bodies.world: has the name of the world frame (frame_id)')
    doc['frame_id'] = 'map'
    assert parse_scenario(doc).frame_id == 'map'


def test_mass_on_a_fixed_body_is_ignored_with_a_warning(caplog):
    doc = doc_with('bodies.O', {'fixed': True, 'mass': 5.0, 'inertia': [1, 1, 1]})
    with caplog.at_level(logging.WARNING, logger='cfem_ros'):
        model = parse_scenario(doc, source='s.yaml')
    assert model.bodies[0].mass == 0.0 and not model.bodies[0].inertia.any()
    assert 's.yaml: bodies.O: mass and inertia ignored' in caplog.text


def test_unhashable_values_in_joints_are_refused():
    refused(doc_with('joints.elbow.type', ['hinge']), "joints.elbow.type: is ['hinge']")
    refused(doc_with('joints.elbow.parent', {'A': 1}), 'is not a body')
    refused(doc_with('joints.elbow.child', [1, 2]), 'is not a body')


def test_long_lists_in_messages_are_clipped():
    message = refused(doc_with('gravity', list(range(100_000))), 'a list of 3 numbers')
    assert len(message) < 300
    many = {f'B{i}': {'fixed': True} for i in range(1000)}
    many.update(BASE['bodies'])
    doc = copy.deepcopy(BASE)
    doc['bodies'] = many
    doc['joints']['elbow']['child'] = 'nobody'
    assert '(and 995 more)' in refused(doc, 'not a body')


# ------------------------------------------------------------------ the CLI

def test_check_prints_no_numpy_warning(tmp_path, capsys):
    path = tmp_path / 'axis.yaml'
    path.write_text(yaml.safe_dump(doc_with('joints.elbow.axis', [0, 1e200, 0])))
    assert cli.main(['check', str(path)]) == 0
    assert capsys.readouterr().err == ''


def hostile_files(folder: pathlib.Path):
    """Write one file of each hostile kind; return their paths."""
    files = {
        'bomb.yaml': bomb(),
        'deep.yaml': 'bodies: ' + '[' * 200_000,
        'garbage.yaml': '\x01\x02: [}{',
        'empty.yaml': '',
    }
    paths = []
    for name, text in files.items():
        (folder / name).write_text(text)
        paths.append(folder / name)
    (folder / 'latin1.yaml').write_bytes('bodies: {\u00e9: 1}'.encode('latin-1'))
    os.mkfifo(folder / 'pipe.yaml')
    (folder / 'dir.yaml').mkdir()
    return paths + [folder / 'latin1.yaml', folder / 'pipe.yaml', folder / 'dir.yaml',
                    pathlib.Path('/dev/zero')]


def test_cfem_sim_check_refuses_hostile_files_quickly(tmp_path):
    for path in hostile_files(tmp_path):
        done = subprocess.run([sys.executable, '-m', 'cfem_ros.cli', 'check', str(path)],
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 2, (path, done.stderr)
        assert done.stderr.startswith(f'ERROR: {path}: '), done.stderr
        assert done.stderr.count('\n') == 1 and len(done.stderr) < 400, done.stderr
        assert 'Traceback' not in done.stderr and done.stdout == ''
