# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The package builds with pip in a clean venv and with colcon in a workspace; both run.

The C++ core (``cfem_ros.core._kernel``) is compiled once, by pip, from a
copy of the source (``built``: a wheel, 3 to 4 minutes of a core when
compiled cold); colcon's build of the same sources starts with that
extension in its build folder, up to date, so that it builds, installs and
runs everything else without compiling the core again (issue 47.5). Either
way a scenario runs right after, with nothing compiled at run time.

With ccache on PATH (``make test`` installs it) the compiler runs through
it, in the layout of ``make test``'s own build of the core in the checkout
(the build requirements in ``.venv`` inside the source folder, paths hashed
relative to it, ccache's base_dir): the compile of sources that ``make
test`` has just built, or that an earlier session built, is a cache hit,
the object files the compiler made for the same preprocessed sources and
flags.
"""

import os
import pathlib
import shutil
import subprocess
import sys
import sysconfig
import types
import zipfile

import pytest

try:
    import tomllib
except ModuleNotFoundError:   # Python 3.10
    from pip._vendor import tomli as tomllib

ROOT = pathlib.Path(__file__).resolve().parents[1]
IGNORE = shutil.ignore_patterns('.venv', '.git', 'build', 'install', 'log', 'runs', '__pycache__',
                                '*.egg-info', '.pytest_cache', '*.so')


def _run_a_scenario(python, env, folder, name):
    """Run and record a shipped scenario with python (a fresh process), and check it ran."""
    out = folder / f'{name}.mcap'
    code = ('import sys; from cfem_ros import cli; '
            'status = cli.main(sys.argv[1:]); '
            "assert 'numba' not in sys.modules; sys.exit(status)")
    done = subprocess.run([python, '-c', code, 'run', str(ROOT / 'config' / f'{name}.yaml'),
                           '-o', str(out)], capture_output=True, text=True, env=env,
                          cwd=folder, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    assert 'release pivot at t = 0.280158914 s' in done.stdout, done.stdout
    assert out.stat().st_size > 10_000


def compiler_through_ccache(folder: pathlib.Path) -> dict:
    """
    Return the environment changes that send the build's compiler calls through ccache.

    A folder of links named as the compilers (ccache's masquerade) goes first
    on PATH: the compile commands stay as they are. Paths under folder are
    hashed relative to the working directory, and the directory itself not,
    so that another session's folder finds the same entries. Nothing without
    ccache.
    """
    ccache = shutil.which('ccache')
    if ccache is None:
        return {}
    links = folder / 'ccache-bin'
    links.mkdir()
    names = {'cc', 'c++', 'gcc', 'g++'}
    names |= {(sysconfig.get_config_var(v) or 'cc').split()[0] for v in ('CC', 'CXX')}
    for name in names:
        if '/' not in name:
            (links / name).symlink_to(ccache)
    return {'PATH': f'{links}{os.pathsep}{os.environ.get("PATH", "")}',
            'CCACHE_BASEDIR': str(folder), 'CCACHE_NOHASHDIR': '1'}


@pytest.fixture(scope='module')
def built(tmp_path_factory):
    """
    Return a clean venv and the package's wheel, built by pip from a copy of the source.

    pip builds it as a user's ``pip install`` does in an isolated build
    environment: in a venv of its own that holds nothing but the build
    requirements pyproject.toml names (setuptools, pybind11, from the
    index), compiling the core with the system compiler. That venv is
    ``.venv`` in the copy, as ``make test`` builds in the checkout
    (``ccache``).
    """
    folder = tmp_path_factory.mktemp('built')
    source = folder / 'cfem_ros'
    shutil.copytree(ROOT, source, ignore=IGNORE)
    venv, tools = folder / 'venv', source / '.venv'
    for where in (venv, tools):
        subprocess.run([sys.executable, '-m', 'venv', str(where)], check=True, timeout=120)
    python = venv / 'bin' / 'python'
    requires = tomllib.loads((source / 'pyproject.toml').read_text())['build-system']['requires']
    # the newest that meet them, as pip's isolated build takes (not the venv's own setuptools)
    setup = subprocess.run([str(tools / 'bin' / 'python'), '-m', 'pip', 'install', '-q',
                            '--upgrade', *requires], capture_output=True, text=True, timeout=600)
    assert setup.returncode == 0, setup.stdout + setup.stderr
    build = subprocess.run([str(tools / 'bin' / 'python'), '-m', 'pip', 'wheel', '-q',
                            '--no-deps', '--no-build-isolation', '-w', str(folder / 'dist'),
                            str(source)], capture_output=True, text=True, timeout=900,
                           env=dict(os.environ, **compiler_through_ccache(folder)))
    assert build.returncode == 0, build.stdout + build.stderr
    wheel = next((folder / 'dist').glob('cfem_ros-*.whl'))
    with zipfile.ZipFile(wheel) as archive:
        kernel = [name for name in archive.namelist()
                  if name.startswith('cfem_ros/core/_kernel') and name.endswith('.so')]
        assert len(kernel) == 1, archive.namelist()   # the core, compiled
        core = archive.read(kernel[0])
    return types.SimpleNamespace(folder=folder, python=python, wheel=wheel,
                                 kernel_name=pathlib.PurePath(kernel[0]).name, kernel=core)


@pytest.mark.slow
def test_colcon_build_installs_a_working_package(tmp_path, built):
    source = tmp_path / 'src' / 'cfem_ros'
    shutil.copytree(ROOT, source, ignore=IGNORE)
    # the core pip compiled from these sources, newer than them: setuptools' build_ext
    # finds it up to date in colcon's build folder and does not compile it again
    platform = f'{sysconfig.get_platform()}-{sys.implementation.cache_tag}'
    lib = tmp_path / 'build' / 'cfem_ros' / 'build' / f'lib.{platform}' / 'cfem_ros' / 'core'
    lib.mkdir(parents=True)
    (lib / built.kernel_name).write_bytes(built.kernel)
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
    # the install holds the extension, ready at once
    assert (site / 'cfem_ros' / 'core' / built.kernel_name).read_bytes() == built.kernel
    env = dict(os.environ, PYTHONPATH=str(site))
    _run_a_scenario(sys.executable, env, tmp_path, 'store_separation')
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
    _drive_with_simulation_interfaces(tmp_path, node, share, env)


def _drive_with_simulation_interfaces(folder, executable, share, env):
    """
    Pause, step, read, reset and play the installed node with the standard types only.

    On a ROS 2 install rosdep brings ``simulation_interfaces``; here the one
    ``make interfaces`` built into this venv stands in for it, and the node
    is the workspace's.
    """
    from rosharness import NodeProcess, stamp_ns
    from simclient import Client, pose_of
    from simulation_interfaces.msg import Result, SimulationState
    node = NodeProcess(folder, share / 'config' / 'store_separation.yaml',
                       executable=executable, env=env, paused=True, duration=0.0)
    client = Client()
    try:
        client.ready(node)
        assert client.call('get_simulation_state').state.state == SimulationState.STATE_PAUSED
        start = client.state('store')
        assert client.call('step_simulation', steps=7).result.result == Result.RESULT_OK
        stepped = client.state('store')
        assert stamp_ns(stepped.header) - stamp_ns(start.header) == 7_000_000   # dt = 1 ms
        assert pose_of(stepped) != pose_of(start)   # the store swings on its hinge
        assert client.call('reset_simulation').result.result == Result.RESULT_OK
        assert pose_of(client.state('store')) == pose_of(start)
        assert client.set_state(SimulationState.STATE_PLAYING).result == Result.RESULT_OK
        assert client.set_state(SimulationState.STATE_QUITTING).result == Result.RESULT_OK
        assert node.wait(timeout=60.0) == 0, node.output
    finally:
        client.close()
        node.stop()


@pytest.mark.slow
def test_pip_install_in_a_clean_venv_builds_the_core(tmp_path, built):
    # the package alone, as pip built it (``built``); the run's dependencies (numpy,
    # mcap ...) are this environment's, found after the new venv's own packages
    install = subprocess.run([str(built.python), '-m', 'pip', 'install', '-q', '--no-deps',
                              str(built.wheel)], capture_output=True, text=True, timeout=600)
    assert install.returncode == 0, install.stdout + install.stderr
    site = next((built.folder / 'venv').glob('lib/python3*/site-packages'))
    assert (site / 'cfem_ros' / 'core' / built.kernel_name).read_bytes() == built.kernel
    here = next(pathlib.Path(sys.prefix).glob('lib/python3*/site-packages'))
    (site / 'dependencies.pth').write_text(f'{here}\n')
    _run_a_scenario(str(built.python), dict(os.environ, PYTHONPATH=''), tmp_path,
                    'store_separation')
