# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Start cfem_node on a scenario (ROS 2 installs with launch).

    ros2 launch cfem_ros cfem_sim.launch.py
    ros2 launch cfem_ros cfem_sim.launch.py scenario:=/path/to/my.yaml record:=run.mcap
    ros2 launch cfem_ros cfem_sim.launch.py use_sim_time:=true   # beside ros2 bag play --clock
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare


def generate_launch_description():
    """Declare the arguments and the cfem_sim node."""
    share = FindPackageShare('cfem_ros')
    arguments = [
        DeclareLaunchArgument(
            'scenario', default_value=PathJoinSubstitution(
                [share, 'config', 'store_release_on_command.yaml']),
            description='scenario file (YAML)'),
        DeclareLaunchArgument(
            'params_file', default_value=PathJoinSubstitution(
                [share, 'config', 'cfem_node.params.yaml']),
            description='parameters of the node (rate_hz, real_time_factor, ...)'),
        DeclareLaunchArgument('namespace', default_value='cfem',
                              description='namespace of every topic'),
        DeclareLaunchArgument('record', default_value='',
                              description='MCAP file to record to; empty records nothing'),
        DeclareLaunchArgument('use_sim_time', default_value='false',
                              description='follow /clock (ros2 bag play --clock)'),
    ]
    node = Node(
        package='cfem_ros',
        executable='cfem_node',
        name='cfem_sim',
        namespace=LaunchConfiguration('namespace'),
        output='screen',
        emulate_tty=True,
        parameters=[
            LaunchConfiguration('params_file'),
            {
                'scenario': LaunchConfiguration('scenario'),
                'record': LaunchConfiguration('record'),
                'use_sim_time': ParameterValue(LaunchConfiguration('use_sim_time'),
                                               value_type=bool),
            },
        ],
    )
    return LaunchDescription(arguments + [node])
