# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The node refuses what ``cfem-sim check`` refuses, with check's line (issue 46.4).

A double pendulum whose second body is 1e9 m from its elbow builds (the
joints are well formed) but fails at its first step; ``check`` refuses it
naming the elbow's anchor. The node, made in this process, refuses it at
start-up with that same line (``StartupError``, which ``main`` prints after
``ERROR:``), instead of another message, or a run that fails at t = 0.
"""

import pathlib

from cfem_ros import cli
from cfem_ros.ros.node import CfemNode, StartupError
import pytest
import rclpy
from rclpy.signals import SignalHandlerOptions
import yaml

PENDULUM = pathlib.Path(__file__).resolve().parents[2] / 'config' / 'double_pendulum.yaml'


def test_the_node_refuses_what_check_refuses_in_its_words(tmp_path, capsys):
    document = yaml.safe_load(PENDULUM.read_text())
    document['bodies']['B']['position'] = [-1e9, 0, 0]
    path = tmp_path / 'far.yaml'
    path.write_text(yaml.safe_dump(document))
    assert cli.main(['check', str(path)]) == 2
    line = capsys.readouterr().err
    assert line.startswith(f'ERROR: {path}: cannot start: ') and "joint 'elbow'" in line, line

    context = rclpy.Context()
    rclpy.init(args=['--ros-args', '-p', f'scenario:={path}', '-p', 'use_sim_time:=true'],
               context=context, signal_handler_options=SignalHandlerOptions.NO)
    try:
        with pytest.raises(StartupError) as refused:
            CfemNode(context=context)
    finally:
        rclpy.try_shutdown(context=context)
    assert f'ERROR: {refused.value}\n' == line
