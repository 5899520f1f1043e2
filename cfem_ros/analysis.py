# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The analysis API under its first name; its home is ``cfem_ros.recording.analysis``."""

from cfem_ros.recording.analysis import *  # noqa: F401, F403
from cfem_ros.recording.analysis import __all__  # noqa: F401
