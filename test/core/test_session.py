# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
``Session.run`` (the kernel takes the samples) against ``Session.advance`` sample by sample.

Both must take the same steps and record the same messages: the same
numbers to the bit, the same stamps, the same events and inputs. The cases
cut steps at samples that do not fall on the dt grid (30 Hz at dt = 1 ms),
release on a timer at a sample time, on a condition between samples and on
command, take inputs at and between sample times, and switch the sample
layout while its buffer is part full, and fill it more than once (a buffer
of one chunk) or write one buffer as several chunks (the default batch).
"""

import json
import pathlib

from cfem_ros import load_scenario, parse_scenario, Simulator
from cfem_ros.core.run.inputs import release_input, wrench_input
from cfem_ros.core.run.session import Session
from cfem_ros.recording import samplelayout
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.recorder import StateRecorder
import numpy as np
import pytest
from recordings import fields, read_checked
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'


def pendulum_with_releases():
    doc = yaml.safe_load((CONFIG / 'double_pendulum.yaml').read_text())
    doc['joints']['elbow']['release'] = {'time': 0.1}   # sample 3 at 30 Hz
    return parse_scenario(doc, duration=5.0)


def pendulum_inputs():
    return [wrench_input('A', [0, 3e3, 0], [0, 0, 0], 'world', time=0.1),   # at the release
            wrench_input('B', [0, 0, 2e4], [0, 0, 0], 'world', time=0.2),   # a sample time
            wrench_input('A', [1e4, 0, 0], [0, 500.0, 0], 'A', time=0.2345),
            release_input('shoulder', time=0.5)]


CASES = {
    'pendulum, 30 Hz, timer, inputs, command': (pendulum_with_releases, pendulum_inputs, 30.0),
    'store separation, 100 Hz, angle': (
        lambda: load_scenario(str(CONFIG / 'store_separation.yaml')), list, 100.0),
}


def record(path, model, inputs, rate_hz, batched, **run_options):
    sim = Simulator(model)
    with Recorder(str(path)) as recorder:
        session = Session(sim, rate_hz=rate_hz, duration=model.duration,
                          outputs=[StateRecorder(recorder, sim)])
        for item in inputs:
            session.submit(item, check=False)
        if batched:
            session.run(**run_options)
        else:
            session.start()
            while not session.finished:
                session.advance(session.next_sample_time)
    return sim, session


def by_topic(messages):
    topics = {}
    for topic, log_time, publish_time, message in messages:
        topics.setdefault(topic, []).append((log_time, publish_time, fields(message)))
    return topics


@pytest.mark.parametrize('batch_chunks', [1, samplelayout.BATCH_CHUNKS])
@pytest.mark.parametrize('case', sorted(CASES))
def test_kernel_sampling_records_what_sampling_one_by_one_records(case, batch_chunks, tmp_path,
                                                                  monkeypatch):
    monkeypatch.setattr(samplelayout, 'BATCH_CHUNKS', batch_chunks)
    make_model, make_inputs, rate_hz = CASES[case]
    model = make_model()
    runs = [record(tmp_path / f'{batched}.mcap', model, make_inputs(), rate_hz, batched)
            for batched in (False, True)]
    (one, one_session), (many, many_session) = runs
    assert many.status == one.status == 'running'
    assert many.t == one.t == model.duration
    assert many.steps == one.steps
    assert np.array_equal(many.y, one.y)
    assert many.events == one.events and len(one.events) >= 1
    assert many_session.samples == one_session.samples == round(model.duration * rate_hz) + 1
    (_, summary_one, expected), (_, summary, got) = (
        read_checked(tmp_path / f'{batched}.mcap') for batched in (False, True))
    # the same chunks: the buffer's samples are written a chunk's worth at a time
    assert summary.statistics.chunk_count == summary_one.statistics.chunk_count
    assert [(c.message_start_time, c.message_end_time) for c in summary.chunk_indexes] == [
        (c.message_start_time, c.message_end_time) for c in summary_one.chunk_indexes]
    # in time order (a stable sort keeps the file's order at equal times: events first)
    assert ([m[:2] for m in sorted(got, key=lambda m: m[1])]
            == [m[:2] for m in sorted(expected, key=lambda m: m[1])])
    expected, got = by_topic(expected), by_topic(got)
    assert got.keys() == expected.keys()
    for topic in expected:
        assert got[topic] == expected[topic], topic   # floats compared exactly


@pytest.mark.parametrize('case', sorted(CASES))
def test_unrecorded_runs_take_the_same_steps(case):
    make_model, make_inputs, rate_hz = CASES[case]
    model = make_model()
    sims = []
    for batched in (False, True):
        sim = Simulator(model)
        session = Session(sim, rate_hz=rate_hz, duration=model.duration)
        for item in make_inputs():
            session.submit(item, check=False)
        if batched:
            session.run()
        else:
            while not session.finished:
                session.advance(session.next_sample_time)
        sims.append((sim, session.samples))
    (one, one_samples), (many, many_samples) = sims
    assert many.steps == one.steps and many.t == one.t
    assert np.array_equal(many.y, one.y)
    assert many.events == one.events
    assert many_samples == one_samples


def test_a_failed_run_keeps_its_samples(tmp_path):
    doc = yaml.safe_load((CONFIG / 'joints' / 'hinge.yaml').read_text())
    doc['bodies']['rod']['angular_velocity'] = [0, 20.0, 0]
    doc['bodies']['rod']['velocity'] = [0, 0, -50.0]
    doc['dt'] = 0.1
    doc['baumgarte'] = 1.0
    model = parse_scenario(doc)
    # the swing leaves the tolerance after 30 ms: the samples before it are kept,
    # none after it (a sample beyond the tolerance ends the run)
    runs = [record(tmp_path / f'{batched}.mcap', model, [], 100.0, batched)
            for batched in (False, True)]
    (one, one_session), (many, many_session) = runs
    assert one.status == many.status == 'failed' and one.message == many.message
    assert many_session.samples == one_session.samples > 1
    assert (by_topic(read_checked(tmp_path / 'True.mcap')[2])
            == by_topic(read_checked(tmp_path / 'False.mcap')[2]))


def test_progress_cuts_the_kernel_calls_not_the_steps(tmp_path):
    # progress_every = 0: every kernel call is limited to 10 steps, progress after each
    model = pendulum_with_releases()
    one, _ = record(tmp_path / 'one.mcap', model, pendulum_inputs(), 30.0, False)
    times = []
    cut, _ = record(tmp_path / 'cut.mcap', model, pendulum_inputs(), 30.0, True,
                    progress=times.append, progress_every=0.0)
    assert cut.steps == one.steps and cut.events == one.events
    assert np.array_equal(cut.y, one.y)
    assert len(times) > model.duration / (10 * model.dt) / 2
    assert times == sorted(times) and times[-1] == model.duration
    assert (by_topic(read_checked(tmp_path / 'cut.mcap')[2])
            == by_topic(read_checked(tmp_path / 'one.mcap')[2]))


@pytest.mark.parametrize('batched', [False, True])
def test_a_release_at_a_sample_time_acts_after_that_sample_whatever_its_cause(
        tmp_path, batched):
    # the same release of the elbow at t = 0.1 s (sample 3 at 30 Hz), timed or commanded:
    # both recordings hold the elbow's load at 0.1 s, then its zero at the release (SPEC 4:
    # a released joint's wrench goes to zero once, so plots end at zero), and then none
    doc = yaml.safe_load((CONFIG / 'double_pendulum.yaml').read_text())
    timed = yaml.safe_load(yaml.safe_dump(doc))
    timed['joints']['elbow']['release'] = {'time': 0.1}
    runs = {}
    for name, model, inputs in (
            ('timed', parse_scenario(timed, duration=0.3), []),
            ('command', parse_scenario(doc, duration=0.3), [release_input('elbow', time=0.1)])):
        sim, _ = record(tmp_path / f'{name}.mcap', model, inputs, 30.0, batched)
        assert [(e['joint'], e['time']) for e in sim.events] == [('elbow', 0.1)]
        runs[name] = by_topic(read_checked(tmp_path / f'{name}.mcap')[2])
    for run in runs.values():
        loads = run['/cfem/joints/elbow/wrench']
        assert [t for t, _, _ in loads] == [0, 33333333, 66666667, 100000000, 100000000]
        assert any(v != 0.0 for v in loads[3][2][3:]), 'the sample before the release'
        assert all(v == 0.0 for v in loads[4][2][3:]), 'the zero at the release'
        event = json.loads(run['/cfem/events'][0][2][0])
        assert event['cause'] in ('time', 'command') and event['time'] == 0.1
    elbow = '/cfem/joints/elbow/wrench'
    assert runs['timed'][elbow] == runs['command'][elbow]
    assert runs['timed']['/cfem/bodies/B/pose'] == runs['command']['/cfem/bodies/B/pose']
