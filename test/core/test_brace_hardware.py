# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Sway braces as hardware (SPEC section 11, issue 45.1, 52.2): pads fixed on the carrier."""

import pathlib

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.scenario.parse import parse_scenario
import pytest
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'


def two_hooks_released(duration=3.0) -> dict:
    """The two-hook example released at 0.1 s, its aero block removed (issue 45.1)."""
    doc = yaml.safe_load((CONFIG / 'store_release_two_hooks.yaml').read_text())
    doc.pop('aero')
    doc['duration'] = duration
    doc['release_groups']['station_1']['release'] = {'time': 0.1}
    return doc


def test_no_pad_touches_the_store_again_once_it_falls_clear():
    sim = Simulator(parse_scenario(two_hooks_released(), source='two_hooks.yaml'))
    assert sim.advance_to(3.0), sim.message
    contacts = [e for e in sim.events if e['event'] == 'brace_contact']
    # each of the four pads lets go once, within the ejectors' stroke, and never touches again
    assert sorted(e['brace'] for e in contacts) == sorted(
        ['fwd_left', 'fwd_right', 'aft_left', 'aft_right'])
    assert all(not e['contact'] and 0.1 < e['time'] < 0.2 for e in contacts)
    assert sim.position[2][2] > 40.0   # m: it fell clear (z down)


def test_a_pad_pointing_out_of_the_store_is_refused_with_its_key_path():
    doc = two_hooks_released()
    doc['sway_braces'][0]['direction'] = [0, -0.5736, -0.8192]
    with pytest.raises(ScenarioError) as err:
        parse_scenario(doc, source='two_hooks.yaml')
    text = str(err.value)
    assert 'sway_braces[0].direction' in text and 'towards the carrier' in text, text


@pytest.mark.parametrize('which, stiffness, damping, key, said', [
    (None, 1.0e9, 2.0e3, 'sway_braces[0].stiffness', 'is 1e+09 N/m (damping 2000 N s/m)'),
    (None, 5.0e6, 1.0e9, 'sway_braces[0].damping', 'is 1e+09 N s/m (stiffness 5e+06 N/m)'),
    # one pad too stiff (or too damped) among four of the example's: that pad, that key
    (2, 1.0e9, None, 'sway_braces[2].stiffness', 'is 1e+09 N/m'),
    (3, None, 1.0e9, 'sway_braces[3].damping', 'is 1e+09 N s/m'),
])
def test_braces_rk4_cannot_follow_are_refused_with_the_dt_that_would_do(
        which, stiffness, damping, key, said):
    doc = two_hooks_released(duration=0.3)
    for k, brace in enumerate(doc['sway_braces']):
        if which is None or k == which:
            brace.update({n: v for n, v in (('stiffness', stiffness), ('damping', damping))
                          if v is not None})
    with pytest.raises(ScenarioError) as err:
        parse_scenario(doc, source='two_hooks.yaml')
    text = str(err.value)
    # the case: a damping of 1e9 was refused as sway_braces[0].stiffness
    assert err.value.key == key and err.value.problem.startswith(said), text
    assert ('less damped pad' if key.endswith('damping') else 'softer pad') in text, text
    assert 'expected dt <=' in text, text
    would = float(text.split('expected dt <= ')[1].split(' s')[0])
    doc['dt'] = would
    doc['duration'] = min(0.3, 2000 * would)
    sim = Simulator(parse_scenario(doc, source='two_hooks.yaml'))
    assert sim.advance_to(doc['duration']), sim.message   # runs, and ends
    assert len([e for e in sim.events if e['event'] == 'brace_contact']) < 100


def test_a_brace_point_out_of_place_is_named_as_the_file_gives_it():
    doc = two_hooks_released()
    doc['bodies']['store']['cg_offset'] = [0.03, 0, 0.005]
    doc['sway_braces'][0]['point'] = [-0.35, 0, 0.4]
    with pytest.raises(ScenarioError) as err:
        parse_scenario(doc, source='two_hooks.yaml')
    assert '[-0.35, 0.0, 0.4]' in str(err.value), str(err.value)
