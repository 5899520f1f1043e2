# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Exceptions of the recording layer."""

from __future__ import annotations

from cfem_ros.core.errors import CfemError


class RecordingError(CfemError):
    """A recording that cannot be written or read."""


class OutputError(RecordingError):
    """A recording that could not be written to the end (a full disk, a file size limit)."""
