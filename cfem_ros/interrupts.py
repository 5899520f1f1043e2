# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
SIGINT and SIGTERM for the command line: the exception and the handlers.

``console`` installs ``exit_now`` before anything heavy is imported (nothing
is being written then); a command that writes (``cli``) raises
``Interrupted`` from its own handlers instead and stops between two chunks.
Both import this module, which imports nothing of the package.
"""

import os
import signal
import sys

#: Exit status after a signal: 128 + its number.
EXIT_SIGINT = 128 + signal.SIGINT
EXIT_SIGTERM = 128 + signal.SIGTERM


class Interrupted(BaseException):
    """A SIGINT or SIGTERM received; ``signum`` says which."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def exit_status(self) -> int:
        """Return 128 + the signal's number (130 for SIGINT, 143 for SIGTERM)."""
        return 128 + self.signum


def exit_now(signum, frame):
    """Say so on stderr and exit 128 + signum at once: SIGINT's and SIGTERM's handler."""
    try:
        os.write(2, f'interrupted by {signal.Signals(signum).name}\n'.encode())
    except OSError:
        pass
    os._exit(128 + signum)


def quiet_broken_pipe() -> int:
    """Point stdout and stderr at /dev/null (so that exiting flushes nothing); return 141."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.dup2(devnull, sys.stderr.fileno())
    except (OSError, ValueError):
        pass
    return 128 + signal.SIGPIPE
