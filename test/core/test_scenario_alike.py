# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Small inconsistencies of scenario reading (issue 41.11): refusals, and check and run alike."""

import pathlib

from cfem_ros import cli
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.scenario.parse import parse_scenario
import pytest
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'


@pytest.mark.parametrize('frame', [[1, 1, 3], {'a': 1}, 3])
def test_a_wrench_frame_that_is_no_name_is_refused_with_its_key(frame):
    doc = yaml.safe_load((CONFIG / 'store_separation.yaml').read_text())
    doc['wrenches'] = [{'body': 'store', 'force': [0, 0, 1], 'frame': frame}]
    with pytest.raises(ScenarioError, match=r'wrenches\[0\]\.frame: is .*; expected world or '
                       'one of pylon, store'):
        parse_scenario(doc)


def test_check_and_run_refuse_the_same_scenario(tmp_path, capsys):
    # a reference length of 1e300 m: the aerodynamic loads overflow at t = 0
    doc = yaml.safe_load((CONFIG / 'store_separation_aero.yaml').read_text())
    doc['aero']['store']['length'] = 1e300
    scenario = tmp_path / 'long.yaml'
    scenario.write_text(yaml.safe_dump(doc))
    assert cli.main(['check', str(scenario)]) == 2
    refused = capsys.readouterr().err
    out = tmp_path / 'long.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out), '--duration', '0.01']) == 2
    assert capsys.readouterr().err == refused and 'loads at t = 0 overflow' in refused
    assert not out.exists()


@pytest.mark.parametrize('body', [[1e308, 1e308, 1e308], {}, ['store']])
def test_a_wrench_body_that_is_no_name_is_refused_with_its_key(body):
    # found by the reliability campaign of 2026-11-27: a TypeError (unhashable) before
    doc = yaml.safe_load((CONFIG / 'store_separation.yaml').read_text())
    doc['wrenches'] = [{'body': body, 'force': [0, 0, 1]}]
    with pytest.raises(ScenarioError, match=r'wrenches\[0\]\.body: .* is not a body; expected '
                       'one of pylon, store'):
        parse_scenario(doc)
