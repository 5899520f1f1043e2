# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Figures written into a folder without replacing what is there unless told (``--overwrite``).

The figures are drawn into a hidden folder inside the target folder, then
moved in, each by one rename. A figure whose name is taken is refused
before any is moved: the folder is left as it was (nothing half-replaced),
with the names that were in the way.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from typing import Callable, List

from cfem_ros.core.errors import InputError


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
