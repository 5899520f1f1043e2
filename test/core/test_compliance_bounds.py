# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""A hook's compliance weighs only the split of redundant loads, at any ratio (issue 41.7)."""

import pathlib

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.scenario.parse import parse_scenario
import numpy as np
import pytest
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'


def two_hooks(forward_compliance):
    doc = yaml.safe_load((CONFIG / 'store_release_two_hooks.yaml').read_text())
    doc['joints']['fwd_hook']['compliance'] = [forward_compliance] * 3
    return doc


def store_track(doc, until=0.1):
    with np.errstate(all='raise', under='ignore'):   # as cfem-sim check builds it
        sim = Simulator(parse_scenario(doc))
    track = []
    for k in range(1, 11):
        assert sim.advance_to(until * k / 10), sim.message
        track.append(sim.y.copy())
    return np.array(track), sim


@pytest.mark.parametrize('forward', [1e4, 1e-4, 5e-324])
def test_an_extreme_compliance_changes_no_motion(forward):
    # the aft hook's compliance is 1e-8 m/N: ratios of 1e12 and 2e315 (which overflowed)
    reference, _ = store_track(two_hooks(2e-8))
    track, sim = store_track(two_hooks(forward))
    assert sim.status == 'running'
    scale = np.abs(reference).max(axis=0) + 1.0
    assert np.max(np.abs(track - reference) / scale) < 1e-12


def test_the_stiffer_hook_takes_the_redundant_load():
    # the store hangs in x from both hooks; the compliant forward hook takes none of the
    # (redundant) axial load once its compliance is far above the aft one's
    _, sim = store_track(two_hooks(1e4), until=0.01)
    force, _ = sim.joint_wrenches()
    names = [j.name for j in sim.model.joints]
    fwd, aft = force[names.index('fwd_hook')], force[names.index('aft_hook')]
    assert abs(fwd[0]) < 1e-3 * abs(aft[0])
    # and at the shipped 2:1 ratio the split is 1:2, the stiff limit of two springs
    _, sim = store_track(two_hooks(2e-8), until=0.01)
    force, _ = sim.joint_wrenches()
    fwd, aft = force[names.index('fwd_hook')], force[names.index('aft_hook')]
    assert abs(fwd[0] / (fwd[0] + aft[0]) - 1 / 3) < 1e-9
