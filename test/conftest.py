# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Test session set-up: reference helpers importable, DDS isolated."""

import os
import random
import sys

sys.path.insert(0, os.path.dirname(__file__))

# Node tests must never meet another session's nodes.
os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 100)))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
