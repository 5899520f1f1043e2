# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Sweeps on Dask: many runs per task, each task's rows one Parquet part, resumable.

A sweep folder holds ``sweep.json`` (the resolved sweep and its hash: a
folder holds one sweep), ``parts/part_<first>_<last>.parquet`` (each
written by one task, atomically: a temporary file then ``os.replace``),
optionally ``runs/run_<k>.mcap``, and at the end ``results.parquet``
(every part, sorted by run). Running the same sweep again in the same
folder only does the runs that no part holds yet.
"""

from __future__ import annotations

import dataclasses
import glob
import json
import math
import os
import sys
import tempfile
import time
from typing import Callable, Optional

from cfem_ros.core.engine.events import Status
from cfem_ros.core.errors import ArgumentError
from cfem_ros.recording.export import write_frame
from cfem_ros.study.errors import SweepError
from cfem_ros.study.folder import read_manifest, read_table
from cfem_ros.study.resources import PartialRows, ResourceFailure, unrecorded
from cfem_ros.study.runs import run_one, run_rows, warn_once
from cfem_ros.study.spec import load_sweep, SweepSpec

#: How the runs are recorded to MCAP: every run, the failed ones, none.
RECORD = ('none', 'failed', 'all')
#: Tasks per worker (a task is many runs: total / (TASKS_PER_WORKER x workers)).
TASKS_PER_WORKER = 8
MANIFEST = 'sweep.json'
RESULTS = 'results.parquet'
#: The criteria a folder's table was judged by (SPEC section 9).
CRITERIA = 'criteria.json'


def _missing_study_packages(err: ImportError) -> SweepError:
    return SweepError('cfem-sim sweep', '', f'needs {err.name or "dask"}, not installed',
                      "pip install -e '.[study]' (dask[distributed], pandas, pyarrow)")


def columns(spec: SweepSpec) -> list:
    """Return the table's columns in order."""
    return (['run'] + [v.path for v in spec.variables] + ['status', 'message']
            + spec.metrics.columns())


def frame(rows, names):
    """Return rows as a pandas DataFrame with these columns, in order."""
    import pandas as pd
    return pd.DataFrame.from_records(rows, columns=names)


def write_atomic(table, path: str, document: Optional[dict] = None,
                 units: Optional[dict] = None):
    """
    Write a DataFrame to Parquet (or CSV for .csv) through a temporary file.

    With the base scenario's document, each numeric column's unit
    (``labels.unit_rule``) goes into the Parquet field metadata, or a CSV's
    header (``store_q [deg/s]``), SPEC section 15; units ({column: unit})
    gives those of columns the rules do not know, and wins over them.
    """
    found = {}
    if document is not None:
        from cfem_ros.study.labels import unit_rule
        found = {c: unit_rule(c, document) for c in table.columns
                 if table[c].dtype.kind in 'fiub'}
        found = {c: u for c, u in found.items() if u is not None}
    found.update(units or {})
    write_frame(table, path, units=found or None)


def run_task(spec: SweepSpec, runs, outdir: str, record: str = 'none',
             threads: int = 1) -> tuple:
    """
    Run a group of runs and write their rows as one Parquet part (a Dask task).

    Returns (runs done, runs failed, None), or, when recordings or the part
    could not be written (a full disk), the message of that ``ResourceFailure``
    third: returned, not raised, so that Dask neither retries the task nor
    logs a traceback; the caller raises it once the other tasks are done.
    """
    failure = None
    try:
        rows = run_rows(spec, runs, outdir, record, threads)
    except PartialRows as partial:
        rows, failure = partial.rows, str(partial.failure)
    part = os.path.join(outdir, 'parts', f'part_{runs[0]:07d}_{runs[-1]:07d}.parquet')
    try:
        if rows:
            write_atomic(frame(rows, columns(spec)), part)
    except OSError as err:
        rows, failure = [], str(unrecorded(runs, f'{part}: cannot write '
                                           f'({err.strerror or err})', outdir))
    return len(rows), sum(r['status'] == Status.FAILED for r in rows), failure


def task_done(done: tuple, progress=None, failures=None):
    """Take a task's result: progress(runs, failed); a resource failure kept in failures."""
    if progress:
        progress(done[0], done[1])
    if done[2] is not None and failures is not None:
        failures.append(done[2])


def _done_runs(outdir: str, names: list) -> set:
    """
    Return the runs the finished parts hold (removing leftovers of killed tasks).

    names: the table's columns; a part with other columns (written by another
    version of cfem_ros, which made other metrics of the same sweep) is refused
    rather than resumed into a table whose rows would not agree.
    """
    import pyarrow.parquet as pq
    done = set()
    for path in glob.glob(os.path.join(outdir, 'parts', '*.tmp-*')):
        os.remove(path)
    for path in sorted(glob.glob(os.path.join(outdir, 'parts', '*.parquet'))):
        try:
            held = pq.read_schema(path).names
            done.update(pq.read_table(path, columns=['run']).column('run').to_pylist())
        except Exception:  # noqa: B902 - a damaged part: said by the reader, in one line
            read_table(path, 'part')
            raise
        if held != names:
            missing = [n for n in names if n not in held]
            other = [n for n in held if n not in names]
            said = '; '.join(part for part in (
                f'it lacks {", ".join(missing[:4])}{" ..." if len(missing) > 4 else ""}'
                if missing else '',
                f'it has {", ".join(other[:4])}{" ..." if len(other) > 4 else ""}'
                if other else '') if part) or 'its columns are in another order'
            raise SweepError(outdir, '', f'{os.path.relpath(path, outdir)} was written by '
                             f'another version of cfem_ros ({said})', 'a new folder: its '
                             "runs cannot be resumed into this version's table")
    return done


def saved_runs(outdir: str) -> int:
    """Return how many runs the finished parts in outdir hold (touching nothing)."""
    import pyarrow.parquet as pq
    return len(set().union(*[pq.read_table(path, columns=['run']).column('run').to_pylist()
                             for path in glob.glob(os.path.join(outdir, 'parts', '*.parquet'))]))


def prepare(spec: SweepSpec, outdir: str, record: str = 'none') -> list:
    """
    Make or reopen a sweep folder; return the runs still to do.

    Raises
    ------
    SweepError
        If the folder holds another sweep, or cannot be written.

    """
    manifest = os.path.join(outdir, MANIFEST)
    digest = spec.digest()
    try:
        os.makedirs(os.path.join(outdir, 'parts'), exist_ok=True)
        if record != 'none':
            os.makedirs(os.path.join(outdir, 'runs'), exist_ok=True)
        if os.path.exists(manifest):
            held = read_manifest(outdir)
            if held.get('digest') != digest:
                raise SweepError(outdir, '', f'holds another sweep ({held.get("sweep")}, '
                                 f'{held.get("total")} runs, hash {held.get("digest", "")[:12]})',
                                 'a new folder, or the same sweep file, seed and runs '
                                 'to resume it')
        else:
            tmp = manifest + '.tmp'
            with open(tmp, 'w', encoding='utf-8') as stream:
                json.dump({'digest': digest, 'sweep': os.path.abspath(spec.path),
                           'total': spec.total, 'resolved': json.loads(spec.describe())},
                          stream, indent=1)
            os.replace(tmp, manifest)
        done = _done_runs(outdir, columns(spec))
    except OSError as err:
        raise SweepError(outdir, '', f'cannot write ({err.strerror})',
                         'a folder this user can write') from err
    return [k for k in range(spec.total) if k not in done]


def assemble(spec: SweepSpec, outdir: str, csv: bool = False):
    """Gather the parts into ``results.parquet`` (sorted by run) and return the table."""
    import pandas as pd
    paths = sorted(glob.glob(os.path.join(outdir, 'parts', '*.parquet')))
    table = pd.concat([read_table(p, 'part') for p in paths], ignore_index=True) if paths \
        else frame([], columns(spec))
    table = table.drop_duplicates('run').sort_values('run', kind='stable')
    table = table.reset_index(drop=True)[columns(spec)]
    missing = sorted(set(range(spec.total)) - set(table['run'].tolist()))
    if missing:
        raise ResourceFailure(f'{outdir}: runs {missing[:10]} are missing from the parts')
    table = decide(spec, outdir, table)
    write_atomic(table, os.path.join(outdir, RESULTS), spec.document)
    if csv:
        write_atomic(table, os.path.join(outdir, 'results.csv'), spec.document)
    return table


def decide(spec: SweepSpec, outdir: str, table):
    """
    Judge the table by the sweep's criteria and write them to ``criteria.json``.

    Returns the table with ``pass`` and ``failed_criterion`` when the sweep
    has criteria (SPEC section 9), as it is otherwise. The criteria do not
    change the runs: a folder resumed with other criteria is judged again.
    """
    from cfem_ros.study.criteria import judge, to_json
    path = os.path.join(outdir, CRITERIA)
    if not spec.criteria:
        if os.path.exists(path):
            os.remove(path)
        return table
    tmp = f'{path}.tmp-{os.getpid()}'
    with open(tmp, 'w', encoding='utf-8') as stream:
        json.dump({'confidence': spec.confidence,
                   'criteria': [to_json(c) for c in spec.criteria]},
                  stream, indent=1)
    os.replace(tmp, path)
    return judge(table, spec.criteria)


def groups(runs, workers: int, least: int = 1) -> list:
    """
    Split runs into about TASKS_PER_WORKER tasks per worker, in order.

    A task holds at least ``least`` runs, if there are so many for each
    worker: a task's own cost (Dask, the base scenario parsed, its part
    written and read) then stays small beside its runs'.
    """
    if not runs:
        return []
    workers = max(1, workers)
    size = max(min(least, math.ceil(len(runs) / workers)),
               math.ceil(len(runs) / (TASKS_PER_WORKER * workers)))
    return [runs[i:i + size] for i in range(0, len(runs), size)]


def _part_of(spec: SweepSpec, runs) -> SweepSpec:
    """Return the spec with only these runs' values (what a task needs)."""
    return dataclasses.replace(spec, values={
        path: {k: values[k] for k in runs} for path, values in spec.values.items()})


class Progress:
    """
    A progress line on stderr: runs done, failures, runs/s, ETA.

    On a terminal the line is rewritten in place (ended when every run is
    done); to a file or pipe each finished task adds a line.
    """

    def __init__(self, total: int, done: int, stream=None, what: str = 'sweep'):
        self.total, self.done, self.failed = total, done, 0
        self.what = what   # the line's first word: sweep, or envelope (all its conditions)
        self.start_done = done
        self.started = time.monotonic()
        self.stream = stream or sys.stderr
        isatty = getattr(self.stream, 'isatty', None)
        self.in_place = bool(isatty and isatty())

    def update(self, runs: int, failed: int):
        """Count a finished task and print the line."""
        self.done += runs
        self.failed += failed
        spent = max(time.monotonic() - self.started, 1e-9)
        rate = (self.done - self.start_done) / spent
        eta = (self.total - self.done) / rate if rate > 0 else math.inf
        line = (f'{self.what}: {self.done}/{self.total} runs, {self.failed} failed, '
                f'{rate:.1f} runs/s, ETA {eta:.0f} s')
        if self.in_place:
            end = '\n' if self.done >= self.total else ''
            print(f'\r{line}\x1b[K', end=end, file=self.stream, flush=True)
        else:
            print(line, file=self.stream, flush=True)


class Sweep:
    """
    A sweep (SPEC section 6) to run on a Dask client, in process, or resume.

    Use ``Sweep.from_file(path)``, then ``run(client, outdir)``: a pandas
    DataFrame, one row per run.
    """

    def __init__(self, spec: SweepSpec):
        self.spec = spec

    @classmethod
    def from_file(cls, path: str, runs: Optional[int] = None) -> 'Sweep':
        """Read and check a sweep file (``runs`` overrides its runs)."""
        return cls(load_sweep(path, runs=runs))

    @property
    def total(self) -> int:
        """Return the number of runs."""
        return self.spec.total

    def columns(self) -> list:
        """Return the table's columns."""
        return columns(self.spec)

    def run_one(self, k: int, record: Optional[str] = None) -> dict:
        """Run run k here and return its row."""
        return run_one(self.spec, k, record)

    def scenario(self, k: int) -> dict:
        """Return run k's scenario document (YAML-ready)."""
        return self.spec.run_document(k)

    def run(self, client=None, outdir: Optional[str] = None, *, record: str = 'none',
            csv: bool = False, progress: Optional[Callable[[int, int], None]] = None,
            threads: Optional[int] = None):
        """
        Run every run not yet done in outdir and return the whole table.

        Parameters
        ----------
        client : dask.distributed.Client, optional
            Where the tasks run; in this process, one task after another, if None.
        outdir : str, optional
            The sweep folder (kept, resumable); a temporary one if None.
        record : str
            'none', 'failed' or 'all': MCAP recordings under outdir/runs.
        csv : bool
            Also write results.csv.
        progress : callable, optional
            Called with (runs, failed runs) of each finished task.
        threads : int, optional
            Threads each task runs its runs on: by default the CPU count
            in this process, 1 on Dask (whose workers' threads run tasks
            side by side). The table is the same with any number.

        """
        if record not in RECORD:
            raise ArgumentError(f'record is {record!r}; expected one of {", ".join(RECORD)}')
        if outdir is None:
            with tempfile.TemporaryDirectory(prefix='cfem-sweep-') as tmp:
                return self.run(client, tmp, record=record, csv=csv, progress=progress,
                                threads=threads)
        failures = []
        if client is None:
            todo = prepare(self.spec, outdir, record)
            if todo:
                warn_once(self.spec)
            threads = threads or os.cpu_count() or 1
            for runs in groups(todo, 1):
                task_done(run_task(self.spec, runs, outdir, record, threads), progress,
                          failures)
        else:
            from dask.distributed import as_completed
            futures = self.submit(client, outdir, record=record, threads=threads)
            try:
                for future in as_completed(futures):
                    task_done(future.result(), progress, failures)
            finally:
                for future in futures:
                    future.cancel()
        if failures:   # the runs written are saved; those not are done again on resume
            raise ResourceFailure(failures[0])
        return assemble(self.spec, outdir, csv=csv)

    def submit(self, client, outdir: str, *, record: str = 'none',
               threads: Optional[int] = None) -> list:
        """
        Make or reopen the sweep folder and submit its runs not yet done to Dask.

        Return the futures, each of ``run_task``'s result; ``task_done``
        takes them, ``assemble`` gathers the folder once all are (what
        ``run`` does; an envelope submits its conditions' runs together).
        """
        todo = prepare(self.spec, outdir, record)
        if todo:
            warn_once(self.spec)
        workers = max(1, len(client.scheduler_info().get('workers', {})))
        # each task carries its own runs' values (no shared data to lose with a worker)
        return [client.submit(run_task, _part_of(self.spec, runs), runs, outdir, record,
                              threads or 1, pure=False, retries=2)
                for runs in groups(todo, workers)]
