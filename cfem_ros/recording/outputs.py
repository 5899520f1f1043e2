# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Where a recording may be written: a regular file or a new path, never a device or folder."""

from __future__ import annotations

import os
import stat
from typing import Optional

from cfem_ros.core.fileio.textfile import file_kind


def _nearest_existing(directory: str) -> str:
    """Return directory, or its nearest ancestor that exists (lexically, as makedirs goes)."""
    while directory and not os.path.lexists(directory):
        parent = os.path.dirname(directory.rstrip(os.sep))
        if parent == directory:
            break
        directory = parent
    return directory or '.'


def output_problem(path: str, *, exists_ok: bool = True, option: str = '-o',
                   what: str = 'a recording') -> Optional[str]:
    """
    Return why path cannot receive a recording (None if it can).

    A recording goes to a regular file (replaced only if ``exists_ok``) or
    a new path whose missing folders are made: an empty name, a directory,
    a FIFO, a device or a socket is refused, even with --overwrite (writing
    there would block, or replace the device or folder with a file), as is
    a path under a regular file.
    """
    example = {'a recording': 'runs/out.mcap', 'a report': 'runs/report.html'}.get(
        what, 'runs/table.parquet')
    expected = f'a regular file or a new path, e.g. {example}'
    if not path:
        return f"{option} '': is empty; expected {expected}"
    if path.endswith(os.sep):
        return f'{option} {path}: names a folder; expected {expected}'
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        mode = None      # a new path (or a dangling symbolic link, which is replaced)
    except NotADirectoryError:
        mode = None      # under a regular file: said below
    except OSError as err:
        return f'{option} {path}: cannot be examined ({err.strerror}); expected {expected}'
    if mode is not None and not stat.S_ISREG(mode):
        return (f'{option} {path}: is {file_kind(mode)}; {what} is written only to '
                f'{expected} (not even with --overwrite)')
    if mode is not None and not exists_ok:
        return f'{option} {path}: already exists; choose another name'
    folder = _nearest_existing(os.path.dirname(path))
    try:
        folder_mode = os.stat(folder).st_mode
    except OSError as err:
        return f'{option} {path}: its folder {folder} cannot be examined ({err.strerror})'
    if not stat.S_ISDIR(folder_mode):
        kind = 'a regular file' if stat.S_ISREG(folder_mode) else file_kind(folder_mode)
        return f'{option} {path}: {folder} is {kind}, not a folder; expected a path in a folder'
    return None
