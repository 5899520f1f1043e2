# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The batch API under its first name; its home is ``cfem_ros.core.run.batch``."""

from cfem_ros.core.run.batch import *  # noqa: F401, F403
from cfem_ros.core.run.batch import __all__  # noqa: F401
