# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Docstring style through ament_pep257, as every ROS 2 Python package runs it."""

from ament_pep257.main import main
import pytest


@pytest.mark.linter
@pytest.mark.pep257
def test_pep257():
    rc = main(argv=['.', 'test'])
    assert rc == 0, 'Found code style errors / warnings'
