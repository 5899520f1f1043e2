# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The launch file and the parameters file start the node they describe.

ROS 2 launch is not on PyPI, so the launch file is run against recording
stand-ins of the few launch classes it uses; what it builds must name the
installed executable, the node name, and parameters the node declares. The
parameters file is given to a real node.
"""

import importlib.util
import pathlib
import sys
import types

from cfem_ros.ros.node import PARAMETERS
from rosharness import NodeProcess
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[2]


class _Recorded:
    """Stand-in for a launch class: keeps its arguments."""

    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs


def _stand_ins(monkeypatch):
    names = {
        'launch': ['LaunchDescription'],
        'launch.actions': ['DeclareLaunchArgument'],
        'launch.substitutions': ['LaunchConfiguration', 'PathJoinSubstitution'],
        'launch_ros.actions': ['Node'],
        'launch_ros.parameter_descriptions': ['ParameterValue'],
        'launch_ros.substitutions': ['FindPackageShare'],
    }
    for module_name, classes in names.items():
        module = types.ModuleType(module_name)
        for name in classes:
            setattr(module, name, type(name, (_Recorded,), {}))
        monkeypatch.setitem(sys.modules, module_name, module)


def test_launch_file_starts_cfem_node_with_declared_parameters(monkeypatch):
    _stand_ins(monkeypatch)
    path = ROOT / 'launch' / 'cfem_sim.launch.py'
    spec = importlib.util.spec_from_file_location('cfem_sim_launch', path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    description = module.generate_launch_description()
    actions = description.args[0]
    nodes = [a for a in actions if type(a).__name__ == 'Node']
    assert len(nodes) == 1
    node = nodes[0].kwargs
    assert (node['package'], node['executable'], node['name']) == (
        'cfem_ros', 'cfem_node', 'cfem_sim')
    setup = (ROOT / 'setup.py').read_text()
    assert "'cfem_node = cfem_ros.console:node_entry_point'" in setup
    overrides = node['parameters'][1]
    assert set(overrides) <= set(PARAMETERS) | {'use_sim_time'}
    declared = {a.args[0] for a in actions if type(a).__name__ == 'DeclareLaunchArgument'}
    used = {v.args[0] for v in overrides.values() if type(v).__name__ == 'LaunchConfiguration'}
    assert used <= declared and 'scenario' in declared
    # the defaults point at files that are installed
    for action in actions:
        default = action.kwargs.get('default_value')
        if type(default).__name__ == 'PathJoinSubstitution':
            parts = default.args[0][1:]
            assert (ROOT.joinpath(*parts)).is_file(), parts


def test_params_file_declares_only_known_parameters_with_their_types():
    document = yaml.safe_load((ROOT / 'config' / 'cfem_node.params.yaml').read_text())
    values = document['/**']['ros__parameters']
    assert set(values) <= set(PARAMETERS) | {'use_sim_time'}
    for name, value in values.items():
        if name in PARAMETERS:
            assert type(value) is type(PARAMETERS[name][0]), name


def test_node_starts_from_the_params_file(tmp_path):
    recording = tmp_path / 'run.mcap'
    node = NodeProcess(tmp_path, ROOT / 'config' / 'store_separation.yaml',
                       params_file=ROOT / 'config' / 'cfem_node.params.yaml',
                       real_time_factor=0.0, record=recording)
    assert node.wait(timeout=120) == 0, node.output
    assert 'as fast as possible' in node.output and 'run complete at t = 1.5 s' in node.output
    assert recording.stat().st_size > 0
