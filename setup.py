# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Install cfem_ros as an ament_python package (pip or colcon)."""

from glob import glob
import os

from setuptools import find_packages, setup

package_name = 'cfem_ros'


def tree(folder):
    """Return data_files entries that install every file under folder."""
    entries = {}
    for path in glob(os.path.join(folder, '**', '*'), recursive=True):
        if os.path.isfile(path):
            target = os.path.join('share', package_name, os.path.dirname(path))
            entries.setdefault(target, []).append(path)
    return sorted(entries.items())


setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*', 'benchmarks']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ] + tree('config') + tree('launch'),
    python_requires='>=3.10',
    install_requires=[
        'setuptools',
        'numpy>=1.24',
        'scipy>=1.10',
        'PyYAML>=6.0',
        'mcap>=1.1',
        'mcap-ros2-support>=0.5',
        'numba>=0.59',
        'matplotlib>=3.6',
    ],
    extras_require={
        'ros': [
            'ros-kilted-rclpy',
            'ros-kilted-std-msgs',
            'ros-kilted-geometry-msgs',
            'ros-kilted-rosgraph-msgs',
            'ros-kilted-rcl-interfaces',
            'ros-kilted-visualization-msgs',
            'ros-kilted-nav-msgs',
            'ros-kilted-rmw-fastrtps-cpp',
        ],
        # the benchmark peer (benchmarks/suite.py); never needed to run cfem_ros
        'bench': ['mujoco'],
        # separation studies (cfem-sim sweep / summarize / report, cfem_ros.study):
        # rare events with OpenTURNS, sensitivities with SALib
        'study': ['dask[distributed]>=2024.1', 'pandas>=2.0', 'pyarrow>=14',
                  'openturns>=1.22', 'SALib>=1.4.7'],
        'test': [
            'pytest',
            'hypothesis',
            'rosbags>=0.10',
            'ros-kilted-ament-flake8',
            'ros-kilted-ament-pep257',
            'pydocstyle',
            'flake8-quotes',
            'flake8-import-order',
            'flake8-builtins',
            'flake8-comprehensions',
            'catkin_pkg',
            'colcon-common-extensions',
        ],
    },
    zip_safe=True,
    maintainer='cfem_ros maintainers',
    maintainer_email='cfem-ros@example.org',
    description='CFEM multibody simulation with releasable joints, for ROS 2',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'cfem-sim = cfem_ros.console:main',
            'cfem_node = cfem_ros.console:node_entry_point',
            'cfem_pub = cfem_ros.ros.publish:entry_point',
        ],
    },
)
