# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A CG dispersion as one key path (SPEC section 10): ``bodies.<body>.cg_offset``.

A store hangs on a hinge and is released when it has turned 20 deg; a sweep
moves its CG. Each run's release time must be the exact compound-pendulum
time for the moved CG (hinge where it was, inertia about the actual CG):
t = integral of d(alpha) / sqrt(2 k (sin theta0 - sin(theta0 + alpha))).
"""

import json
import math

from cfem_ros.study import Sweep
from cfem_ros.study.reliability import distribution
from cfem_ros.study.sensitivity import problem
from cfem_ros.study.spec import load_sweep
import numpy as np
import pytest
from scipy.integrate import quad
from sweeps import write_sweep

MASS, IYY, G = 230.0, 95.0, 9.80665
RELEASE = math.radians(20.0)
NOMINAL = np.array([-1.0, 0.0, 0.0])   # the nominal CG from the hinge, m

HINGED = {
    'gravity': [0, 0, -G], 'duration': 0.45, 'dt': 0.001,
    'bodies': {'pylon': {'fixed': True},
               'store': {'mass': MASS, 'inertia': [4.1, IYY, IYY],
                         'position': NOMINAL.tolist(), 'cg_offset': [0.0, 0.0, 0.0]}},
    'joints': {'pivot': {'type': 'hinge', 'parent': 'pylon', 'child': 'store',
                         'anchor': [0, 0, 0], 'axis': [0, 1, 0],
                         'release': {'angle_deg': 20}}},
}


def pendulum_release_time(offset) -> float:
    """Return the time the moved CG's compound pendulum takes to turn RELEASE from rest."""
    r = NOMINAL + np.asarray(offset, dtype=float)      # the hinge stays at the origin
    d = float(np.hypot(r[0], r[2]))
    theta0 = math.atan2(r[2], r[0])                     # the CG's angle in the x-z plane
    k = MASS * G * d / (IYY + MASS * d * d)
    sense = 1.0 if r[0] < 0 else -1.0                   # which way it falls: down

    def drop(alpha):   # sin(theta0) - sin(theta): the CG's fall over d
        return math.sin(theta0) - math.sin(theta0 + sense * alpha)

    # alpha = u^2 takes the integrable 1/sqrt(alpha) of the start away
    value, _ = quad(lambda u: 2 * u / math.sqrt(2 * k * drop(u * u)) if u > 0 else
                    2 / math.sqrt(2 * k * abs(math.cos(theta0))),
                    0.0, math.sqrt(RELEASE), epsabs=1e-14, epsrel=1e-14, limit=200)
    return value


def test_a_cg_offset_sweep_releases_when_the_moved_pendulum_says(tmp_path):
    offsets = [[0.0, 0.0, 0.0], [0.15, 0.0, 0.0], [-0.2, 0.0, 0.0], [0.05, 0.0, 0.12]]
    path = write_sweep(tmp_path, runs=1, scenario=HINGED,
                       vary={'bodies.store.cg_offset': {'grid': offsets}},
                       metrics={'clearance': [], 'at': []})
    table = Sweep.from_file(path).run(None)
    assert list(table['status']) == ['ok'] * len(offsets)
    times = table['release_pivot_time'].to_numpy()
    want = [pendulum_release_time(o) for o in offsets]
    np.testing.assert_allclose(times, want, rtol=0, atol=1e-9)
    assert np.ptp(want) > 0.01   # the CG's place matters: no run could pass by accident
    # the column holds each run's offset (as text: a list is not a number)
    assert [json.loads(v) for v in table['bodies.store.cg_offset']] == offsets


def test_rare_event_and_sobol_take_a_cg_offset_component_as_one_key_path(tmp_path):
    path = write_sweep(tmp_path, runs=4, scenario=HINGED,
                       vary={'bodies.store.cg_offset[0]': {'normal': [0.0, 0.05]}},
                       metrics={'clearance': [], 'at': []},
                       criteria={'early': 'release_pivot_time >= 0.2'})
    spec = load_sweep(path)
    assert problem(spec, 'sobol')['names'] == ['bodies.store.cg_offset[0]']
    assert distribution(spec).getDimension() == 1
    row = Sweep.from_file(path).run(None).iloc[0]
    offset = row['bodies.store.cg_offset[0]']
    assert row['release_pivot_time'] == pytest.approx(
        pendulum_release_time([offset, 0.0, 0.0]), abs=1e-9)
