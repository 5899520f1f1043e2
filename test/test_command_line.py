# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
How ``cfem-sim`` is put together: each subcommand runs the function its group set on it.

What each command does is tested with its subject (test/core, test/recording,
test/study, test/ros); here, the dispatch that replaced an if-chain: every
subcommand has its own function, from its group's module, in the order the
help lists them.
"""

import argparse

from cfem_ros.cli import build_parser
import pytest

COMMANDS = ['run', 'check', 'plot', 'export', 'info', 'recover', 'compare', 'play', 'sweep',
            'envelope', 'fit', 'predict', 'report', 'rerun', 'summarize']


def subcommands() -> dict:
    """Return cfem-sim's subparsers by name, in the order they were added."""
    parser = build_parser()
    [sub] = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return sub.choices


def test_every_command_runs_a_function_of_its_own():
    parsers = subcommands()
    assert list(parsers) == COMMANDS   # the order of cfem-sim --help
    functions = {name: parser.get_default('func') for name, parser in parsers.items()}
    assert all(callable(f) for f in functions.values()), functions
    assert len(set(functions.values())) == len(COMMANDS), functions   # none wired twice
    for name, function in functions.items():
        assert function.__module__.startswith('cfem_ros.cli.'), (name, function)
        assert name in function.__name__, (name, function.__name__)


@pytest.mark.parametrize('argv', [['check', 'a.yaml'], ['sweep', '--plan', '0.9,0.9'],
                                  ['rerun', 'out', '3', '-o', 'r.mcap']])
def test_parsed_arguments_carry_the_function_that_runs_them(argv):
    args = build_parser().parse_args(argv)
    assert args.command == argv[0] and args.func.__name__ == f'{argv[0]}_command'
