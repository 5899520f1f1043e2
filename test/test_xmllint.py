# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""package.xml is well-formed, valid format 3, and declares what the code imports."""

import pathlib
from xml.dom import minidom

from catkin_pkg.package import parse_package
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.mark.xmllint
@pytest.mark.linter
def test_package_xml():
    minidom.parse(str(ROOT / 'package.xml'))   # raises on malformed XML
    package = parse_package(str(ROOT / 'package.xml'))
    package.validate()
    assert package.package_format == 3
    assert package.name == 'cfem_ros'
    assert package.get_build_type() == 'ament_python'
    runtime = {d.name for d in package.exec_depends}
    for needed in ('rclpy', 'std_msgs', 'geometry_msgs', 'python3-numpy', 'python3-scipy',
                   'python3-yaml'):
        assert needed in runtime, f'package.xml does not declare {needed}'
    # the compiled core is C++ built by setup.py with pybind11; no JIT at run time
    assert 'python3-pybind11' in {d.name for d in package.build_depends}
    assert 'python3-numba' not in runtime
