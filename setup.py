# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Install cfem_ros as an ament_python package (pip or colcon).

Both build the compiled core, the extension module ``cfem_ros.core._kernel``
(C++17, pybind11), from ``cfem_ros/core/cpp`` with the system compiler.
"""

from glob import glob
import os
import sys

from setuptools import find_packages, setup

try:
    from pybind11.setup_helpers import build_ext, has_flag, ParallelCompile, Pybind11Extension
except ImportError:   # colcon runs setup.py without build isolation
    sys.exit('ERROR: building cfem_ros needs pybind11 (pip install pybind11, or apt install '
             'python3-pybind11; rosdep installs it from package.xml)')

package_name = 'cfem_ros'
CPP = os.path.join('cfem_ros', 'core', 'cpp')
#: Flags of some sources beyond the others': the crossing search (kernel.locate) rounds
#: as scipy's brentq and numpy do (the tests' reference search), with no contraction of
#: a * b + c into fused multiply-adds.
SOURCE_FLAGS = {'events.cpp': ['-ffp-contract=off']}
#: The instruction set: the build machine's own by default, like any source build;
#: CFEM_ROS_ARCH=x86-64-v3 (or v2) for a binary that runs on other machines.
ARCH = os.environ.get('CFEM_ROS_ARCH', 'native')
#: -O3 without GCC's vectorizer, and without its tuning that splits chains of fused
#: multiply-adds on some CPUs (AMD Zen): with either, which multiply-adds are fused would
#: depend on the CPU, and differ from earlier builds, whose numbers this build keeps
#: (docs/guide/compiled-core.md, CHANGELOG.md).
#: A flag the compiler does not know is left out.
FLAGS = ['-O3', '-fno-math-errno', '-fno-tree-vectorize', '-fno-tree-slp-vectorize',
         '--param=avoid-fma-max-bits=0', '-Wall'] + ([f'-march={ARCH}'] if ARCH else [])


class BuildCore(build_ext):
    """pybind11's build_ext, compiling the sources of SOURCE_FLAGS with their flags."""

    def build_extension(self, ext):
        """Compile the sources with flags of their own, then the rest and the link."""
        ext.extra_compile_args = [f for f in ext.extra_compile_args
                                  if f in ('-O3', '-Wall') or has_flag(self.compiler, f)]
        for name, flags in SOURCE_FLAGS.items():
            sources = [s for s in ext.sources if os.path.basename(s) == name]
            if not sources:
                continue
            objects = self.compiler.compile(
                sources, output_dir=self.build_temp, include_dirs=ext.include_dirs,
                extra_postargs=ext.extra_compile_args + flags, depends=ext.depends)
            ext.sources = [s for s in ext.sources if s not in sources]
            ext.extra_objects = list(ext.extra_objects or []) + objects
        super().build_extension(ext)


ParallelCompile('CFEM_ROS_BUILD_JOBS', default=0).install()   # one job per core


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
    ext_modules=[Pybind11Extension(
        'cfem_ros.core._kernel', sorted(glob(os.path.join(CPP, '*.cpp'))), cxx_std=17,
        extra_compile_args=FLAGS + ['-ffp-contract=fast'],
        depends=sorted(glob(os.path.join(CPP, '*.hpp'))))],
    cmdclass={'build_ext': BuildCore},
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
        # the benchmark peers (benchmarks/suite.py: MuJoCo; benchmarks/bench_pinocchio.py:
        # Pinocchio's aba); never needed to run cfem_ros
        'bench': ['mujoco', 'pin'],
        # separation studies (cfem-sim sweep / summarize / report, cfem_ros.study):
        # rare events with OpenTURNS, sensitivities with SALib
        'study': ['dask[distributed]>=2024.1', 'pandas>=2.0', 'pyarrow>=14',
                  'openturns>=1.22', 'SALib>=1.4.7'],
        # the user guide (make docs; rosdoc2 reads the same docs/conf.py)
        'docs': ['sphinx>=7', 'myst-parser>=2'],
        'test': [
            'pybind11>=2.10',   # colcon build runs setup.py without build isolation
            'pytest',
            'pytest-xdist',   # make test runs the suite in two processes
            'hypothesis',
            'rosbags>=0.10',
            # the reference for the shape distances (test/core/test_shape_distance.py)
            'coal>=3.0',
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
    zip_safe=False,
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
