# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""run --inputs with a stamp no ROS time holds and a force beyond 1e9 N (issue 41.4)."""

import json
import pathlib

from cfem_ros import cli
from cfem_ros.recording.msgdefs import DEFINITIONS
from mcap_ros2.writer import Writer
from recordings import read_checked

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
WRENCH = 'geometry_msgs/msg/WrenchStamped'


def wrench(sec, nanosec, force_z):
    return {'header': {'stamp': {'sec': sec, 'nanosec': nanosec}, 'frame_id': 'world'},
            'wrench': {'force': {'x': 0.0, 'y': 0.0, 'z': force_z},
                       'torque': {'x': 0.0, 'y': 0.0, 'z': 0.0}}}


def test_bad_replayed_inputs_are_warnings_not_a_traceback(tmp_path, capsys):
    log = tmp_path / 'inputs.mcap'
    with open(log, 'wb') as stream:
        writer = Writer(stream)
        writer._writer.add_metadata('cfem_ros', {'start_stamp_ns': '0'})
        schema = writer.register_msgdef(WRENCH, DEFINITIONS[WRENCH])
        topic = '/cfem/bodies/store/wrench'
        for k, message in enumerate([wrench(2 ** 31 - 1, 2 ** 32 - 1, 5000.0),
                                     wrench(0, 100_000_000, 1e300),
                                     wrench(0, 150_000_000, 5000.0)]):
            at = 50_000_000 * (k + 1)
            writer.write_message(topic, schema, message, log_time=at, publish_time=at)
        writer.finish()
    out = tmp_path / 'replay.mcap'
    status = cli.main(['run', str(CONFIG / 'store_separation.yaml'), '-o', str(out),
                       '--inputs', str(log), '--duration', '0.2'])
    err = capsys.readouterr().err
    assert status == 0, err
    assert 'is not a ROS time' in err and 'must be at most 1e+09' in err
    assert 'Traceback' not in err
    _, _, messages = read_checked(out)
    events = [json.loads(m.data) for topic, _, _, m in messages if topic == '/cfem/events']
    assert not any(e.get('event') == 'error' for e in events)
    # the good wrench (at 0.15 s) is the only one applied: the store's CG is pushed from then
    applied = [m for topic, _, _, m in messages if topic == '/cfem/bodies/store/wrench']
    assert [m.wrench.force.z for m in applied][-1] == 5000.0
