# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The joint solve's memory: linear in the bodies for a tree, a model too large refused first."""

from cfem_ros.core.engine import topology
from cfem_ros.core.engine.bodies import state_views
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.scenario.parse import parse_scenario
import pytest


def chain(count: int, close: bool = False) -> dict:
    """Return a chain of count bodies held by fixed joints from the ground (a loop if close)."""
    bodies = {'ground': {'fixed': True}}
    joints = {}
    for i in range(count):
        bodies[f'b{i}'] = {'mass': 1.0, 'inertia': [0.1, 0.1, 0.1], 'position': [0, 0, i + 1.0]}
        joints[f'j{i}'] = {'type': 'fixed', 'parent': 'ground' if i == 0 else f'b{i - 1}',
                           'child': f'b{i}', 'anchor': [0, 0, i + 0.5]}
    if close:
        joints['closing'] = {'type': 'fixed', 'parent': f'b{count - 1}', 'child': 'ground',
                             'anchor': [0, 0, count + 0.5]}
    return {'duration': 0.01, 'dt': 0.001, 'gravity': [0, 0, 9.8], 'bodies': bodies,
            'joints': joints}


def test_a_tree_s_workspace_is_linear_in_the_bodies():
    # issue 41.6: a dense (m, m) part made 8.6 GiB at 4,000 bodies (m = 24,000)
    sizes = {}
    for count in (400, 800):
        sim = Simulator(parse_scenario(chain(count)))
        assert sim.topology.dense == 0
        sizes[count] = sim.topology.system.work.nbytes
    assert sizes[800] < 2.1 * sizes[400]
    assert sizes[800] < 3000 * 8 * 800      # a few thousand numbers a body (m x m: 36 MiB)


def test_a_model_too_large_for_memory_is_refused_with_its_size(monkeypatch):
    monkeypatch.setattr(topology, 'memory_limit', lambda: 64e6)
    with pytest.raises(topology.ModelTooLarge, match=r'401 bodies, 2406 constraint rows '
                       r'\(closed loops: a dense m x m solve\) need 0\.\d+ GiB'):
        Simulator(parse_scenario(chain(400, close=True)))
    # the same bodies as a tree fit
    assert Simulator(parse_scenario(chain(400))).topology.dense == 0


def test_a_long_chain_on_a_moving_carrier_is_read_in_linear_time():
    # issue 46.3: each body's carrier was searched rescanning every joint per step (cubic:
    # 800 bodies took 27 s); the graph is now built once. Every body of the chain is carried
    # by the aircraft, is sampled relative to it, and starts with its velocity.
    count = 3000
    doc = chain(count)
    doc['bodies']['ground'] = {'motion': {'velocity': [200.0, 0.0, 0.0]}}
    model = parse_scenario(doc)
    assert model.references == tuple((i, 0) for i in range(1, count + 1))
    assert model.carrier(count) == 0
    sim = Simulator(model)
    assert (state_views(sim.y, sim.n)[1] == [200.0, 0.0, 0.0]).all()
