# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A script beside the clone imports the package, not the clone's folder.

``~/cfem_ros`` (the clone) beside ``~/script.py``: Python puts ``~`` first on
sys.path and finds the folder ``~/cfem_ros`` there. Without the clone's
root ``__init__.py`` that folder became an empty namespace package
(``cannot import name 'load_scenario' from 'cfem_ros' (unknown location)``);
with it, the installed package is loaded in its place (quietly when it is the
clone's own editable install, with a warning otherwise), and an ImportError
says what to do when nothing is installed. An editable install is also made as
a path entry (setup.cfg's ``[editable_wheel] mode = compat``), which puts the
clone itself on sys.path.
"""

import configparser
import os
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]


def test_editable_installs_are_path_entries():
    config = configparser.ConfigParser()
    config.read(ROOT / 'setup.cfg')
    assert config['editable_wheel']['mode'] == 'compat'


def beside_the_clone(tmp_path, pythonpath, isolated=False):
    """Run a script in the folder that holds the clone; return the finished process."""
    (tmp_path / 'cfem_ros').symlink_to(ROOT, target_is_directory=True)   # the clone
    script = tmp_path / 'script.py'
    script.write_text('from cfem_ros import load_scenario\nprint(load_scenario.__module__)\n')
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(map(str, pythonpath)))
    return subprocess.run([sys.executable] + (['-S'] if isolated else []) + [str(script)],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)


def test_a_script_beside_the_clone_imports_the_package(tmp_path):
    # the path entry a compat editable install writes (its .pth holds the clone's path)
    done = beside_the_clone(tmp_path, [ROOT])
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith('cfem_ros.core.')
    assert 'Warning' not in done.stderr   # the clone's own install: nothing to say


def test_an_installed_package_elsewhere_is_loaded_with_a_warning(tmp_path):
    site = tmp_path / 'site'   # another install of cfem_ros, found without a .pth (-S)
    (site / 'cfem_ros').mkdir(parents=True)
    (site / 'cfem_ros' / '__init__.py').write_text('def load_scenario():\n    pass\n')
    work = tmp_path / 'work'
    work.mkdir()
    done = beside_the_clone(work, [site], isolated=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == 'cfem_ros'   # the installed package's function
    assert f'beside the folder {work / "cfem_ros"}' in done.stderr
    assert f'the installed package {site / "cfem_ros"} was loaded instead' in done.stderr


def test_no_installed_package_says_what_to_do(tmp_path):
    done = beside_the_clone(tmp_path, [], isolated=True)
    assert done.returncode == 1
    message = done.stderr.strip().splitlines()[-1]
    clone = tmp_path / 'cfem_ros'
    assert message.startswith(f"ImportError: 'cfem_ros' here is the folder {clone}")
    assert f'is not installed for {sys.executable}' in message
    assert 'pip install -e' in message and 'unknown location' not in done.stderr
