# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The package builds with colcon in a workspace, and what it installs runs."""

import os
import pathlib
import shutil
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_colcon_build_installs_a_working_package(tmp_path):
    source = tmp_path / 'src' / 'cfem_ros'
    ignore = shutil.ignore_patterns('.venv', '.git', 'build', 'install', 'log', 'runs',
                                    '__pycache__', '*.egg-info', '.pytest_cache')
    shutil.copytree(ROOT, source, ignore=ignore)
    colcon = pathlib.Path(sys.executable).parent / 'colcon'
    build = subprocess.run([str(colcon), 'build'], cwd=tmp_path, capture_output=True,
                           text=True, timeout=600)
    assert build.returncode == 0, build.stdout + build.stderr
    prefix = tmp_path / 'install' / 'cfem_ros'
    share = prefix / 'share' / 'cfem_ros'
    assert (share / 'package.xml').is_file()
    assert (prefix / 'share' / 'ament_index' / 'resource_index' / 'packages'
            / 'cfem_ros').is_file()
    assert (share / 'config' / 'joints' / 'universal.yaml').is_file()
    script = prefix / 'lib' / 'cfem_ros' / 'cfem-sim'
    assert script.is_file()
    site = next(prefix.glob('lib/python3*/site-packages'))
    env = dict(os.environ, PYTHONPATH=str(site))
    # what the README asks of a colcon install: compile the numerical core once. Its
    # result, the kernel compiled ahead of time for these sources on this machine, is
    # what make built in the source tree: put in the install, it must be taken (the
    # installed sources hash to it). Compiling takes minutes and is tested on its own
    # (test/core/test_warmup.py, test_aot.py); without a build, the JIT compiles here
    core = ROOT / 'cfem_ros' / 'core'
    built = sorted(core.glob('_kernel_aot*.so'))
    if built and (core / '_kernel_aot.json').is_file():
        for path in (built[0], core / '_kernel_aot.json'):
            shutil.copy2(path, site / 'cfem_ros' / 'core')
        expected = 'numerical core compiled ahead of time'
    else:
        env['CFEM_ROS_JIT'] = '1'
        expected = 'numerical core compiled'
    warm = subprocess.run([sys.executable, '-m', 'cfem_ros.core.warmup'], capture_output=True,
                          text=True, env=env, cwd=tmp_path, timeout=900)
    assert warm.returncode == 0, warm.stderr
    assert expected in warm.stderr, warm.stderr
    check = subprocess.run([sys.executable, str(script), 'check',
                            str(share / 'config' / 'store_separation.yaml')],
                           capture_output=True, text=True, env=env, timeout=120)
    assert check.returncode == 0, check.stderr
    assert 'degrees of freedom: 1' in check.stdout
    # ros2 run cfem_ros cfem_node, and what ros2 launch needs
    assert (share / 'launch' / 'cfem_sim.launch.py').is_file()
    assert (share / 'config' / 'cfem_node.params.yaml').is_file()
    node = prefix / 'lib' / 'cfem_ros' / 'cfem_node'
    run = subprocess.run([str(node), '--ros-args',
                          '--params-file', str(share / 'config' / 'cfem_node.params.yaml'),
                          '-p', f'scenario:={share / "config" / "store_separation.yaml"}',
                          '-p', 'real_time_factor:=0.0', '-p', 'duration:=0.2'],
                         capture_output=True, text=True, env=env, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr
    assert 'run complete at t = 0.2 s' in run.stdout + run.stderr
