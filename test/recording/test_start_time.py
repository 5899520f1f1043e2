# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
``cfem-sim run --start-time`` and the scenario's ``start_time``: a recording dated as its flight.

Read back with rosbags' own MCAP reader: every message of a dated run is the
undated run's, its log time and every stamp inside it (headers, /tf,
markers) later by exactly the start's nanoseconds since 1970; what reads
times from t = 0 (``open_run``) reads the same numbers.
"""

import dataclasses
import datetime
import pathlib

from cfem_ros import cli, load_scenario
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio.instants import instant_ns
from cfem_ros.recording.analysis import open_run
import numpy as np
import pytest
from recordings import read_rosbags
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
EXAMPLE = CONFIG / 'store_separation.yaml'
#: 2026-03-14T09:30:00.123456789Z: seconds past 2^30, and all nine digits of a fraction.
START = '2026-03-14T10:30:00.123456789+01:00'
START_NS = (datetime.datetime(2026, 3, 14, 9, 30, tzinfo=datetime.timezone.utc)
            - datetime.datetime(1970, 1, 1, tzinfo=datetime.timezone.utc)) \
    // datetime.timedelta(seconds=1) * 10 ** 9 + 123456789


def _split(value, stamps, rest):
    """Sort a decoded message's leaves into its stamps (ns) and everything else."""
    if dataclasses.is_dataclass(value):
        if value.__msgtype__ == 'builtin_interfaces/msg/Time':   # not a Duration (lifetime)
            stamps.append(value.sec * 10 ** 9 + value.nanosec)
            return
        for field in dataclasses.fields(value):
            if field.name != 'texture':   # a Marker's image, unused: its stamp stays 0
                _split(getattr(value, field.name), stamps, rest)
    elif isinstance(value, (list, tuple)):
        for item in value:
            _split(item, stamps, rest)
    elif isinstance(value, np.ndarray):
        rest.append(value.tolist())
    else:
        rest.append(value)


def _run(tmp_path, name, *options):
    out = tmp_path / f'{name}.mcap'
    assert cli.main(['run', str(EXAMPLE), '-o', str(out), '--duration', '0.4', *options]) == 0
    return out


def test_the_start_is_read_to_the_nanosecond():
    assert instant_ns(START) == START_NS
    assert instant_ns('2026-03-14T09:30:00.123456789Z') == START_NS
    assert instant_ns('1970-01-01T00:00:00Z') == 0
    # what YAML makes of an unquoted timestamp: a datetime, to the microsecond
    assert instant_ns(yaml.safe_load('t: 2026-03-14T09:30:00.123456Z')['t']) \
        == START_NS - 789


def test_a_dated_recording_is_the_undated_one_later_by_the_start(tmp_path):
    plain = read_rosbags(_run(tmp_path, 'plain'))[0]
    dated = read_rosbags(_run(tmp_path, 'dated', '--start-time', START))[0]
    assert len(dated) == len(plain) > 100
    assert {topic for topic, _, _ in plain} >= {
        '/tf', '/tf_static', '/cfem/markers', '/cfem/load_markers', '/cfem/events'}
    assert min(t for _, t, _ in dated) == START_NS
    plain = sorted(plain, key=lambda m: (m[1], m[0]))
    dated = sorted(dated, key=lambda m: (m[1], m[0]))
    stamps_seen = 0
    for (topic, t, message), (topic_d, t_d, message_d) in zip(plain, dated):
        assert (topic_d, t_d) == (topic, t + START_NS)
        stamps, rest, stamps_d, rest_d = [], [], [], []
        _split(message, stamps, rest)
        _split(message_d, stamps_d, rest_d)
        assert rest_d == rest, topic
        assert stamps_d == [s + START_NS for s in stamps], topic
        stamps_seen += len(stamps)
    assert stamps_seen > len(plain)   # headers, /tf's transforms, each marker
    # times from t = 0 are the same numbers; the release is at the same instant
    a, b = open_run(str(tmp_path / 'plain.mcap')), open_run(str(tmp_path / 'dated.mcap'))
    assert b.start_ns == START_NS
    assert np.array_equal(a.bodies['store'].time, b.bodies['store'].time)
    assert np.array_equal(a.bodies['store'].position, b.bodies['store'].position)
    assert a.releases() == b.releases() and len(a.releases()) == 1


def test_the_scenario_start_time_is_the_default_and_the_option_overrides_it(tmp_path):
    document = yaml.safe_load(EXAMPLE.read_text())
    scenario = tmp_path / 'dated.yaml'
    scenario.write_text(yaml.safe_dump({**document, 'start_time': START}))
    assert load_scenario(str(scenario)).start_ns == START_NS
    out = tmp_path / 'from_file.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out), '--duration', '0.05']) == 0
    assert open_run(str(out)).start_ns == START_NS
    assert cli.main(['run', str(scenario), '-o', str(out), '--duration', '0.05',
                     '--overwrite', '--start-time', '1970-01-01T00:00:00Z']) == 0
    assert min(t for _, t, _ in read_rosbags(out)[0]) == 0


@pytest.mark.parametrize('value, said', [
    ('2026-03-14T09:30:00', 'no UTC offset'),
    ('2026-02-30T09:30:00Z', 'day is out of range'),
    ('14/03/2026', "is '14/03/2026'"),
    ('2038-01-19T03:14:07Z', 'past 2038-01-19T03:14:07Z'),
    ('1969-12-31T23:59:59Z', 'outside what a ROS stamp holds'),
])
def test_a_start_that_is_no_stamp_is_refused_with_what_would_do(tmp_path, capsys, value, said):
    out = tmp_path / 'refused.mcap'
    assert cli.main(['run', str(EXAMPLE), '-o', str(out), '--start-time', value]) == 2
    err = capsys.readouterr().err
    assert err.startswith('ERROR: --start-time: ') and said in err
    assert 'ISO 8601' in err or 'earlier start' in err
    assert 'Traceback' not in err and not out.exists()
    document = yaml.safe_load(EXAMPLE.read_text())
    scenario = tmp_path / 'refused.yaml'
    scenario.write_text(yaml.safe_dump({**document, 'start_time': value}))
    with pytest.raises(ScenarioError, match='start_time'):
        load_scenario(str(scenario))
