# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Jobs run in forked processes beside the caller's own work: a fit's figures.

A figure is matplotlib's Python (ticks, text), which holds the GIL: threads
would draw one at a time. ``Forked`` starts up to ``processes`` children by
``fork`` (each shares the parent's objects as they are at the fork: nothing
is pickled), each taking the next job not taken until none is left (a
figure of trajectories costs more than one of residuals), while the parent
goes on (it records ``fitted.mcap``); leaving the block waits for them and
raises the first failed job's error (in the jobs' order) in the parent. A
SIGINT or SIGTERM ends a child at once (exit 128 + the signal) and is
raised in the parent, whose handler says what it means (the command
line's raises ``Interrupted``); the parent leaving the block by an
exception ends its children first. Where ``fork`` is missing, or for one
process, the jobs run in the parent as the block ends.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import signal
from typing import Optional

STOPS = (signal.SIGINT, signal.SIGTERM)


class Forked:
    """
    Run jobs (callables without arguments) in forked processes during a ``with`` block.

    Parameters
    ----------
    jobs : list of callable
        Each returns nothing; what it writes (a file) is its result.
    processes : int
        Children at most (one per job at most); 1 runs the jobs in the parent.

    """

    def __init__(self, jobs: list, processes: int):
        self.jobs = list(jobs)
        self.processes = max(1, min(processes, len(self.jobs)))
        if 'fork' not in multiprocessing.get_all_start_methods():
            self.processes = 1
        self._children = []   # (process, connection)

    def __enter__(self) -> 'Forked':
        if self.processes == 1:
            return self
        context = multiprocessing.get_context('fork')
        taken = context.Value('l', 0)   # the jobs taken so far
        try:
            # the children start with the stops held, set their own handlers, then take them
            held = signal.pthread_sigmask(signal.SIG_BLOCK, STOPS)
            try:
                for _ in range(self.processes):
                    receive, send = context.Pipe(duplex=False)
                    child = context.Process(target=_child, args=(self.jobs, taken, send, held),
                                            daemon=True)
                    child.start()
                    send.close()
                    self._children.append((child, receive))
            finally:
                signal.pthread_sigmask(signal.SIG_SETMASK, held)   # a stop held is raised here
        except BaseException:
            self._end()
            raise
        return self

    def __exit__(self, kind, error, traceback) -> None:
        if kind is not None:
            self._end()
            return
        if not self._children:
            for job in self.jobs:
                job()
            return
        failures = {}
        try:
            for child, receive in self._children:
                failures.update(_outcome(child, receive, len(self.jobs)))
        finally:
            self._end()
        if failures:
            raise failures[min(failures)]

    def _end(self):
        """End the children still running and wait for each."""
        for child, receive in self._children:
            if child.is_alive():
                child.terminate()
            child.join()
            receive.close()
        self._children = []


def _child(jobs: list, taken, send, held) -> None:
    """Run the jobs not taken yet; send (index, error) of the first that fails, or None."""
    for stop in STOPS:
        signal.signal(stop, _exit_at_once)
    signal.pthread_sigmask(signal.SIG_SETMASK, held)
    failed: Optional[tuple] = None
    while failed is None:
        with taken.get_lock():
            index = taken.value
            taken.value += 1
        if index >= len(jobs):
            break
        try:
            jobs[index]()
        except Exception as err:   # noqa: B902 (raised in the parent, which says it)
            failed = (index, _portable(err))
    send.send(failed)
    send.close()


def _exit_at_once(signum, frame):
    os._exit(128 + signum)


def _portable(error: Exception) -> Exception:
    """Return error if it survives pickling, else a RuntimeError that says it."""
    try:
        return pickle.loads(pickle.dumps(error))
    except Exception:   # noqa: B902 (an exception whose arguments do not rebuild it)
        return RuntimeError(f'{type(error).__name__}: {error}')


def _outcome(child, receive, last: int) -> dict:
    """Wait for a child; return {job index: error} of its failure (empty if none)."""
    try:
        failed = receive.recv()
    except EOFError:   # it ended without a word: a stop, or killed
        child.join()
        code = child.exitcode
        if code - 128 in STOPS:   # the child's stop is the parent's
            signal.raise_signal(code - 128)
        how = f'by signal {-code}' if code < 0 else f'with exit status {code}'
        return {last: RuntimeError(f'a process drawing figures ended {how}')}
    child.join()
    return {} if failed is None else {failed[0]: failed[1]}


__all__ = ['Forked']
