# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""scenario.reparse: some bodies and joints parsed again give the whole parse's model."""

import copy
import os

from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.scenario import load_yaml, parse_scenario, read_text, reparse
import numpy as np
import pytest

CONFIG = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__)))), 'config')


def base():
    path = os.path.join(CONFIG, 'store_separation.yaml')
    return load_yaml(read_text(path), source=path)


def test_a_body_and_a_joint_parsed_again_are_the_whole_parse():
    document = base()
    model = parse_scenario(document, source='base.yaml')
    edited = copy.deepcopy(document)
    edited['bodies']['store']['mass'] = 950.0
    edited['bodies']['store']['orientation_rpy_deg'] = [0, 3, 0]
    edited['joints']['pivot']['anchor'] = [-0.3, 0, -0.25]
    edited['joints']['pivot']['release'] = {'angle_deg': 11, 'time': 0.2}
    whole = parse_scenario(edited, source='run.yaml')
    again = reparse(model, edited, bodies=['store'], joints=['pivot'], source='run.yaml')
    assert repr(again) == repr(whole)   # every field, arrays printed in full below
    for mine, theirs in ((again.bodies[1], whole.bodies[1]),
                         (again.joints[0], whole.joints[0])):
        for name in vars(mine):
            a, b = getattr(mine, name), getattr(theirs, name)
            if isinstance(a, np.ndarray):
                assert a.tobytes() == b.tobytes(), name
    assert again.bodies[1].mass == 950.0 and again.joints[0].release.time == 0.2
    assert again.bodies[0] is model.bodies[0]   # the pylon was not parsed again
    assert again.name == 'store_separation'


def test_what_reparse_cannot_do_is_refused_with_the_key():
    document = base()
    model = parse_scenario(document, source='base.yaml')
    edited = copy.deepcopy(document)
    edited['bodies']['store']['fixed'] = True
    with pytest.raises(ScenarioError, match='bodies.store.fixed'):
        reparse(model, edited, bodies=['store'], source='run.yaml')
    edited = copy.deepcopy(document)
    edited['bodies']['store']['mass'] = -1.0
    with pytest.raises(ScenarioError, match='bodies.store.mass: is -1'):
        reparse(model, edited, bodies=['store'], source='run.yaml')
