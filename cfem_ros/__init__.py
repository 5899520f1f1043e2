# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Rigid bodies joined by releasable joints, simulated with CFEM."""

from cfem_ros.engine import Simulator
from cfem_ros.errors import CfemError, RecordingError, ScenarioError
from cfem_ros.model import Body, Joint, Model, Release
from cfem_ros.scenario import load_scenario, parse_scenario

__all__ = [
    'Body', 'CfemError', 'Joint', 'Model', 'RecordingError', 'Release',
    'ScenarioError', 'Simulator', 'load_scenario', 'parse_scenario',
]
__version__ = '0.1.0'
