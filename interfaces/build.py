# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Build simulation_interfaces (1.6.1) from interfaces/simulation_interfaces into this venv.

The pip route has no wheel of the ROS 2 standard simulator interfaces, so this
builds the interface package with the ROS wheels' own generators (ament_cmake,
rosidl_default_generators; cmake and ninja from pip), with the venv as the
install prefix: the venv's Python then imports ``simulation_interfaces`` with
nothing to source. About 3 CPU-minutes. A ROS 2 distribution install does
not need it (rosdep installs ros-$ROS_DISTRO-simulation-interfaces).

Usage: .venv/bin/python interfaces/build.py   (or: make interfaces)

The traps it takes care of:

- several ``ros-kilted-*`` wheels miss dependencies in their metadata
  (``BUILD_TOOLS`` lists them with the rest);
- the wheels' ``*__rosidl_generator_pyExport.cmake`` files name the wheel
  builder's Python and numpy include folders (``/opt/python/...``): they are
  pointed at this Python's;
- ``AMENT_PREFIX_PATH`` and ``CMAKE_PREFIX_PATH`` must name the venv while
  building.
"""

import os
import pathlib
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile

HERE = pathlib.Path(__file__).resolve().parent
SOURCE = HERE / 'simulation_interfaces'
PREFIX = pathlib.Path(sys.prefix)
#: What building an ament_cmake interface package needs from pip.
BUILD_TOOLS = [
    'ros-kilted-rosidl-default-generators', 'ros-kilted-rosidl-default-runtime',
    'ros-kilted-ament-cmake', 'ros-kilted-std-msgs', 'ros-kilted-geometry-msgs',
    # what those wheels' metadata forgets
    'ros-kilted-ament-package', 'ros-kilted-ament-cmake-include-directories',
    'ros-kilted-rosidl-core-generators', 'ros-kilted-ament-cmake-ros-core', 'catkin_pkg',
    'cmake', 'ninja',
]
#: The include folders a wheel's generated CMake file names, the wheel builder's own.
BUILDER_INCLUDES = re.compile(r'/opt/python/cp\d+-cp\d+/[^;"]*')


def step(message: str):
    print(f'simulation_interfaces: {message}', flush=True)


def install_tools():
    """Install what the build needs into the venv (pip; cached wheels are reused)."""
    step('installing the ROS build tools from pip')
    subprocess.run([sys.executable, '-m', 'pip', 'install', '-q'] + BUILD_TOOLS, check=True)


def fix_exports() -> int:
    """Point the wheels' pyExport CMake files at this Python's include folders; return how many."""
    import numpy
    python = sysconfig.get_paths()['include']
    if not pathlib.Path(python, 'Python.h').is_file():
        sys.exit(f'ERROR: {python}/Python.h is missing: install the Python headers '
                 f'(apt-get install python3-dev) and run {sys.argv[0]} again')
    fixed = 0
    for path in PREFIX.glob('share/*/cmake/*__rosidl_generator_pyExport.cmake'):
        text = path.read_text()

        def ours(match):
            return numpy.get_include() if 'numpy' in match.group(0) else python

        new = BUILDER_INCLUDES.sub(ours, text)
        if new != text:
            path.write_text(new)
            fixed += 1
    return fixed


def build():
    """Configure, build and install the package into the venv."""
    bin_dir = pathlib.Path(sys.executable).parent
    env = dict(os.environ, AMENT_PREFIX_PATH=str(PREFIX), CMAKE_PREFIX_PATH=str(PREFIX),
               PATH=f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}")
    cmake = shutil.which('cmake', path=env['PATH'])
    with tempfile.TemporaryDirectory(prefix='simulation_interfaces-') as work:
        step('configuring')
        subprocess.run([cmake, '-S', str(SOURCE), '-B', work, '-G', 'Ninja',
                        f'-DCMAKE_INSTALL_PREFIX={PREFIX}',
                        f'-DPython3_EXECUTABLE={sys.executable}',
                        '-DBUILD_TESTING=OFF', '-DCMAKE_BUILD_TYPE=Release'],
                       check=True, env=env, stdout=subprocess.DEVNULL)
        step('building (about 3 CPU-minutes)')
        subprocess.run([cmake, '--build', work], check=True, env=env,
                       stdout=subprocess.DEVNULL)
        subprocess.run([cmake, '--install', work], check=True, env=env,
                       stdout=subprocess.DEVNULL)


def check():
    """Import the types in a fresh interpreter (as the node will)."""
    subprocess.run([sys.executable, '-c', 'from simulation_interfaces.srv import '
                    'GetSimulatorFeatures; '
                    'from simulation_interfaces.action import SimulateSteps'], check=True)


def main() -> int:
    if sys.prefix == sys.base_prefix:
        sys.exit("ERROR: run this with the venv's Python (.venv/bin/python interfaces/build.py)")
    install_tools()
    step(f'{fix_exports()} generator files pointed at this Python')
    build()
    check()
    step(f'installed into {PREFIX}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
