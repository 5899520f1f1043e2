# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Rigid bodies joined by releasable joints, simulated with CFEM.

The package is layered (README, "Architecture"); imports only go down:

- ``cfem_ros.core``: the model, scenario files, the compiled engine, sessions,
  inputs and batches; never imports the layers above it, nor rclpy;
- ``cfem_ros.recording``: MCAP recordings, their reader and analysis, offline runs;
- ``cfem_ros.study``: separation studies over many runs;
- ``cfem_ros.ros``: the ROS 2 node and publisher (the only place rclpy is imported);
- ``cfem_ros.cli`` and ``cfem_ros.plots``: the command line and the figures.

The names below are loaded on first use, so that importing the package costs
nothing a command does not need.
"""

import importlib

__version__ = '0.1.0'

_HOMES = {
    'Body': 'cfem_ros.core.model.bodies',
    'Joint': 'cfem_ros.core.model.joints',
    'Model': 'cfem_ros.core.model.model',
    'Release': 'cfem_ros.core.model.joints',
    'CfemError': 'cfem_ros.core.errors',
    'ScenarioError': 'cfem_ros.core.errors',
    'RecordingError': 'cfem_ros.recording.errors',
    'Simulator': 'cfem_ros.core.engine.simulator',
    'load_scenario': 'cfem_ros.core.scenario.parse',
    'parse_scenario': 'cfem_ros.core.scenario.parse',
}

__all__ = sorted(_HOMES)


def __getattr__(name):
    """Load a public name from its home module on first use (PEP 562)."""
    if name in _HOMES:
        value = getattr(importlib.import_module(_HOMES[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


def __dir__():
    """List the public names with the module's own."""
    return sorted(set(globals()) | set(_HOMES))
