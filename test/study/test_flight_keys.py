# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Every ``flight.*`` key is a sweep key path, and grids of conditions run (SPEC section 14)."""

import math

from cfem_ros.core.scenario.checker import Checker
from cfem_ros.core.scenario.flight import FLIGHT_KEYS, parse_flight
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.study.errors import SweepError
from cfem_ros.study.spec import load_sweep
from cfem_ros.study.sweep import Sweep
import pytest
from sweeps import write_sweep

G = 9.80665
MASS = 907.1848


def _scenario(speed_key='mach', duration=0.05):
    """Return a store on a fixed hook at the CG of an aircraft flying a condition."""
    return {
        'duration': duration, 'dt': 0.001,
        'flight': {'carrier': 'aircraft', speed_key: 0.8 if speed_key == 'mach' else 250.0,
                   'altitude': 3000.0, 'load_factor': 2.0},
        'bodies': {
            'aircraft': {'position': [0.0, 0.0, 0.0]},
            'tanker': {'mass': 5000.0, 'inertia': [1e4, 2e4, 2e4], 'position': [0, 40.0, 0]},
            'store': {'mass': MASS, 'inertia': [27.1164, 488.0944, 488.0944],
                      'position': [0.0, 0.0, 0.0]}},
        'joints': {'hook': {'type': 'fixed', 'parent': 'aircraft', 'child': 'store',
                            'anchor': [0.0, 0.0, 0.2]}},
    }


#: Each key of flight: the grid a sweep gives it, and what the parsed condition holds then.
GRIDS = {
    'carrier': (['aircraft', 'tanker'], lambda f: f.carrier),
    'mach': ([0.6, 0.95], lambda f: f.mach),
    'airspeed': ([180.0, 290.0], lambda f: f.airspeed),
    'altitude': ([1500.0, 9000.0], lambda f: f.altitude),
    'temperature_offset': ([-10.0, 15.0], lambda f: f.temperature_offset),
    'flight_path_deg': ([-30.0, 20.0], lambda f: math.degrees(f.flight_path)),
    'load_factor': ([1.0, 3.0], lambda f: f.load_factor),
    'roll_rate_deg_s': ([0.0, 30.0], lambda f: math.degrees(f.roll_rate)),
    'alpha_deg': ([0.0, 4.0], lambda f: math.degrees(f.alpha)),
}


def test_the_test_names_every_key_of_flight():
    assert set(GRIDS) == set(FLIGHT_KEYS)


@pytest.mark.parametrize('key', sorted(GRIDS))
def test_every_flight_key_is_a_sweep_key_path(tmp_path, key):
    """A grid of the key gives runs whose scenarios fly each of its values."""
    values, held = GRIDS[key]
    scenario = _scenario('airspeed' if key == 'airspeed' else 'mach')
    if key == 'carrier':   # either flies; the other falls free (its mass ignored if it flies)
        scenario['bodies']['aircraft'].update(mass=5000.0, inertia=[1e4, 2e4, 2e4])
    path = write_sweep(tmp_path, runs=1, scenario=scenario,
                       vary={f'flight.{key}': {'grid': values}}, metrics={})
    spec = load_sweep(path)
    assert spec.total == len(values)
    for k, value in enumerate(values):
        document = spec.run_document(k)
        flown = parse_flight(Checker('test'), document)
        if isinstance(value, str):
            assert held(flown) == value
        else:
            assert held(flown) == pytest.approx(value, rel=1e-12, abs=1e-12)
        parse_scenario(document)   # and the whole scenario is accepted with it


def test_a_grid_of_conditions_runs_each_condition(tmp_path):
    """
    Mach x load factor in vary: each run flies its own condition.

    The store sits at the carrier's CG on a fixed hook, no aero. From level
    flight the path turns at q = g (n - 1) / V, so at gamma = q t the hook
    carries m g (n - 1 + cos(gamma)) normal to the path and m g sin(gamma)
    along it: the load is m n g at t = 0 and falls after it (for n >= 1), so
    the run's largest load is m n g, whatever the Mach number; the store
    goes round the arc of radius V / q that Mach number and n give.
    """
    from cfem_ros.core.native.atmosphere import isa
    duration = 0.05
    path = write_sweep(tmp_path, runs=1, scenario=_scenario(duration=duration), rate_hz=100,
                       vary={'flight.mach': {'grid': [0.6, 0.95]},
                             'flight.load_factor': {'grid': [1.0, 3.0]}},
                       metrics={'at': [{'time': duration, 'body': 'store'}]})
    table = Sweep(load_sweep(path)).run(None, str(tmp_path / 'out'), threads=1)
    assert len(table) == 4 and (table['status'] == 'ok').all()
    seen = set()
    for _, row in table.iterrows():
        mach, n = row['flight.mach'], row['flight.load_factor']
        seen.add((mach, n))
        assert row['peak_force_hook'] == pytest.approx(MASS * n * G, rel=1e-9)
        speed = mach * isa(3000.0)[1]    # the arc flown at this Mach number, climb z-
        q = G * (n - 1.0) / speed
        x = speed * duration if q == 0 else math.sin(q * duration) / q * speed
        z = 0.0 if q == 0 else (math.cos(q * duration) - 1.0) / q * speed
        assert row[f'store_at_{duration}_x'] == pytest.approx(x, abs=1e-6)
        assert row[f'store_at_{duration}_z'] == pytest.approx(z, abs=1e-6)
    assert seen == {(0.6, 1.0), (0.6, 3.0), (0.95, 1.0), (0.95, 3.0)}


def test_a_key_that_conflicts_with_the_scenario_whatever_its_value_is_refused(tmp_path):
    """Sweeping airspeed over a scenario that gives mach refuses the file, not each run."""
    path = write_sweep(tmp_path, runs=1, scenario=_scenario('mach'), metrics={},
                       vary={'flight.airspeed': {'grid': [180.0, 290.0]}})
    with pytest.raises(SweepError, match=r'vary\.flight\.airspeed: is not in .*scenario\.yaml, '
                       r'and with it flight\.airspeed is given together with mach: every run '
                       r'would be refused; expected one of mach or airspeed'):
        load_sweep(path)
