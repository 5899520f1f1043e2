# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Batches of input points run as sweep runs: what the study methods call (SPEC section 9).

A rare-event or sensitivity method asks for the metrics at batches of
points it chose. ``Evaluator`` numbers the points as runs (0, 1, ... in the
order asked), runs each batch as the tasks of a sweep (on the Dask
client, or here), writes them as Parquet parts in the sweep folder, and
returns their rows. The methods are seeded, so running the same command
again asks for the same points in the same order: the runs a part already
holds are read back, not run again (resume), and a point that differs from
the one saved under its number stops the study (the folder holds another).
"""

from __future__ import annotations

import dataclasses
import glob
import hashlib
import json
import os
import sys
from typing import Callable, Optional

from cfem_ros.core.engine.events import Status
from cfem_ros.study.draws import RANDOM_NUMBERS
from cfem_ros.study.errors import SweepError
from cfem_ros.study.folder import read_manifest, read_table
from cfem_ros.study.resources import ResourceFailure
from cfem_ros.study.runs import numeric
from cfem_ros.study.spec import SweepSpec
from cfem_ros.study.sweep import (
    _part_of, columns, decide, frame, groups, MANIFEST, RESULTS, run_task, task_done,
    write_atomic)
import numpy as np

METHODS = ('mc', 'subset', 'nais', 'form')
#: Least runs of a Dask task of a study's batch: a subset step of 100 runs is one task per
#: worker of 2 (a task's own cost, the base scenario parsed, its part written and read
#: back, Dask's messages, then weighs some 4 % of its runs' where 4 tasks of 25 weighed 8).
LEAST_TASK_RUNS = 50
DESIGNS = ('morris', 'sobol')


def random_variables(spec: SweepSpec, what: str) -> list:
    """
    Return the sweep's varied key paths, each drawn from a distribution of numbers.

    Raises
    ------
    SweepError
        If one is a grid or a choice (these methods need a probability
        density over numbers), or none is varied.

    """
    for v in spec.variables:
        if v.kind not in RANDOM_NUMBERS:
            raise SweepError(spec.path, f'vary.{v.path}', f'is a {v.kind}, which {what} '
                             'cannot draw from', 'a distribution of numbers (normal, uniform, '
                             'truncnormal); run each grid value or choice as its own study')
        if v.kind == 'normal' and v.params[1] == 0:
            raise SweepError(spec.path, f'vary.{v.path}.normal', 'has standard deviation 0 '
                             '(a constant)', 'a standard deviation > 0, or the value set in '
                             'the scenario')
    if not spec.variables:
        raise SweepError(spec.path, 'vary', f'is empty: {what} has nothing to vary',
                         'at least one key path with a distribution')
    return list(spec.variables)


def study_digest(spec: SweepSpec, method: str, options: dict) -> str:
    """Return the hash of what decides a study's runs (the sweep, the method, its options)."""
    text = json.dumps([spec.describe(), method, options], sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


class Evaluator:
    """
    Run batches of points as numbered sweep runs and return their rows.

    Parameters
    ----------
    spec : SweepSpec
        The sweep; every varied key path a distribution of numbers.
    outdir : str
        The study folder (``sweep.json``, ``parts/``, ``results.parquet``).
    method : str
        What asks (a ``METHODS`` or ``DESIGNS`` name): the folder holds one.
    options : dict
        The method's options that decide its points (budget, seed, ...).
    client : dask.distributed.Client, optional
        Where the runs go; here (``threads`` threads) if None.
    rows : callable, optional
        ``rows(spec, runs) -> list of row dicts``: how a batch becomes rows.
        By default the sweep's own runs (``sweep.run_task``); a function of
        the values alone gives a scenario-free path through the same study.
    record : str
        'none', 'failed' or 'all' (as a sweep).
    log : callable, optional
        Called with a line of progress per batch.

    """

    def __init__(self, spec: SweepSpec, outdir: str, method: str, options: dict,
                 client=None, rows: Optional[Callable] = None, record: str = 'none',
                 threads: int = 1, log: Optional[Callable[[str], None]] = None):
        self.spec = spec
        self.outdir = outdir
        self.client = client
        self.rows = rows
        self.record = record
        self.threads = threads
        self.log = log or (lambda line: print(line, file=sys.stderr, flush=True))
        self.paths = [v.path for v in spec.variables]
        self.names = columns(spec)
        self.count = 0          # runs asked for so far
        self.ran = 0            # of them, run now (not read back)
        self._prepare(method, options)

    def _prepare(self, method: str, options: dict):
        self.method = method
        manifest = os.path.join(self.outdir, MANIFEST)
        digest = study_digest(self.spec, method, options)
        try:
            os.makedirs(os.path.join(self.outdir, 'parts'), exist_ok=True)
            if self.record != 'none':
                os.makedirs(os.path.join(self.outdir, 'runs'), exist_ok=True)
            if os.path.exists(manifest):
                held = read_manifest(self.outdir)
                if held.get('digest') != digest:
                    raise SweepError(self.outdir, '', f'holds another study ({held.get("sweep")},'
                                     f' method {held.get("method", "mc")}, hash '
                                     f'{held.get("digest", "")[:12]})', 'a new folder, or the '
                                     'same sweep file, method and options to resume it')
            else:
                tmp = manifest + '.tmp'
                with open(tmp, 'w', encoding='utf-8') as stream:
                    json.dump({'digest': digest, 'sweep': os.path.abspath(self.spec.path),
                               'method': method, 'options': options, 'total': None,
                               'resolved': json.loads(self.spec.describe())}, stream, indent=1)
                os.replace(tmp, manifest)
        except OSError as err:
            raise SweepError(self.outdir, '', f'cannot write ({err.strerror})',
                             'a folder this user can write') from err
        self.saved = self._saved()

    def _saved(self) -> dict:
        """Return the rows the finished parts hold, by run (leftovers of killed tasks removed)."""
        import pandas as pd
        for path in glob.glob(os.path.join(self.outdir, 'parts', '*.tmp-*')):
            os.remove(path)
        paths = sorted(glob.glob(os.path.join(self.outdir, 'parts', '*.parquet')))
        if not paths:
            return {}
        table = pd.concat([read_table(p, 'part') for p in paths], ignore_index=True)
        return {int(row['run']): row for row in records(table)}

    def __call__(self, points) -> 'pandas.DataFrame':  # noqa: F821
        """
        Return the rows of a batch of points (n, d), d the varied key paths in file order.

        The rows are in the order of the points, numbered from the runs asked before.
        """
        points = np.atleast_2d(np.asarray(points, dtype=float))
        runs = list(range(self.count, self.count + len(points)))
        self.count += len(points)
        values = {path: {k: float(x) for k, x in zip(runs, points[:, i])}
                  for i, path in enumerate(self.paths)}
        todo = []
        for k in runs:
            row = self.saved.get(k)
            if row is None:
                todo.append(k)
            elif not all(np.isclose(row[p], values[p][k], rtol=1e-12, atol=0.0)
                         for p in self.paths):
                raise SweepError(self.outdir, f'run {k}', 'holds other values than the study '
                                 'asks for now', 'a new folder (or the parts of this study only)')
        if todo:
            part = dataclasses.replace(self.spec, values={
                p: {k: values[p][k] for k in todo} for p in self.paths})
            self._read(self._run(part, todo))
            self.ran += len(todo)
        if self.method != 'mc':
            refuse_invalid(self.spec, self.method, [self.saved[k] for k in runs])
        failed = sum(self.saved[k]['status'] != Status.OK for k in todo)
        self.log(f'{len(points)} runs asked ({len(todo)} run, {len(points) - len(todo)} saved, '
                 f'{failed} failed); {self.count} in all')
        return frame([self.saved[k] for k in runs], self.names)

    def _read(self, paths):
        for path in paths:
            for row in records(read_table(path, 'part')):
                self.saved[int(row['run'])] = row

    def _run(self, part: SweepSpec, todo: list) -> list:
        """Run these runs as parts; return the parts' paths."""
        if self.client is None:   # one part per batch
            chunks = [todo]
        else:
            chunks = groups(todo, len(self.client.scheduler_info().get('workers', {})),
                            least=LEAST_TASK_RUNS)
        paths = [os.path.join(self.outdir, 'parts', f'part_{c[0]:07d}_{c[-1]:07d}.parquet')
                 for c in chunks]
        if self.rows is not None:
            for chunk, path in zip(chunks, paths):
                write_atomic(frame(self.rows(part, chunk), self.names), path)
            return paths
        failures = []
        if self.client is None:
            for chunk in chunks:
                task_done(run_task(part, chunk, self.outdir, self.record, self.threads),
                          failures=failures)
        else:
            futures = [self.client.submit(run_task, _part_of(part, chunk), chunk, self.outdir,
                                          self.record, 1, pure=False, retries=2)
                       for chunk in chunks]
            try:
                for future in futures:
                    task_done(future.result(), failures=failures)
            finally:
                for future in futures:
                    future.cancel()
        if failures:
            raise ResourceFailure(failures[0])
        return paths

    def assemble(self):
        """Write every run asked for to ``results.parquet`` (judged) and return the table."""
        table = decide(self.spec, self.outdir,
                       frame([self.saved[k] for k in range(self.count)], self.names))
        write_atomic(table, os.path.join(self.outdir, RESULTS), self.spec.document)
        return table


def records(table) -> list:
    """
    Return a DataFrame's rows as dicts of Python values, as ``table.to_dict('records')``.

    The same values of the same types (NaN as NaN, a masked column's NA as
    None) a column at a time: pandas' own reads each column again per call
    (0.4 ms a column of a part, 15 ms a part of 37 columns in the parent
    that waits for it).
    """
    import pandas as pd
    names = list(table.columns)
    columns = []
    for name in names:
        values = table[name].tolist()
        if getattr(table[name].dtype, 'na_value', None) is pd.NA:   # masked: NA is None
            values = [None if v is pd.NA else v for v in values]
        columns.append(values)
    return [dict(zip(names, row)) for row in zip(*columns)]


def refuse_invalid(spec: SweepSpec, method: str, rows):
    """
    Raise SweepError if a run of rows is invalid: a method that chose it needs its value.

    Monte Carlo leaves invalid draws out of P; a rare-event method's limit
    state and a sensitivity design need a value at every point they choose.
    """
    from cfem_ros.study.criteria import INVALID
    for row in rows:
        if row['status'] == INVALID:
            raise SweepError(spec.path, 'vary', f'--{"design" if method in DESIGNS else "method"}'
                             f' {method} drew run {row["run"]}, which the scenario\'s checks '
                             f'refuse ({row["message"]}); {method} needs a value at every '
                             'point it draws', 'distributions whose every draw is a valid '
                             'scenario (truncnormal bounds inside the valid range), or '
                             '--method mc, which leaves invalid draws out')


def table_values(spec: SweepSpec) -> np.ndarray:
    """Return the sweep's own draws as points (runs, d): what plain Monte Carlo runs."""
    for v in spec.variables:
        if not numeric(v):
            raise SweepError(spec.path, f'vary.{v.path}', f'is a {v.kind} of other values '
                             'than numbers', 'numbers')
    return np.array([[float(spec.values[v.path][k]) for v in spec.variables]
                     for k in range(spec.total)]).reshape(spec.total, len(spec.variables))


def write_json(path: str, content: dict):
    """Write a JSON file through a temporary file."""
    tmp = f'{path}.tmp-{os.getpid()}'
    with open(tmp, 'w', encoding='utf-8') as stream:
        json.dump(content, stream, indent=1)
    os.replace(tmp, path)
