# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Numbers in scenario files are read as YAML 1.2 reads them (5.0e4 is a number)."""

from cfem_ros.core.fileio.yamlfile import load_yaml, LOADERS
from cfem_ros.core.scenario.parse import parse_scenario
import pytest

SCENARIO = """
bodies:
  pylon: {fixed: true}
  store: {mass: 907.1848, inertia: [27.1164, 488.0944, 488.0944]}
joints:
  pivot:
    type: hinge
    parent: pylon
    child: store
    anchor: [-0.3292, 0, -0.25]
    axis: [0, 1, 0]
    release: {force: 5.0e4, time: 5e-1}
"""


@pytest.mark.parametrize('loader', LOADERS, ids=lambda cls: cls.__name__)
def test_exponents_without_dot_or_sign_are_floats(loader):
    text = 'a: 5.0e4\nb: 1e-3\nc: 2E5\nd: -.5e+2\ne: 10\nf: 1.5\ng: 1e\nh: e5\ni: 1.2.3e4\n'
    assert load_yaml(text, loader=loader) == {
        'a': 50000.0, 'b': 0.001, 'c': 200000.0, 'd': -50.0, 'e': 10, 'f': 1.5,
        'g': '1e', 'h': 'e5', 'i': '1.2.3e4'}
    assert isinstance(load_yaml('x: 10', loader=loader)['x'], int)


def test_a_release_force_written_5_0e4_is_a_number():
    model = parse_scenario(load_yaml(SCENARIO), source='numbers.yaml')
    release = model.joints[0].release
    assert release.force == 5.0e4
    assert release.time == 0.5
