# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""What every ``cfem-sim`` command shares: exit statuses, ERROR lines, output checks, signals."""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
from typing import Optional

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_BAD_INPUT = 2
#: ``cfem-sim run``: the run stopped at a contact (``contacts: on_contact: stop``).
EXIT_CONTACT = 3

#: The signals that stop a command: Ctrl-C and a polite kill.
STOPS = (signal.SIGINT, signal.SIGTERM)


def error(message: str) -> int:
    """Say what is wrong with the command's input in one ERROR line; exit status 2."""
    print(f'ERROR: {message}', file=sys.stderr)
    return EXIT_BAD_INPUT


def failed(message: str) -> int:
    """Say what stopped a command that had started working (a full disk); exit 1."""
    print(f'ERROR: {message}', file=sys.stderr)
    return EXIT_FAILED


def warn(text: str):
    """Print one WARNING line on stderr."""
    print(f'WARNING: {text}', file=sys.stderr)


def vec(values, fmt='{:+.6g}') -> str:
    """Return a vector as one bracketed line, each number in fmt."""
    return '[' + ', '.join(fmt.format(v) for v in values) + ']'


def cannot_start(scenario: str, errors: list) -> str:
    """Return the error line of a scenario that check, run and the node refuse (``startcheck``)."""
    from cfem_ros.core.engine import startcheck   # the engine, imported when a run is made
    return startcheck.cannot_start(scenario, errors)


def same_file(a: str, b: str) -> bool:
    """Return whether two paths name one file (or would, once made)."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


def output_refused(path: str, overwrite: bool, what: str = 'a recording') -> Optional[str]:
    """Return why -o path cannot receive a recording (None if it can), before anything runs."""
    from cfem_ros.recording.outputs import output_problem
    return output_problem(path, exists_ok=overwrite, what=what)


def table_refused(path: str, overwrite: bool, what: str) -> Optional[str]:
    """Return why a table or page cannot be written to path (None if it can)."""
    refused = output_refused(path, overwrite=True, what=what)   # never a device or folder
    if refused:
        return refused
    if not overwrite and os.path.lexists(path):
        return f'{path}: already exists; pass --overwrite to replace it'
    return None


@contextlib.contextmanager
def signals_to(handler):
    """Have SIGINT and SIGTERM go to handler inside the block; restore them after it."""
    previous = [signal.signal(s, handler) for s in STOPS]
    try:
        yield
    finally:
        for s, before in zip(STOPS, previous):
            signal.signal(s, before)


@contextlib.contextmanager
def warnings_held():
    """
    Hold the package's warnings while a scenario is read and checked; say them after.

    A command refused in the block says only its one ``ERROR:`` line; one
    that goes on says the held warnings when the block ends.
    """
    log = logging.getLogger('cfem_ros')
    held = []

    def hold(record):
        held.append(record)
        return False
    log.addFilter(hold)
    try:
        yield
    except BaseException:
        held.clear()
        raise
    finally:
        log.removeFilter(hold)
        for record in held:
            log.handle(record)
