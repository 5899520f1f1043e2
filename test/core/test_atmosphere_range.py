# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""A body beyond the standard atmosphere (issue 52 item 11): refused at t = 0, told in a run."""

import math

from cfem_ros import cli, Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.native.atmosphere import STANDARD_RANGE
from cfem_ros.core.scenario.parse import parse_scenario
import pytest
import yaml

G0 = 9.80665


def store(z, velocity=(250.0, 0, 0), duration=0.5) -> dict:
    """Return a store at z (world, z down) whose tables give no load: it flies ballistic."""
    return {'gravity': [0, 0, G0], 'duration': duration, 'dt': 0.001,
            'bodies': {'store': {'mass': 230.0, 'inertia': [4.1, 95.0, 95.0],
                                 'position': [0, 0, z], 'velocity': list(velocity)}},
            'aero': {'store': {'area': 0.03, 'length': 0.2, 'altitude': 1000.0,
                               'alpha_deg': [-180, 180],
                               'zero': ['CX', 'CY', 'CZ', 'Cl', 'Cm', 'Cn']}}}


@pytest.mark.parametrize('z, at', [(-40500.0, '41500 m'), (29500.0, '-28500 m')])
def test_a_body_beyond_the_standard_atmosphere_at_t0_is_refused(z, at):
    # the cases: 41.5 km up and 28.5 km below sea level ran in an extrapolated air
    with pytest.raises(ScenarioError) as err:
        parse_scenario(store(z), source='high.yaml')
    assert err.value.key == 'bodies.store.position'
    assert err.value.problem.startswith(f'puts store at {at} (aero.store.altitude 1000 m')
    assert 'from -5000 to 32000 m' in err.value.expected


@pytest.mark.parametrize('z, climb, level', [(-30950.0, 400.0, 32000.0),
                                             (5950.0, -400.0, -5000.0)])
def test_leaving_it_in_a_run_is_an_event_at_the_instant(tmp_path, capsys, z, climb, level):
    # ballistic (no aero load): the altitude 1000 - z(t), z(t) = z0 - climb t + g t^2 / 2,
    # reaches the standard's end at the root of a quadratic
    start = 1000.0 - z
    a, b, c = -G0 / 2, climb, start - level
    t_cross = min(r for r in ((-b + s * math.sqrt(b * b - 4 * a * c)) / (2 * a) for s in (1, -1))
                  if r > 0)
    sim = Simulator(parse_scenario(store(z, (0, 0, -climb))))
    assert sim.advance_to(0.5)
    event, = [e for e in sim.events if e['event'].startswith('atmosphere')]
    assert event['event'] == 'atmosphere_outside' and event['body'] == 'store'
    assert (event['altitude'], event['low'], event['high']) == (level,) + STANDARD_RANGE
    # the cubic Hermite between two looks is exact for a fall at constant acceleration
    assert event['time'] == pytest.approx(t_cross, abs=1e-9)
    assert event['inside_at'] <= event['time'] <= event['seen_at']
    # the run says it, with the air's fate
    path = tmp_path / 'climb.yaml'
    path.write_text(yaml.safe_dump(store(z, (0, 0, -climb))))
    assert cli.main(['run', str(path), '-o', str(tmp_path / 'climb.mcap')]) == 0
    out = capsys.readouterr().out
    assert f'atmosphere_outside store at t = {t_cross:.9f} s: beyond {level:g} m' in out
    assert 'last layer continued' in out


def test_a_body_that_comes_back_is_told_too():
    # thrown up through 32 km and falling back: out, then in, each at its instant
    sim = Simulator(parse_scenario(store(-30950.0, (0, 0, -460.0), duration=95.0)))
    assert sim.advance_to(95.0)
    kinds = [(e['event'], e['altitude']) for e in sim.events if e['event'].startswith('atm')]
    assert kinds == [('atmosphere_outside', 32000.0), ('atmosphere_inside', 32000.0)]
    up, down = (e['time'] for e in sim.events if e['event'].startswith('atm'))
    apex = 460.0 / G0
    assert up + down == pytest.approx(2 * apex, abs=1e-9)   # symmetric about the apex
