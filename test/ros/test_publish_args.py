# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""cfem_pub refuses arguments it cannot publish, before ROS 2 starts (issue 41.10)."""

from cfem_ros.ros import publish
import pytest
import rclpy


@pytest.mark.parametrize('argv, said', [
    (['wrench', 'store', '--force', '0', '0', '1', '--stamp', 'nan'], '--stamp: is nan'),
    (['wrench', 'store', '--stamp', 'inf'], '--stamp: is inf'),
    (['wrench', 'store', '--stamp', '1e30'], '--stamp: is 1e+30'),
    (['wrench', 'store', '--stamp', '-1'], '--stamp: is -1'),
    (['wrench', '', '--force', '0', '0', '1'], "'/cfem/bodies//wrench'"),
    (['wrench', 'a b'], "'/cfem/bodies/a b/wrench'"),
    (['--ns', 'a b', 'release', 'pivot'], "'a b/release'"),
    (['--wait', 'nan', 'release', 'pivot'], '--wait: is nan'),
    (['--wait', '-1', 'release', 'pivot'], '--wait: is -1'),
    (['release', 'pivot', '--confirm', 'inf'], '--confirm: is inf'),
    (['release', 'pivot', '--confirm', '-2'], '--confirm: is -2'),
])
def test_bad_arguments_are_one_error_line_and_nothing_published(argv, said, capsys):
    assert publish.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith('ERROR: ') and err.count('\n') == 1
    assert said in err and err.rstrip().endswith('nothing published')
    assert not rclpy.ok()   # refused before ROS 2 started
