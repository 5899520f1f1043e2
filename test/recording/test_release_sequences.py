# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The two-hook example offline (SPEC section 7).

``--inputs`` releasing the station, the events in the recording, ``open_run``'s
end-of-stroke figures, ``run``'s printout.
"""

import json
import pathlib

from cfem_ros import cli, load_scenario, Simulator
from cfem_ros.core.run.inputs import release_input
from cfem_ros.recording.analysis import open_run
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.recorder import StateRecorder
import numpy as np
import pytest
from recordings import read_checked

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
EXAMPLE = CONFIG / 'store_release_two_hooks.yaml'
RELEASE = 0.1


@pytest.fixture(scope='module')
def replayed(tmp_path_factory):
    """``cfem-sim run`` of the example with a log that releases station_1 at 0.1 s."""
    folder = tmp_path_factory.mktemp('two_hooks')
    log = folder / 'inputs.mcap'
    with Recorder(str(log), metadata={'start_stamp_ns': 0}) as recorder:
        StateRecorder(recorder, Simulator(load_scenario(str(EXAMPLE)))).received(
            release_input('station_1'), RELEASE)
    out = folder / 'replay.mcap'
    return log, out


def test_inputs_replay_releases_the_station_and_records_the_figures(replayed, capsys):
    log, out = replayed
    assert cli.main(['run', str(EXAMPLE), '-o', str(out), '--inputs', str(log),
                     '--duration', '0.4']) == 0
    printed = capsys.readouterr().out
    # the same release through the API
    sim = Simulator(load_scenario(str(EXAMPLE)))
    assert sim.advance_to(RELEASE)
    sim.release('station_1')
    assert sim.advance_to(0.4), sim.message
    _, _, messages = read_checked(out)
    events = [json.loads(m.data) for topic, _, _, m in messages if topic == '/cfem/events']
    # the same events (to rounding: the run's steps are cut at its sample times)
    assert [(e['event'], e.get('joint', e.get('wrench'))) for e in events] == [
        (e['event'], e.get('joint', e.get('wrench'))) for e in sim.events]
    releases = [e for e in events if e['event'] == 'release']
    assert [(e['joint'], e['time'], e['group']) for e in releases] == [
        ('fwd_hook', RELEASE, 'station_1'), ('aft_hook', RELEASE, 'station_1')]
    assert 'release fwd_hook at t = 0.100000000 s (command; group station_1)' in printed
    strokes = open_run(str(out)).stroke_ends()
    assert set(strokes) == {'forward_ejector', 'aft_ejector'}
    for event in (e for e in sim.events if e['event'] == 'stroke_end'):
        figures = strokes[event['wrench']]
        assert abs(figures['time'] - event['time']) < 1e-12
        assert figures['reacts_on'] == 'pylon'
        np.testing.assert_allclose(figures['velocity'], event['velocity'], rtol=0, atol=1e-9)
        np.testing.assert_allclose(figures['rates'], event['rates'], rtol=0, atol=1e-9)
        assert f"stroke end {event['wrench']} at t = {figures['time']:.9f} s" in printed
        # pushed away from the pylon (z down), nose up (the aft ejector is stronger)
        assert figures['velocity'][2] > 3.0 and figures['rates'][1] > 1.0
        assert event['time'] > RELEASE


def test_carriage_loads_before_the_release_are_split_by_the_hooks_stiffness(replayed):
    _, out = replayed
    run = open_run(str(out))
    fwd, aft = run.joints['fwd_hook'], run.joints['aft_hook']
    before = fwd.time < RELEASE - 1e-9
    assert before.sum() == 10 and np.all(fwd.time <= RELEASE + 1e-9)
    # the drag, along the line between the hooks, shared 1 : 2 (the aft hook is twice
    # as stiff in x); no ejector load on the hooks before the release
    np.testing.assert_allclose(aft.force[before, 0], 2.0 * fwd.force[before, 0], rtol=1e-9)
    # the hooks hold the weight and the four sway braces' preloads (2,000 N each, 35 deg
    # from the vertical, in the store's axes: level while it is carried)
    weight = 907.1848 * 9.80665
    braces = load_scenario(str(EXAMPLE)).braces
    assert len(braces) == 4
    preloads = sum(b.preload * b.direction[2] for b in braces)
    vertical = fwd.force[before, 2] + aft.force[before, 2]
    np.testing.assert_allclose(vertical, -(weight + preloads), rtol=1e-9)
    assert np.all(fwd.force[before, 0] > 100.0)   # the hooks hold the store against drag
