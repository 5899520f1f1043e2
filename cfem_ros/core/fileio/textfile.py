# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Files read within bounds: regular files only, of bounded size, in UTF-8, never blocking."""

from __future__ import annotations

import os
import stat
from typing import Optional

from cfem_ros.core.errors import ScenarioError

#: Largest scenario file, bytes.
MAX_FILE_BYTES = 16 * 1024 * 1024


def display(path) -> str:
    """Return a path as messages show it: as given, quoted if it has control characters."""
    text = os.fsdecode(path) if isinstance(path, (bytes, os.PathLike)) else str(path)
    return text if text.isprintable() else repr(text)


def file_kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return 'a directory'
    if stat.S_ISFIFO(mode):
        return 'a named pipe (FIFO)'
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return 'a device'
    if stat.S_ISSOCK(mode):
        return 'a socket'
    return 'not a regular file'


def read_text(path, source: Optional[str] = None,
              what: str = 'a readable, regular YAML scenario file') -> str:
    """
    Read a scenario file's text: a regular file, at most ``MAX_FILE_BYTES``, UTF-8.

    Never blocks (a FIFO or device is refused from its ``stat`` before it is
    opened, and opened non-blocking) and never reads more than the bound.
    ``what`` is the file that would be right, as a refusal says it (a
    scenario, a motion table's CSV file).

    Raises
    ------
    ScenarioError
        For a file that is missing, unreadable, not regular, too large or not UTF-8.

    """
    source = source or display(path)
    limit = f'at most {MAX_FILE_BYTES:,} bytes ({MAX_FILE_BYTES >> 20} MiB)'

    def refuse(problem, expected=what):
        raise ScenarioError(source, '', problem, expected)

    try:
        mode = os.stat(path).st_mode
        if not stat.S_ISREG(mode):
            refuse(f'is {file_kind(mode)}')
        fd = os.open(path, os.O_RDONLY | getattr(os, 'O_NONBLOCK', 0))
    except (OSError, ValueError) as err:
        refuse(f'cannot read the file ({getattr(err, "strerror", None) or err})')
    with os.fdopen(fd, 'rb') as stream:
        try:
            info = os.fstat(stream.fileno())    # the file opened, not the one stat saw
            if not stat.S_ISREG(info.st_mode):
                refuse(f'is {file_kind(info.st_mode)}')
            if info.st_size > MAX_FILE_BYTES:
                refuse(f'is {info.st_size:,} bytes', limit)
            data = stream.read(MAX_FILE_BYTES + 1)
        except OSError as err:
            refuse(f'cannot read the file ({err.strerror or err})')
    if len(data) > MAX_FILE_BYTES:
        refuse(f'is more than {MAX_FILE_BYTES:,} bytes', limit)
    try:
        return data.decode('utf-8')
    except UnicodeDecodeError as err:
        line = data.count(b'\n', 0, err.start) + 1
        refuse(f'line {line}: byte {err.start} (0x{data[err.start]:02x}) is not UTF-8',
               'a text file in UTF-8')
