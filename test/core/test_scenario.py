# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Bad scenarios are refused before anything runs, naming file, key, value and fix."""

import copy
import pathlib

from cfem_ros import cli
import pytest
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
BASE = yaml.safe_load((CONFIG / 'double_pendulum.yaml').read_text())


def edited(change):
    doc = copy.deepcopy(BASE)
    change(doc)
    return doc


def setter(path, value):
    def change(doc):
        *parents, last = path.split('.')
        node = doc
        for key in parents:
            node = node[key]
        node[last] = value
    return change


def deleter(path):
    def change(doc):
        *parents, last = path.split('.')
        node = doc
        for key in parents:
            node = node[key]
        del node[last]
    return change


CASES = [
    ('unknown top key', setter('gravty', [0, 0, -9.8]), 'gravty', 'unknown key'),
    ('unknown body key', setter('bodies.A.mas', 3), 'bodies.A.mas', 'unknown key'),
    ('missing mass', deleter('bodies.A.mass'), 'bodies.A.mass', 'missing'),
    ('missing joint type', deleter('joints.elbow.type'), 'joints.elbow.type', 'missing'),
    ('wrong type', setter('dt', 'fast'), 'dt', 'a number'),
    ('bool as number', setter('bodies.A.mass', True), 'bodies.A.mass', 'a number'),
    ('wrong length', setter('gravity', [0, -9.8]), 'gravity', 'a list of 3 numbers'),
    ('non-finite', setter('bodies.B.position', [0, float('nan'), 0]), 'bodies.B.position[1]',
     'finite'),
    ('infinite', setter('duration', float('inf')), 'duration', 'finite'),
    ('zero mass', setter('bodies.A.mass', 0), 'bodies.A.mass', '> 0'),
    ('negative mass', setter('bodies.A.mass', -1), 'bodies.A.mass', '> 0'),
    ('inertia not positive', setter('bodies.A.inertia', [1, 1, -1]), 'bodies.A.inertia',
     'positive definite'),
    ('inertia triangle', setter('bodies.A.inertia', [1, 1, 3]), 'bodies.A.inertia',
     'triangle inequality'),
    ('inertia length', setter('bodies.A.inertia', [1, 1, 1, 0]), 'bodies.A.inertia',
     '3 or 6'),
    ('zero axis', setter('joints.elbow.axis', [0, 0, 0]), 'joints.elbow.axis', 'zero length'),
    ('universal not perpendicular', setter('joints.shoulder.axis2', [1, 1, 0]),
     'joints.shoulder.axis2', 'perpendicular'),
    ('unknown body', setter('joints.elbow.child', 'C'), 'joints.elbow.child', 'not a body'),
    ('joint on one body', setter('joints.elbow.child', 'A'), 'joints.elbow.child',
     'same body'),
    ('unknown joint type', setter('joints.elbow.type', 'weld'), 'joints.elbow.type',
     'one of fixed, hinge'),
    ('missing axis', deleter('joints.elbow.axis'), 'joints.elbow.axis', 'missing'),
    ('axis2 on hinge', setter('joints.elbow.axis2', [0, 0, 1]), 'joints.elbow.axis2',
     'only on universal'),
    ('bad release key', setter('joints.elbow.release', {'angle': 10}),
     'joints.elbow.release.angle', 'unknown key'),
    ('negative release', setter('joints.elbow.release', {'time': -1}),
     'joints.elbow.release.time', '>= 0'),
    ('bad name', setter('bodies', {'my body': {'fixed': True}, 'A': BASE['bodies']['A']}),
     'bodies.my body', 'usable name'),
    ('both orientations', lambda d: d['bodies']['A'].update(
        orientation_xyzw=[0, 0, 0, 1], orientation_rpy_deg=[0, 0, 0]),
     'bodies.A.orientation_xyzw', 'one of the two'),
    ('quaternion norm', setter('bodies.A.orientation_xyzw', [0, 0, 0, 2]),
     'bodies.A.orientation_xyzw', 'unit quaternion'),
    ('unstable baumgarte', setter('baumgarte', 5000), 'baumgarte', 'stability'),
    ('velocity on fixed body', setter('bodies.O.velocity', [1, 0, 0]), 'bodies.O.velocity',
     'fixed body'),
    ('all fixed', setter('bodies', {'O': {'fixed': True}}), 'bodies', 'nothing can move'),
]


@pytest.mark.parametrize('label, change, key, words', CASES, ids=[c[0] for c in CASES])
def test_bad_scenario_exits_2_with_file_key_and_fix(tmp_path, capsys, label, change, key,
                                                    words):
    path = tmp_path / 'bad.yaml'
    path.write_text(yaml.safe_dump(edited(change)))
    out = tmp_path / 'out.mcap'
    assert cli.main(['run', str(path), '-o', str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith('ERROR: ') and err.count('\n') == 1, err
    assert f'{path}: {key}' in err, err
    assert words in err, err
    assert 'Traceback' not in err
    assert not out.exists()                     # nothing ran, nothing written
    assert cli.main(['check', str(path)]) == 2


def test_duplicate_names_are_refused(tmp_path, capsys):
    path = tmp_path / 'dup.yaml'
    text = (CONFIG / 'store_separation.yaml').read_text()
    path.write_text(text.replace('joints:\n', 'joints:\n  pivot:\n    type: ball\n'
                                 '    parent: pylon\n    child: store\n    anchor: [0, 0, 0]\n'))
    assert cli.main(['check', str(path)]) == 2
    err = capsys.readouterr().err
    assert "duplicate key 'pivot'" in err and str(path) in err


@pytest.mark.parametrize('text, words', [
    ('bodies: [1, 2', 'not valid YAML'),
    ('- just\n- a list\n', 'a mapping'),
    ('', 'a mapping'),
])
def test_unreadable_documents(tmp_path, capsys, text, words):
    path = tmp_path / 'x.yaml'
    path.write_text(text)
    assert cli.main(['check', str(path)]) == 2
    assert words in capsys.readouterr().err


def test_missing_file(tmp_path, capsys):
    assert cli.main(['check', str(tmp_path / 'nope.yaml')]) == 2
    assert 'cannot read the file' in capsys.readouterr().err


def test_every_shipped_scenario_checks(capsys):
    for path in sorted(CONFIG.rglob('*.yaml')):
        if path.name.endswith('.params.yaml') or 'sweeps' in path.parts \
                or path.name.startswith('fit_') or 'scenario' in yaml.safe_load(path.read_text()):
            # node parameters; sweep, fit and prediction files, which name their scenario
            # (test/study checks them)
            continue
        assert cli.main(['check', str(path)]) == 0, path
        out = capsys.readouterr().out
        assert 'degrees of freedom' in out
