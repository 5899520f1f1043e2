# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A study's resource failures: what the machine could not do, as opposed to a run that failed.

A run whose recording cannot be written (a full disk, a file size limit, a
read-only folder) has no row in the study's table: it is no result of the
run, and a resumed study does it again.
"""

from __future__ import annotations

from cfem_ros.core.errors import CfemError, ScenarioError


class ResourceFailure(CfemError):
    """Runs whose recordings or table part could not be written; the study resumes them."""


class MethodFailed(ScenarioError):
    """A study method that ran and could give no estimate (exit 1: its runs are saved)."""


def recording_failure(err: BaseException) -> bool:
    """Return whether err is a recording (or its folder) that could not be written."""
    from cfem_ros.recording.errors import RecordingError
    return isinstance(err, (RecordingError, OSError))


def unrecorded(runs, reason: str, outdir: str) -> ResourceFailure:
    """Return the failure of runs not recorded for reason, to do again on resume."""
    runs = sorted(runs)
    shown = ', '.join(str(k) for k in runs[:10]) + (' ...' if len(runs) > 10 else '')
    return ResourceFailure(f'{outdir}: {len(runs)} run(s) ({shown}) could not be written: '
                           f'{reason}; they are not in the table and no result of the runs; '
                           'the others are saved: free some space (or make the folder '
                           'writable) and run the same command again to do them')


class PartialRows(CfemError):
    """The rows of a task's runs that were written, and the failure of the others."""

    def __init__(self, rows: list, failure: ResourceFailure):
        super().__init__(str(failure))
        self.rows = rows
        self.failure = failure
