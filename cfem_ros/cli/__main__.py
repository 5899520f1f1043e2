# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""``python -m cfem_ros.cli``: cfem-sim without the console script."""

import sys

from cfem_ros.cli import main

sys.exit(main())
