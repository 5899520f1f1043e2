# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Applied loads recorded per source, read back and drawn; wrench points through --inputs."""

import pathlib

from cfem_ros import cli, load_scenario, Simulator
from cfem_ros.core.run.inputs import wrench_input
from cfem_ros.recording import analysis
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.offline import run as run_offline
from cfem_ros.recording.recorder import StateRecorder
import numpy as np
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
EJECTORS = CONFIG / 'store_separation_ejectors.yaml'


def test_applied_loads_are_recorded_read_and_drawn(tmp_path):
    out = tmp_path / 'ejectors.mcap'
    assert cli.main(['run', str(EJECTORS), '-o', str(out), '--rate', '1000']) == 0
    run = analysis.open_run(str(out))
    assert sorted(run.applied) == ['store/aft_ejector', 'store/forward_ejector']
    assert not any('/applied/' in t for t in run.topics if 'pylon' in t)   # fixed: none
    # the simulator's numbers, sample by sample (to rounding: its steps land on the
    # sample times by another sum)
    sim = Simulator(load_scenario(str(EJECTORS)))
    aft = run.applied['store/aft_ejector']
    for k in (0, 20, 50, 56, 57, 300):
        assert sim.advance_to(aft.time[k])
        loads = sim.applied_loads()
        np.testing.assert_allclose(aft.force[k], loads[1, :3], rtol=1e-12, atol=0)
        np.testing.assert_allclose(aft.moment[k], loads[1, 3:], rtol=1e-12, atol=1e-9)
    # constant force while the stroke lasts, then none; the moment is r x F about the CG
    np.testing.assert_array_equal(aft.force[0], [0, 0, 42703.0])
    np.testing.assert_allclose(aft.moment[0], np.cross([-0.3292, 0, -0.25], [0, 0, 42703.0]),
                               rtol=1e-15)
    ended = np.flatnonzero(np.all(aft.force == 0.0, axis=1))
    assert 0.04 < aft.time[ended[0]] < 0.07 and np.all(np.diff(ended) == 1)
    paths = cli.main(['plot', str(out), '-o', str(tmp_path / 'figures')])
    assert paths == 0
    assert (tmp_path / 'figures' / 'applied_store_aft_ejector.png').exists()


def test_reaction_on_a_free_body_is_recorded_on_it(tmp_path):
    document = yaml.safe_load(EJECTORS.read_text())
    document['bodies']['pylon'] = {'mass': 9000.0, 'inertia': [2e4, 6e4, 7.5e4]}
    document['gravity'] = [0, 0, 0]
    scenario = tmp_path / 'free.yaml'
    scenario.write_text(yaml.safe_dump(document))
    out = tmp_path / 'free.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out), '--duration', '0.1']) == 0
    run = analysis.open_run(str(out))
    on_store, on_pylon = run.applied['store/aft_ejector'], run.applied['pylon/aft_ejector']
    np.testing.assert_array_equal(on_pylon.force, -on_store.force)
    assert np.abs(on_pylon.moment).max() > 1e3


def test_a_wrench_at_a_point_replays_from_a_recording(tmp_path):
    scenario = tmp_path / 'free.yaml'
    scenario.write_text(yaml.safe_dump({
        'gravity': [0, 0, 0], 'duration': 0.5,
        'bodies': {'store': {'mass': 907.0, 'inertia': [27.0, 488.0, 488.0]}}}))
    first = tmp_path / 'first.mcap'
    sim = Simulator(load_scenario(str(scenario)))
    with Recorder(str(first)) as recorder:
        run_offline(sim, StateRecorder(recorder, sim), rate_hz=100.0, duration=0.5,
                    inputs=[wrench_input('store', [0, 0, 1000.0], [0, 0, 0],
                                         'store@0.5,0,0', time=0.1)])
    assert abs(sim.rates[0, 1]) > 0.01   # the point's moment pitched it
    replay = tmp_path / 'replay.mcap'
    assert cli.main(['run', str(scenario), '-o', str(replay), '--inputs', str(first)]) == 0
    a, b = analysis.open_run(str(first)), analysis.open_run(str(replay))
    assert np.array_equal(a.bodies['store'].rates, b.bodies['store'].rates)
    assert np.array_equal(a.bodies['store'].position, b.bodies['store'].position)
