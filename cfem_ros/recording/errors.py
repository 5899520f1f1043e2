# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Exceptions of the recording layer."""

from __future__ import annotations

from cfem_ros.core.errors import CfemError


class RecordingError(CfemError):
    """A recording that cannot be written or read."""


class OutputError(RecordingError):
    """
    A recording that could not be written to the end (a full disk, a file size limit).

    Attributes
    ----------
    kept_messages : int or None
        Messages the file keeps (None: nothing is kept, the file was removed).
    kept_until_ns : int or None
        Log time of the last message kept, ns.
    complete : bool
        Whether the file kept is a finished recording (summary, footer).

    """

    def __init__(self, message: str, kept_messages=None, kept_until_ns=None,
                 complete: bool = False):
        super().__init__(message)
        self.kept_messages = kept_messages
        self.kept_until_ns = kept_until_ns
        self.complete = complete
