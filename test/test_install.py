# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A script beside the clone imports the package, not the clone's folder.

``~/cfem_ros`` (the clone) beside ``~/script.py``: Python puts ``~`` first on
sys.path and finds the folder ``~/cfem_ros`` (no ``__init__.py``) before an
editable install's import hook, so ``import cfem_ros`` gave an empty namespace
package. An editable install made as a path entry (setup.cfg's
``[editable_wheel] mode = compat``, which ``pip install -e .`` and ``make``
read) puts the clone itself on sys.path, where the regular package wins.
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


def test_a_script_beside_the_clone_imports_the_package(tmp_path):
    (tmp_path / 'cfem_ros').symlink_to(ROOT, target_is_directory=True)   # the clone
    script = tmp_path / 'script.py'
    script.write_text('from cfem_ros import load_scenario\nprint(load_scenario.__module__)\n')
    # the path entry a compat editable install writes (its .pth holds the clone's path)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith('cfem_ros.')
    # without it (an import-hook install), the trap the path entry avoids
    env['PYTHONPATH'] = ''
    done = subprocess.run([sys.executable, '-S', str(script)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)
    assert "cannot import name 'load_scenario' from 'cfem_ros' (unknown location)" in done.stderr
