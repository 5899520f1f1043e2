# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The output schema is what a recording holds and what its readers find (issue 34).

A run with joints, scheduled and aero loads, the air and a carrier's frame
(``store_release_near_pylon``) and a wrench input is recorded; its channels
must be the schema's topics of the model, each with the schema's type, QoS
and frame, and the readers must find every body, joint, load and air track
by those topics. The node's side is ``test/ros/test_node_schema.py``.
"""

import pathlib

from cfem_ros.core.engine.aero import AIR_TOPICS
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.run.inputs import input_topic, odometry_input, release_input, wrench_input
from cfem_ros.core.scenario.parse import load_scenario
from cfem_ros.recording import offline, schema
from cfem_ros.recording.airtracks import read_air
from cfem_ros.recording.analysis import open_run
from cfem_ros.recording.container import offered_qos, Recorder
from cfem_ros.recording.recorder import StateRecorder
import pytest
from recordings import read_mcap

SCENARIO = pathlib.Path(__file__).resolve().parents[2] / 'config' / 'store_release_near_pylon.yaml'
QUANTITIES = [name for name, _ in AIR_TOPICS]


@pytest.fixture(scope='module')
def recorded(tmp_path_factory):
    model = load_scenario(str(SCENARIO))
    sim = Simulator(model)
    path = tmp_path_factory.mktemp('schema') / 'run.mcap'
    push = wrench_input('store', [0.0, 0.0, 10.0], [0.0, 0.0, 0.0], 'store', time=0.05)
    with Recorder(str(path)) as recorder:
        assert offline.run(sim, StateRecorder(recorder, sim), rate_hz=100.0, duration=0.1,
                           inputs=[push])
    return model, sim, str(path)


def test_the_recording_holds_the_schema_s_topics_types_and_qos(recorded):
    model, sim, path = recorded
    expected = schema.run_topics(model, sim.applied_sources, '/cfem', QUANTITIES)
    # the model has every kind of output: a failure below is a real drift
    kinds = {id(topic) for topic in expected.values()}
    assert kinds == {id(topic) for topic in schema.OUTPUTS}
    _, summary, messages = read_mcap(path)
    channels = {c.topic: c for c in summary.channels.values()}
    inputs = {t for t in channels if any(i.pattern.match(t) for i in schema.INPUTS)}
    assert inputs == {schema.WRENCH_INPUT.absolute('/cfem', body='store')}
    assert set(channels) - inputs == set(expected)
    for name, topic in expected.items():
        channel = channels[name]
        assert summary.schemas[channel.schema_id].name == topic.msgtype, name
        assert channel.metadata['offered_qos_profiles'] == offered_qos(topic.in_recording), name
    first = {}
    for topic, _, _, decoded in messages:
        first.setdefault(topic, decoded)
    reference = {model.bodies[b].name: model.bodies[r].name for b, r in model.references}
    for name, topic in expected.items():
        if topic.frame is None:
            continue
        fields = topic.pattern.match(name).groupdict()
        del fields['ns']
        frame = topic.frame_id(world=model.frame_id, reference=reference.get(fields.get('body')),
                               **fields)
        assert first[name].header.frame_id == frame, name


def test_the_readers_find_every_output_by_the_schema(recorded):
    model, sim, path = recorded
    run = open_run(path)
    assert run.namespace == '/cfem'
    assert set(run.bodies) == {b.name for b in model.bodies}
    assert set(run.joints) == {j.name for j in model.joints}
    assert set(run.applied) == {f'{body}/{source}' for body, source in sim.applied_sources}
    assert set(run.relative) == {model.bodies[b].name for b, _ in model.references}
    assert len(run.bodies['store'].time) == 11   # 0 to 0.1 s at 100 Hz
    air = read_air(path, run.namespace, run.start_ns)
    assert set(air) == {model.bodies[entry.body].name for entry in model.aero}
    for track in air.values():
        assert set(track.values) == set(QUANTITIES) and len(track.time) == 11


def test_the_core_names_inputs_as_the_schema_does():
    inputs = [(wrench_input('store', [0, 0, 1], [0, 0, 0], 'world'), schema.WRENCH_INPUT),
              (odometry_input('aircraft', [0, 0, 0], [0, 0, 0, 1], [0, 0, 0], [0, 0, 0],
                              'world'), schema.ODOMETRY_INPUT),
              (release_input('hook'), schema.RELEASE_INPUT)]
    for item, topic in inputs:
        assert input_topic(item) == topic.relative(body=item.target), item.kind


def test_topic_patterns_take_names_apart():
    match = schema.APPLIED_WORLD.pattern.match('/a/cfem/bodies/store/applied_world/aero')
    assert match.groupdict() == {'ns': '/a/cfem', 'body': 'store', 'source': 'aero'}
    assert schema.APPLIED.pattern.match('/cfem/bodies/store/applied_world/aero') is None
    assert schema.TF.pattern.match('/tf') and not schema.TF.pattern.match('/cfem/tf')
    assert schema.EVENTS.pattern.match('/events')['ns'] == ''
    assert schema.TF.absolute('/cfem') == '/tf'
    assert schema.POSE.absolute('/cfem/', body='b') == '/cfem/bodies/b/pose'


def test_a_cadence_is_due_after_the_first_sample_of_each_period():
    markers = schema.Cadence(1.0, first=1)
    times = [k / 30 for k in range(100)]   # 30 Hz: no sample on most whole seconds
    assert [t for t in times if markers.take(t)] == [times[30], times[60], times[90]]
    arrows = schema.Cadence(0.1, first=0)
    assert [t for t in times[:10] if arrows.take(t)] == [times[0], times[3], times[6],
                                                         times[9]]
    arrows.restart()
    assert arrows.take(0.0)
