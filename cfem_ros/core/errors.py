# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Exceptions of the numerical core: the root of all cfem_ros errors, and its kinds."""

from __future__ import annotations


class CfemError(Exception):
    """Root of every error cfem_ros raises on purpose."""


class ScenarioError(CfemError):
    """
    A scenario (file or mapping) that cannot be simulated.

    Parameters
    ----------
    source : str
        The file name, or a description of where the scenario came from.
    key : str
        Dotted key path of the offending entry (``joints.pivot.axis``), or ''
        for the document as a whole.
    problem : str
        What is wrong, with the value.
    expected : str
        What would be right.

    """

    def __init__(self, source: str, key: str, problem: str, expected: str = ''):
        self.source = source
        self.key = key
        self.problem = problem
        self.expected = expected
        where = f'{source}: {key}' if key else source
        message = f'{where}: {problem}'
        if expected:
            message += f'; expected {expected}'
        super().__init__(message)


class InputError(CfemError):
    """A command-line argument or input log that cannot be used."""


class ArgumentError(CfemError, ValueError):
    """
    An argument a call refuses (a state of the wrong shape, an unknown body, an option's value).

    Also what a value given in a file is refused for before its key path is
    known (a time, a mesh file: the caller names the key). A ``ValueError``
    too, so that a caller catching ``ValueError`` catches it.
    """
