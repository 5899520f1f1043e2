# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
``cfem-sim play`` on bad names, missing message libraries and damaged files: no traceback.

A ``--remap`` to a name ROS refuses is an ``ERROR:`` line (exit 2) before
anything is published; a recorded topic whose name ROS refuses, or whose
message library fails to load, is skipped with a warning and the rest is
played; a damaged file gives one error line with the reason.
"""

import sys

from cfem_ros import cli
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.schema import STRING_TYPE, WRENCH_TYPE


def _wrench(t_ns):
    return {'header': {'stamp': {'sec': t_ns // 10 ** 9, 'nanosec': t_ns % 10 ** 9},
                       'frame_id': 'world'},
            'wrench': {'force': {'x': 1.0, 'y': 0.0, 'z': 0.0},
                       'torque': {'x': 0.0, 'y': 0.0, 'z': 0.0}}}


def test_a_remap_to_an_invalid_name_is_refused(tmp_path, capsys):
    log = tmp_path / 'log.mcap'
    with Recorder(str(log)) as recorder:
        recorder.write('/cfem/release', STRING_TYPE, {'data': 'pivot'}, 1_000)
    for target in ('//bad', '/a b', '/1abc'):
        assert cli.main(['play', str(log), '--remap', f'/cfem/release:={target}']) == 2
        err = capsys.readouterr().err
        assert err.startswith('ERROR: --remap') and err.count('\n') == 1, err
        assert 'not a valid ROS 2 topic name' in err


def test_invalid_topics_and_broken_message_libraries_are_skipped_with_a_warning(
        tmp_path, capsys, monkeypatch):
    broken = tmp_path / 'broken_msgs' / 'msg'
    broken.mkdir(parents=True)
    (broken.parent / '__init__.py').write_text('')
    (broken / '__init__.py').write_text("raise RuntimeError('type support not built')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    log = tmp_path / 'log.mcap'
    with Recorder(str(log)) as recorder:
        recorder.write('/cfem//bad', STRING_TYPE, {'data': 'x'}, 1_000)
        recorder.write('/cfem/bodies/store/wrench', WRENCH_TYPE, _wrench(2_000), 2_000)
        # a type of a library that fails to load (its definition is a String's)
        recorder._schemas['broken_msgs/msg/Thing'] = recorder._writer.register_schema(
            name='broken_msgs/msg/Thing', encoding='ros2msg', data=b'string data')
        channel = recorder._writer.register_channel(
            topic='/cfem/thing', message_encoding='cdr',
            schema_id=recorder._schemas['broken_msgs/msg/Thing'], metadata={})
        recorder._writer.add_message(channel, 3_000, b'\x00\x01\x00\x00\x01\x00\x00\x00\x00',
                                     sequence=9, publish_time=3_000)
    assert cli.main(['play', str(log), '--wait', '0', '--delay', '0']) == 0
    captured = capsys.readouterr()
    assert 'Traceback' not in captured.err
    assert "topic '/cfem//bad' is not a valid ROS 2 topic name" in captured.err
    assert "type 'broken_msgs/msg/Thing' is not importable here" in captured.err
    assert f'{log}: 1 messages played' in captured.out
    sys.modules.pop('broken_msgs.msg', None)
    sys.modules.pop('broken_msgs', None)


def test_a_damaged_file_names_its_reason(tmp_path, capsys):
    log = tmp_path / 'log.mcap'
    with Recorder(str(log)) as recorder:
        for k in range(50):
            recorder.write('/cfem/bodies/store/wrench', WRENCH_TYPE, _wrench(k * 1000), k * 1000)
    data = bytearray(log.read_bytes())
    data[len(data) // 3] ^= 0xFF
    log.write_bytes(bytes(data))
    assert cli.main(['play', str(log), '--wait', '0', '--delay', '0']) == 2
    err = capsys.readouterr().err
    assert err.startswith(f'ERROR: {log}: ') and err.count('\n') == 1, err
    assert '()' not in err and 'recover' in err
