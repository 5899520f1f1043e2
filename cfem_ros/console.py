# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The ``cfem-sim`` console script: signals and broken pipes handled from the first instant.

Ctrl-C (SIGINT) and SIGTERM during start-up (imports, compilation, scenario
loading) end the command with one line and exit status 130 or 143, without
a traceback; ``cfem_ros.cli`` then takes over (a running recording is
finished first). A closed stdout or stderr (``cfem-sim info ... | head``)
ends the command quietly.
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


def interrupt(signum, frame):
    """Raise Interrupted: the handler of SIGINT and SIGTERM outside a recording."""
    raise Interrupted(signum)


def quiet_broken_pipe() -> int:
    """Point stdout and stderr at /dev/null (so that exiting flushes nothing); return 141."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.dup2(devnull, sys.stderr.fileno())
    except (OSError, ValueError):
        pass
    return 128 + signal.SIGPIPE


def main(argv=None) -> int:
    """Run cfem-sim with SIGINT and SIGTERM handled before anything heavy is imported."""
    signal.signal(signal.SIGINT, interrupt)
    signal.signal(signal.SIGTERM, interrupt)
    try:
        from cfem_ros import cli
        return cli.main(argv)
    except Interrupted as stop:
        try:
            print(f'interrupted ({stop}) during start-up; nothing written', file=sys.stderr)
        except (BrokenPipeError, OSError):
            pass
        return stop.exit_status
    except BrokenPipeError:
        return quiet_broken_pipe()
    finally:   # the command is over: a late signal changes nothing
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
