# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The ROS 2 adapters: the simulation node and the command-line publisher.

The only layer that imports rclpy; it drives the core and the recording
layer and adds nothing numerical of its own.
"""
