# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Figures written into a folder without replacing what is there unless told (``--overwrite``).

The figures are drawn into a hidden folder inside the target folder, then
moved in, each by one rename. A figure whose name is taken is refused
before any is moved: the folder is left as it was (nothing half-replaced),
with the names that were in the way. A SIGINT or SIGTERM while they are
drawn or moved raises ``Interrupted`` (the command exits 130 or 143) once
the hidden folder is removed: an interrupted command leaves no trace of it.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from typing import Callable, List

from cfem_ros.cli.common import signals_to
from cfem_ros.core.errors import InputError
from cfem_ros.interrupts import Interrupted


def write_figures(directory: str, overwrite: bool,
                  draw: Callable[[str], List[str]]) -> List[str]:
    """
    Draw figures with draw(folder) and move them into directory; return their paths there.

    Raises
    ------
    InputError
        If a figure's name is taken in directory and overwrite is False
        (nothing is written then).
    OSError
        If directory cannot be made or written.

    """
    os.makedirs(directory, exist_ok=True)
    with signals_to(_interrupted):
        return _written(directory, overwrite, draw)


def _interrupted(signum, frame):
    raise Interrupted(signum)


def _written(directory: str, overwrite: bool, draw: Callable[[str], List[str]]) -> List[str]:
    """Draw into a hidden folder of directory, move the figures in, remove the folder."""
    staging = tempfile.mkdtemp(prefix='.cfem-figures-', dir=directory)
    try:
        drawn = draw(staging)
        names = [os.path.basename(path) for path in drawn]
        taken = sorted(n for n in names if os.path.lexists(os.path.join(directory, n)))
        if taken and not overwrite:
            more = f' and {len(taken) - 4} more' if len(taken) > 4 else ''
            shown = ', '.join(taken[:4]) + more
            raise InputError(f'{directory}: already holds {shown}; pass --overwrite to '
                             'replace them, or choose another folder')
        placed = []
        for path, name in zip(drawn, names):
            target = os.path.join(directory, name)
            os.replace(path, target)
            placed.append(target)
        return placed
    finally:
        shutil.rmtree(staging, ignore_errors=True)
