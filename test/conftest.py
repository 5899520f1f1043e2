# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Test session set-up: reference helpers importable, DDS isolated."""

import os
import random
import sys

sys.path.insert(0, os.path.dirname(__file__))

#: DDS domains each test process may use: ROS_DOMAIN_ID and the next ones (the user
#: guide's walk-throughs run in lanes of their own).
DOMAINS_EACH = 3

# Node tests must never meet another session's nodes, nor, with pytest-xdist, another
# worker's: the session draws a first domain, each worker takes the next DOMAINS_EACH.
os.environ.setdefault('CFEM_TEST_DOMAIN', str(random.randint(1, 101 - 8 * DOMAINS_EACH)))
_WORKER = os.environ.get('PYTEST_XDIST_WORKER', 'gw0')
os.environ['ROS_DOMAIN_ID'] = str(int(os.environ['CFEM_TEST_DOMAIN'])
                                  + DOMAINS_EACH * int(_WORKER.removeprefix('gw') or 0))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'

#: Test files that take tens of seconds, longest first (--durations), started first so
#: that the two test processes (make test: pytest-xdist, a file's tests in one process)
#: end together: the first two run side by side (test_colcon.py compiles the core, minutes,
#: when ccache has not seen its sources).
LONG_FILES = ('test_doc_commands.py', 'test_colcon.py', 'test_player.py', 'test_node_kills.py',
              'test_node.py', 'test_fit_uncertainty.py', 'test_sweep_dask.py', 'test_flake8.py',
              'test_node_flood.py', 'test_robust_files.py', 'test_fit.py', 'test_node_inputs.py',
              'test_analysis.py')


def pytest_collection_modifyitems(config, items):
    """Put the long files first, in LONG_FILES order; the rest keep their order."""
    def rank(item):
        name = item.path.name
        return LONG_FILES.index(name) if name in LONG_FILES else len(LONG_FILES)
    items.sort(key=rank)   # stable
