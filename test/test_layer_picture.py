# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The architecture page's picture of the layers is the one the imports draw today.

``tools/layers.py`` reads every import of the package and writes the table
of units and their imports into ``docs/guide/architecture.md`` (and the
figure ``docs/figures/layers.png``); an import added or removed without
running it makes the page stale, and this test says so.
"""

import importlib.util
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _tool():
    spec = importlib.util.spec_from_file_location('layers_tool', ROOT / 'tools' / 'layers.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


layers = _tool()


def test_the_page_shows_the_imports_of_today():
    graph = layers.unit_graph()
    assert {'core.engine', 'core.scenario', 'recording', 'ros', 'study'} <= set(graph)
    assert layers.current_block() == layers.block(graph), \
        'docs/guide/architecture.md: the layers table is stale; run python tools/layers.py'
    assert (ROOT / 'docs' / 'figures' / 'layers.png').stat().st_size > 10_000


def test_the_core_is_the_bottom_and_the_faces_the_top():
    level = layers.levels(layers.unit_graph())
    core = [u for u in level if u.startswith('core')]
    assert max(level[u] for u in core) < min(level[u] for u in ('recording', 'study', 'ros'))
    middle = ('recording', 'study', 'ros', 'separation', 'plots', 'study_plots')
    assert level['console'] > level['cli'] > max(level[u] for u in middle)


def test_levels_and_reduction_on_a_known_graph():
    graph = {'a': {'b', 'c'}, 'b': {'c'}, 'c': set(), 'd': {'a', 'c'}}
    assert layers.levels(graph) == {'a': 2, 'b': 1, 'c': 0, 'd': 3}
    assert layers.reduction(graph) == {'a': {'b'}, 'b': {'c'}, 'c': set(), 'd': {'a'}}
    with pytest.raises(ValueError, match='circle: a -> b -> a'):
        layers.levels({'a': {'b'}, 'b': {'a'}})


def test_units_group_modules_as_the_page_says():
    assert layers.unit_of('cfem_ros.core.engine.simulator') == 'core.engine'
    assert layers.unit_of('cfem_ros.core.errors') == 'core'
    assert layers.unit_of('cfem_ros.study.fit.solve') == 'study'
    assert layers.unit_of('cfem_ros.plots') == 'plots'
