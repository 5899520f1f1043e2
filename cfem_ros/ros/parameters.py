# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The node's parameters (SPEC section 3): their defaults, ranges and descriptions.

``declare`` declares them on a node and returns their values, refusing a bad
one with a ``StartupError``; ``warn_unknown`` warns about a parameter given
that the node does not have.
"""

from cfem_ros.core.errors import CfemError
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import ParameterException

#: Parameters rclpy itself reads: never reported as unknown.
_ROS_PARAMETERS = ('use_sim_time', 'start_type_description_service')


class StartupError(CfemError):
    """A parameter or scenario the node cannot start with."""


def _double(description: str, low: float, high: float, read_only: bool = True):
    return ParameterDescriptor(
        description=description, read_only=read_only,
        floating_point_range=[FloatingPointRange(from_value=low, to_value=high, step=0.0)])


def _integer(description: str, low: int, high: int):
    return ParameterDescriptor(description=description, read_only=True,
                               integer_range=[IntegerRange(from_value=low, to_value=high,
                                                           step=1)])


#: name -> (default, descriptor, what a right value is)
PARAMETERS = {
    'scenario': ('', ParameterDescriptor(
        description='path of the scenario file (YAML, SPEC section 1)', read_only=True),
        'the path of a scenario file, e.g. -p scenario:=config/store_separation.yaml'),
    'rate_hz': (100.0, _double(
        'samples published per simulated second (stamps 1/rate_hz apart)', 0.01, 1e5),
        'a rate in Hz written as a double, 0.01 to 1e5, e.g. -p rate_hz:=100.0'),
    'real_time_factor': (1.0, _double(
        'simulated seconds per wall second; 0 runs as fast as possible; '
        'ignored with use_sim_time', 0.0, 1e4, read_only=False),
        'a double from 0 (as fast as possible) to 1e4, e.g. -p real_time_factor:=1.0'),
    'duration': (-1.0, _double(
        "simulated seconds to run, then finish and exit; < 0: the scenario's duration; "
        '0: until shut down', -1.0, 1e9),
        "a double: < 0 for the scenario's duration, 0 to run until shut down, "
        'else seconds'),
    'record': ('', ParameterDescriptor(
        description='MCAP file to record this run to (SPEC section 4); empty records nothing',
        read_only=True), 'a file path ending in .mcap, or empty'),
    'overwrite': (False, ParameterDescriptor(
        description='replace the record file if it exists', read_only=True),
        'true or false'),
    'paused': (False, ParameterDescriptor(
        description='start paused: the initial state is published, then the node waits for '
        'a play or a step (simulation_interfaces services)', read_only=True),
        'true or false'),
    'interpolate_odometry': (True, ParameterDescriptor(
        description='a kinematic body following bodies/<body>/odom moves on the cubic between '
        'its messages: the simulation waits for the next message (at most the 0.1 s '
        'horizon of clock time), so it runs up to one odometry period behind the clock; '
        'false: extrapolated from the latest message, never behind', read_only=True),
        'true or false'),
    'input_window': (0.05, _double(
        'with use_sim_time: simulated seconds the simulation stays behind /clock, so that an '
        'input stamped before a /clock that arrives up to that much later still takes effect '
        'at its stamp (a replay gives the same run on a loaded machine); when /clock stands '
        'still (the end of a replay) the simulation goes on to it', 0.0, 10.0),
        'a double of simulated seconds from 0 to 10, e.g. -p input_window:=0.05'),
    'input_queue_depth': (1000, _integer(
        'messages each input topic keeps until the node takes them (a full queue loses the '
        'oldest: counted as dropped_inputs and warned about)', 1, 1_000_000),
        'an integer from 1 to 1000000, e.g. -p input_queue_depth:=1000'),
}


def declare(node) -> dict:
    """Declare the node's parameters; return their values (StartupError if one is bad)."""
    values = {}
    for name, (default, descriptor, expected) in PARAMETERS.items():
        try:
            values[name] = node.declare_parameter(name, default, descriptor).value
        except ParameterException as err:
            raise StartupError(f'parameter {name}: {err}; expected {expected}') from None
    if not values['scenario']:
        raise StartupError('parameter scenario: not set; expected '
                           + PARAMETERS['scenario'][2])
    return values


def warn_unknown(node):
    """Warn about each parameter given (-p, --params-file) that the node does not have."""
    given = getattr(node, '_parameter_overrides', {})
    for name in sorted(given):
        if name in PARAMETERS or name in _ROS_PARAMETERS or name.startswith('qos_overrides.'):
            continue
        node.get_logger().warning(
            f'parameter {name!r} is not a parameter of cfem_node; ignored (its parameters: '
            f"{', '.join(list(PARAMETERS) + ['use_sim_time'])})")
