# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The cfem_ros repository, imported as if it were the package.

Python imports this file only when a script runs in the folder that holds the
clone (``~/cfem_ros`` beside ``~/script.py``): the script's folder comes first
on ``sys.path``, and there ``cfem_ros`` is this folder, not the package inside
it (``cfem_ros/cfem_ros``). Without this file Python would make the folder an
empty namespace package and ``from cfem_ros import load_scenario`` would fail
with "unknown location". Instead, the installed package is loaded in its place;
a warning says so when it is not this clone's own (editable) install, and an
ImportError says what to do when no package is installed.
"""

import importlib
import os
import sys
import warnings

_CLONE = os.path.dirname(os.path.abspath(__file__))
_NAME = 'cfem_ros'


def _installed_package():
    """Import and return cfem_ros as found without the folder that holds this clone."""
    holder = os.path.dirname(_CLONE)
    saved = list(sys.path)
    sys.path[:] = [p for p in sys.path if os.path.abspath(p or os.curdir) != holder]
    sys.modules.pop(_NAME, None)   # this module, so that the import looks again
    try:
        return importlib.import_module(_NAME)
    finally:
        sys.path[:] = saved


try:
    _package = _installed_package()
except ImportError as err:
    raise ImportError(
        f"'{_NAME}' here is the folder {_CLONE}, a clone of the cfem_ros repository, which "
        f'Python imported because your script (or your working directory) is in '
        f'{os.path.dirname(_CLONE)}; the package is {os.path.join(_CLONE, "cfem_ros")}, and it '
        f'is not installed for {sys.executable} ({err}). Install it (make demo in the clone, or '
        f'pip install -e {_CLONE}), or run the script from another folder.',
        name=__name__) from None
if os.path.dirname(os.path.realpath(_package.__file__)) != os.path.realpath(
        os.path.join(_CLONE, 'cfem_ros')):
    warnings.warn(
        f'cfem_ros: your script is beside the folder {_CLONE} (a clone of the repository), '
        f'which Python found first as "{_NAME}"; the installed package '
        f"{os.path.dirname(_package.__file__)} was loaded instead, not the clone's sources. "
        f'Run the script from another folder, or install the clone (pip install -e {_CLONE}), '
        f'to make this warning go away.', UserWarning, stacklevel=2)
sys.modules[__name__] = sys.modules[_NAME] = _package
