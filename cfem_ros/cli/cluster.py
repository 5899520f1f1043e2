# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The Dask cluster of the study commands: started, closed whatever comes, and the imports."""

from __future__ import annotations

import logging
import os
import signal
from typing import Optional

from cfem_ros.cli.common import signals_to
from cfem_ros.core.errors import InputError
from cfem_ros.interrupts import Interrupted

#: Dask settings of a local cluster: no statistical profiler sampling the runs every
#: 10 ms (for a dashboard nobody opens) and the event loops' watchdog at 200 ms, not 20:
#: an idle cluster of 2 workers took 7 % of a core, 3 % with these.
QUIET = {'distributed.worker.profile.enabled': False,
         'distributed.admin.tick.interval': '200ms'}


def study_imports():
    """Import the study layer and Dask, or say how to install them (InputError)."""
    try:
        import dask.distributed  # noqa: F401
        import pandas  # noqa: F401
        import pyarrow  # noqa: F401
    except ImportError as err:
        raise InputError(f'cfem-sim sweep/summarize need {err.name}, which is not installed; '
                         "install the study extra: pip install -e '.[study]' "
                         '(dask[distributed], pandas, pyarrow)') from None
    from cfem_ros import study
    return study


def dask_client(workers: Optional[int], scheduler: Optional[str]):
    """Return (client, cluster or None): a LocalCluster of processes, or a scheduler's."""
    import dask
    from dask.distributed import Client, LocalCluster
    if scheduler:
        client = Client(scheduler, timeout='30s')
        client.wait_for_workers(1, timeout=60)
        return client, None
    # the worker processes start with SIGINT ignored (and keep it so): a Ctrl-C at the
    # terminal, sent to every process of the group, stops only this one, which then closes
    # the cluster (no tracebacks from the workers, no leaked semaphores). The workers'
    # own logs are not shown: a SIGTERM to this process alone closes the scheduler under
    # them, and a heartbeat then fails with an ERROR and its traceback on stderr (issue
    # 52.3's campaign); what a run does wrong comes back to the client as its row.
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with dask.config.set(QUIET):   # the workers take the settings they start with
            cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1,
                                   threads_per_worker=1, processes=True,
                                   dashboard_address=':0', silence_logs=logging.CRITICAL)
        return Client(cluster), cluster
    finally:
        signal.signal(signal.SIGINT, previous)


def raise_interrupted(signum, frame):
    """Raise ``Interrupted``: the handler that stops a command's waiting for its cluster."""
    raise Interrupted(signum)


def close(client, cluster, hold: bool = True):
    """
    Close a Dask client and its local cluster (either may be None), whatever comes meanwhile.

    A SIGINT or SIGTERM during the closing is held until it is done (an
    exception raised inside Dask's shutdown would leave its comms half
    closed and their tracebacks on stderr); Dask's own logs of connections
    closing under it are not shown. Return the signal held, or None.
    """
    held = []
    if not hold:
        _close_quietly(client, cluster)
        return None
    with signals_to(lambda signum, frame: held.append(signum)):
        _close_quietly(client, cluster)
    return held[0] if held else None


def _close_quietly(client, cluster):
    """Close the client, then the cluster, with Dask's logs of closing connections not shown."""
    quiet = logging.getLogger('distributed')
    level = quiet.level
    quiet.setLevel(logging.CRITICAL)
    try:
        for thing in (client, cluster):
            if thing is None:
                continue
            try:
                thing.close()
            except Exception:  # noqa: B902 - a comm already closed: nothing left to close
                pass
    finally:
        quiet.setLevel(level)
