# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Aero that is complete (SPEC 10, ``zero:``) in a z-down world (SPEC 14), or refused."""

import copy

from cfem_ros import cli
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.scenario.aeroparse import AERO_COEFFICIENTS
from cfem_ros.core.scenario.parse import parse_scenario
import numpy as np
import pytest
import yaml

G0 = 9.80665

COMPLETE = {'area': 0.2027, 'length': 0.508, 'density': 0.5, 'alpha_deg': [-20, 0, 20],
            'CX': -0.3, 'CY': 0.01, 'CZ': [1.0, 0.0, -1.0], 'Cl': 0.002,
            'Cm': [0.5, 0.0, -0.5], 'Cn': 0.01}


def scenario(aero=None, **top):
    doc = {'gravity': [0, 0, G0], 'duration': 0.1,
           'bodies': {'store': {'mass': 230.0, 'inertia': [4.1, 95.0, 95.0],
                                'velocity': [250.0, 0, 0]}},
           'aero': {'store': copy.deepcopy(COMPLETE) if aero is None else aero}}
    doc.update(top)
    return {k: v for k, v in doc.items() if v is not None}


def without(*names, **more):
    spec = {k: v for k, v in copy.deepcopy(COMPLETE).items() if k not in names}
    spec.update(more)
    return spec


def refusal(doc) -> ScenarioError:
    with pytest.raises(ScenarioError) as err:
        parse_scenario(doc, source='s.yaml')
    return err.value


def test_a_complete_table_is_read():
    table = parse_scenario(scenario()).aero[0].coefficients
    np.testing.assert_array_equal(table[:, 0, 0, 4], [0.5, 0.0, -0.5])
    np.testing.assert_array_equal(table[1, 0, 0], [-0.3, 0.01, 0.0, 0.002, 0.0, 0.01])


def test_one_coefficient_left_out_is_refused_with_its_key_and_the_way_to_say_zero():
    # the case: an aero block with no Cm passed check as the complete file did
    err = refusal(scenario(without('Cm')))
    assert err.key == 'aero.store.Cm'
    assert 'zero' in err.problem and 'aero.store.zero: [Cm]' in err.expected


def test_every_coefficient_left_out_is_refused_in_one_message_naming_them_all():
    err = refusal(scenario(without(*AERO_COEFFICIENTS)))
    assert err.key == 'aero.store'
    assert 'CX, CY, CZ, Cl, Cm, Cn' in err.problem
    assert 'aero.store.zero: [CX, CY, CZ, Cl, Cm, Cn]' in err.expected
    # with some listed, the message lists the rest after them
    err = refusal(scenario(without('Cl', 'Cm', 'Cn', zero=['Cl'])))
    assert err.key == 'aero.store' and 'gives no Cm, Cn' in err.problem
    assert 'aero.store.zero: [Cl, Cm, Cn]' in err.expected


def test_coefficients_listed_in_zero_are_zero_and_the_rest_as_given():
    ours = parse_scenario(scenario(without('Cl', 'CY', zero=['Cl', 'CY']))).aero[0]
    full = parse_scenario(scenario()).aero[0]
    np.testing.assert_array_equal(ours.coefficients[..., [1, 3]], 0.0)
    np.testing.assert_array_equal(ours.coefficients[..., [0, 2, 4, 5]],
                                  full.coefficients[..., [0, 2, 4, 5]])


@pytest.mark.parametrize('zero, key, words', [
    ('Cm', 'aero.store.zero', 'a list'),
    (['Cm', 'CD'], 'aero.store.zero[1]', 'one of CX'),
    (['Cm', 'Cm'], 'aero.store.zero[1]', 'each coefficient once'),
])
def test_a_bad_zero_list_is_refused_with_its_key_path(zero, key, words):
    err = refusal(scenario(without('Cm', zero=zero)))
    assert err.key == key and words in str(err)


def test_a_coefficient_both_given_and_listed_in_zero_is_refused():
    err = refusal(scenario(without(zero=['Cl'])))
    assert err.key == 'aero.store.zero[0]'
    assert 'aero.store.Cl is given too' in err.problem and 'not both' in err.expected


@pytest.mark.parametrize('gravity, shown', [(None, 'missing'), ([0, 0, -G0], 'is [0, 0, ')])
def test_aero_in_a_z_up_world_is_refused_with_the_reason(gravity, shown):
    # the case: no gravity gave z-up gravity while every aero convention is z-down
    err = refusal(scenario(gravity=gravity))
    assert err.key == 'gravity' and err.problem.startswith(shown)
    assert 'z-down' in err.problem and f'[0, 0, {G0:g}]' in err.expected


@pytest.mark.parametrize('gravity', [[0, 0, G0], [0, 0, 0], [0, 0, 3.7]])
def test_aero_with_z_down_or_no_gravity_is_read(gravity):
    assert parse_scenario(scenario(gravity=gravity)).gravity.tolist() == gravity


def test_a_z_up_world_without_aero_keeps_its_default():
    doc = scenario(gravity=None, aero=None)
    del doc['aero']
    assert parse_scenario(doc).gravity.tolist() == [0, 0, -G0]


@pytest.mark.parametrize('command', ['check', 'run'])
@pytest.mark.parametrize('doc, key', [(scenario(without('Cm')), 'aero.store.Cm'),
                                      (scenario(gravity=None), 'gravity')])
def test_the_command_line_refuses_with_one_error_line(tmp_path, capsys, command, doc, key):
    path = tmp_path / 'incomplete.yaml'
    path.write_text(yaml.safe_dump(doc))
    args = [command, str(path)] + (['-o', str(tmp_path / 'r.mcap')] if command == 'run' else [])
    assert cli.main(args) == 2
    out, err = capsys.readouterr()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith('ERROR:') and f': {key}: ' in lines[0]
    assert 'Traceback' not in out + err
    assert not (tmp_path / 'r.mcap').exists()


def test_check_says_which_coefficients_the_scenario_makes_zero(tmp_path, capsys):
    # the case: a block without Cm had the same summary as the complete one
    path = tmp_path / 'store.yaml'
    path.write_text(yaml.safe_dump(scenario(without('Cm', zero=['Cm']))))
    assert cli.main(['check', str(path)]) == 0
    said = capsys.readouterr().out
    path.write_text(yaml.safe_dump(scenario()))
    assert cli.main(['check', str(path)]) == 0
    complete = capsys.readouterr().out
    assert 'zero (as the scenario says): Cm' in said and 'as the scenario says' not in complete
