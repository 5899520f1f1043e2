# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The console scripts ``cfem-sim`` and ``cfem_node``: signals handled from the first instant.

Ctrl-C (SIGINT) and SIGTERM during start-up (imports, compilation, scenario
loading) end the command at once with one line and exit status 130 or 143,
without a traceback (``exit_now``: nothing is being written then; an
exception raised from the handler could be wrapped by the code it lands in,
e.g. into a RuntimeError by a class being created). While ``cfem-sim run``
records, its own handlers stop it between two chunks instead. A closed
stdout or stderr (``cfem-sim info ... | head``) ends the command quietly.
"""

import signal
import sys

from cfem_ros.interrupts import exit_now, Interrupted, quiet_broken_pipe


def main(argv=None) -> int:
    """Run cfem-sim with SIGINT and SIGTERM handled before anything heavy is imported."""
    signal.signal(signal.SIGINT, exit_now)
    signal.signal(signal.SIGTERM, exit_now)
    try:
        from cfem_ros import cli
        return cli.main(argv)
    except Interrupted as stop:
        try:
            print(f'interrupted by {stop}', file=sys.stderr)
        except (BrokenPipeError, OSError):
            pass
        return stop.exit_status
    except BrokenPipeError:
        return quiet_broken_pipe()
    finally:   # the command is over: a late signal changes nothing
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)


def node_main() -> int:
    """
    Run cfem_node with SIGINT and SIGTERM ending its imports at once (exit 130 or 143).

    Nothing is open then; once ROS 2 is initialised, the node's own handlers
    take over and stop it cleanly, its recording finished (exit 0).
    """
    signal.signal(signal.SIGINT, exit_now)
    signal.signal(signal.SIGTERM, exit_now)
    from cfem_ros.ros import node
    return node.main()


def node_entry_point():
    """Console script wrapper of ``node_main``."""
    sys.exit(node_main())
