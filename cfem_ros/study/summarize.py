# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""A sweep's metrics over existing recordings: one row per file, each read once."""

from __future__ import annotations

import os

from cfem_ros.core.engine.events import Status
from cfem_ros.core.errors import CfemError
from cfem_ros.study.metrics import compute, empty, from_run

#: The units of the summary's own numeric columns (a clock stamp, ns); the metrics have
#: their rules' (``labels.unit_rule``), as in a sweep's table.
UNITS = {'start_stamp_ns': 'ns'}


def summarize_file(path: str, metrics) -> dict:
    """
    Return one recording's row: file, start stamp, status, message, metrics.

    A file that cannot be read (truncated, not MCAP, not a cfem_ros run) or
    lacks a body the metrics need is a 'failed' row with the reason.
    """
    row = {'file': os.path.basename(path), 'path': os.path.abspath(path),
           'start_stamp_ns': -1, 'status': Status.OK, 'message': ''}
    from cfem_ros.recording.analysis import open_run   # scipy: not on a sweep's path
    try:
        run = open_run(path)
        row['start_stamp_ns'] = int(run.start_ns)
        row.update(compute(from_run(run), metrics))
    except (CfemError, KeyError, ValueError, OSError) as err:
        message = err.args[0] if isinstance(err, KeyError) else str(err)
        if not message.startswith(f'{path}: '):   # the reader's messages name the file
            message = f'{path}: {message}'
        row.update(status=Status.FAILED, message=message)
        row.update(empty(metrics))
    return row


def summary_columns(metrics) -> list:
    """Return the summary table's columns in order."""
    return ['file', 'path', 'start_stamp_ns', 'status', 'message'] + metrics.columns()


def _summarize_group(paths, metrics) -> list:
    return [summarize_file(p, metrics) for p in paths]


def summarize(paths, metrics, client=None):
    """
    Return the metrics of recordings as a pandas DataFrame, in the order given.

    With a Dask client the files are read in parallel (a few per task), by
    their absolute paths: a worker's working directory is its own (on a
    remote cluster, another machine's), so the files must be where the
    paths say on a shared file system.
    """
    import pandas as pd
    paths = list(paths)
    if client is None:
        rows = _summarize_group(paths, metrics)
    else:
        paths = [os.path.abspath(p) for p in paths]
        workers = max(1, len(client.scheduler_info().get('workers', {})))
        size = max(1, -(-len(paths) // (4 * workers)))
        chunks = [paths[i:i + size] for i in range(0, len(paths), size)]
        futures = [client.submit(_summarize_group, chunk, metrics, pure=False)
                   for chunk in chunks]
        rows = [row for future in futures for row in future.result()]
    return pd.DataFrame.from_records(rows, columns=summary_columns(metrics))
