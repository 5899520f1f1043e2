# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The ``cfem-sim`` command line (SPEC section 2): typed commands, exit codes.

One module per group of commands registers its subcommands and, with
``set_defaults(func=...)``, the function each runs: ``run`` (run, play),
``check``, ``recordings`` (plot, export, info, recover, compare), ``sweep``
(with ``studies`` for ``--method`` and ``--design``), ``envelope``, ``fit`` (fit,
predict) and ``folders`` (report, rerun, summarize). ``common`` holds what they share,
``cluster`` the Dask cluster of the study commands.
"""

from __future__ import annotations

import argparse
import logging
import sys

from cfem_ros.cli import check, envelope, fit, folders, recordings, run, sweep
from cfem_ros.cli.common import EXIT_BAD_INPUT, signals_to
from cfem_ros.interrupts import exit_now, Interrupted, quiet_broken_pipe

LOG = logging.getLogger('cfem_ros')

#: The functions that add each subcommand, in the order ``cfem-sim --help`` lists them.
COMMANDS = (run.add_run_parser, check.add_parser, recordings.add_plot_parser,
            recordings.add_export_parser, recordings.add_info_parser,
            recordings.add_recover_parser, recordings.add_compare_parser, run.add_play_parser,
            sweep.add_parser, envelope.add_parser, fit.add_parser, fit.add_predict_parser,
            folders.add_report_parser, folders.add_rerun_parser, folders.add_summarize_parser)


class _Parser(argparse.ArgumentParser):
    """argparse's parser, whose usage errors are one ERROR line (exit 2), as every other."""

    def error(self, message: str):
        """Print one ``ERROR:`` line naming the command and where to look; exit 2."""
        text = ' '.join(message.split())
        print(f'ERROR: {self.prog}: {text}; see {self.prog} --help', file=sys.stderr)
        sys.exit(EXIT_BAD_INPUT)


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser of cfem-sim: each subcommand's ``func`` runs it."""
    parser = _Parser(
        prog='cfem-sim',
        description='Simulate rigid bodies joined by releasable joints (CFEM), no ROS needed.')
    sub = parser.add_subparsers(dest='command', required=True, metavar='COMMAND')
    for add in COMMANDS:
        add(sub)
    return parser


def main(argv=None) -> int:
    """Run cfem-sim (SIGINT exits 130, SIGTERM 143; a running recording is finished first)."""
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter('WARNING: %(message)s'))
    with signals_to(exit_now):
        LOG.addHandler(handler)
        LOG.propagate = False
        try:
            args = build_parser().parse_args(argv)
            return args.func(args)
        except Interrupted as stop:
            print(f'interrupted by {stop}', file=sys.stderr)
            return stop.exit_status
        except BrokenPipeError:
            return quiet_broken_pipe()
        finally:
            LOG.removeHandler(handler)
