# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The study commands' local Dask cluster says nothing of its workers' own logs.

Found by the reliability campaign (issue 52.3): a SIGTERM to ``cfem-sim sweep``
alone (not its process group) closes the scheduler under its workers; a
worker's heartbeat then fails and the worker logged an ERROR with its
traceback on the command's stderr, after the interrupted line. The case here
logs that same ERROR inside a worker, deterministically, and reads the
stderr of the process that owns the cluster. The same cluster's workers run
with ``cluster.QUIET``'s settings (no statistical profiler sampling the runs).
"""

import pathlib
import subprocess
import sys

import pytest

pytest.importorskip('dask.distributed')
ROOT = pathlib.Path(__file__).resolve().parents[1]
SCRIPT = """
import logging
import sys
sys.path.insert(0, {root!r})
import dask
from cfem_ros.cli.cluster import close, dask_client, QUIET


def settings():
    return {{key: dask.config.get(key) for key in QUIET}}


def heartbeat_fails():
    try:
        raise ConnectionError('Stream is closed')
    except ConnectionError:   # what distributed.worker logs when the scheduler has gone
        logging.getLogger('distributed.worker').exception(
            'Failed to communicate with scheduler during heartbeat.')
    return True


if __name__ == '__main__':
    client, cluster = dask_client(1, None)
    assert client.submit(heartbeat_fails, pure=False).result()
    found = client.run(settings)
    assert list(found.values()) == [QUIET], found
    assert dask.config.get('distributed.worker.profile.enabled')   # here: as it was
    close(client, cluster)
    print('closed')
"""


def test_a_workers_error_log_does_not_reach_stderr(tmp_path):
    script = tmp_path / 'cluster_logs.py'
    script.write_text(SCRIPT.format(root=str(ROOT)))
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          timeout=120, cwd=tmp_path)
    assert done.returncode == 0 and done.stdout.strip() == 'closed', done.stderr
    assert 'Traceback' not in done.stderr and 'heartbeat' not in done.stderr, done.stderr
