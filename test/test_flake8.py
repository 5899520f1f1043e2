# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""flake8 through ament_flake8, as every ROS 2 Python package runs it."""

from ament_flake8.main import main_with_errors
import pytest


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8():
    rc, errors = main_with_errors(argv=[])
    assert rc == 0, \
        'Found %d code style errors / warnings:\n' % len(errors) + '\n'.join(errors)
