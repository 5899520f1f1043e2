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

from concurrent.futures import ThreadPoolExecutor
import copy
import dataclasses
import glob
import json
import logging
import math
import os
import sys
import tempfile
import threading
import time
from typing import Callable, Optional

from cfem_ros.core.engine.simulator import REDUNDANT_MESSAGES, Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.run.session import Session
from cfem_ros.core.scenario.parse import parse_scenario, reparse
from cfem_ros.recording.export import write_frame
from cfem_ros.study.criteria import INVALID
from cfem_ros.study.folder import read_manifest, read_table
from cfem_ros.study.metrics import Collector, compute, empty
from cfem_ros.study.resources import (
    PartialRows, recording_failure, ResourceFailure, unrecorded)
from cfem_ros.study.spec import (
    apply_values, load_sweep, RANDOM_NUMBERS, resolve, SweepError, SweepSpec)

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


def column_value(value, numeric: bool):
    """
    Return a varied value as a table cell.

    A variable whose values are all numbers has a float column; any other
    has a text column: strings as they are, other values as JSON.
    """
    if numeric:
        return float(value)
    return value if isinstance(value, str) else json.dumps(value)


def numeric(variable) -> bool:
    """Tell whether every value a variable takes is a number."""
    return variable.kind in RANDOM_NUMBERS or all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in variable.params)


def _section(tokens, document) -> Optional[tuple]:
    """Return ('bodies'|'joints', name) or ('wrenches', '') if a key path lies inside one."""
    if len(tokens) >= 3 and tokens[0] == 'wrenches' and isinstance(tokens[1], int) \
            and isinstance(document.get('wrenches'), list):
        return 'wrenches', ''
    if len(tokens) < 3 or tokens[0] not in ('bodies', 'joints') \
            or not isinstance(tokens[1], str) or tokens[:3] == ('bodies', tokens[1], 'fixed'):
        return None
    mapping = document.get(tokens[0])
    if not isinstance(mapping, dict) or not isinstance(mapping.get(tokens[1]), dict):
        return None
    return tokens[0], tokens[1]


def _source(spec: SweepSpec, k: int) -> str:
    return f'{spec.scenario} (run {k})'


def full_model(spec: SweepSpec, k: int, values: dict):
    """Return run k's model, its whole document parsed."""
    return parse_scenario(apply_values(spec.document, spec.variables, values),
                          source=_source(spec, k))


class Models:
    """
    The runs' models, the base scenario parsed once per task.

    A key path inside a body (but its ``fixed``), a joint or a wrench only
    needs that body or joint, or the wrenches, parsed again
    (``scenario.reparse``); the others (``dt``, ``aero``, ...) need a whole
    parse, done once per distinct set of their
    values if they are choices or grids (a run drawing numbers for them is
    parsed whole). A run whose values do not parse is parsed whole again,
    so that its message is the whole parse's. A document in which one
    mapping or list sits in two places (a YAML alias) is parsed whole for
    every run: a value set in one place shows in the other. Safe to share
    between threads.
    """

    def __init__(self, spec: SweepSpec):
        self.spec = spec
        sections = {v.path: _section(v.tokens, spec.document) for v in spec.variables}
        self.touched = sorted({s for s in sections.values() if s is not None})
        self.slow = [v for v in spec.variables if sections[v.path] is None]
        if any(v.kind in RANDOM_NUMBERS for v in self.slow) or _shared(spec.document):
            self.touched = []   # a whole parse per run
        self.inside = {s: [v for v in spec.variables if sections[v.path] == s]
                       for s in self.touched}
        self._bases = {}
        self._lock = threading.Lock()
        self._parts = {kind: [n for k, n in self.touched if k == kind]
                       for kind in ('bodies', 'joints')}

    def full(self, k: int, values: dict):
        """Return run k's model parsed whole from its document."""
        return full_model(self.spec, k, values)

    def model(self, k: int, values: dict):
        """Return run k's model, the same to the bit as a whole parse gives."""
        if not self.touched:
            return self.full(k, values)
        key = json.dumps([values[v.path] for v in self.slow], default=repr) if self.slow else ''
        with self._lock:
            base = self._bases.get(key)
        if base is None:
            document = apply_values(self.spec.document, self.slow, values)
            try:
                model = parse_scenario(document, source=_source(self.spec, k))
            except Exception:   # noqa: B902 (this run's whole parse names the error)
                model = None
            base = (document, model)
            with self._lock:
                self._bases.setdefault(key, base)
        document, model = base
        if model is None:
            return self.full(k, values)
        try:
            top = dict(document)
            for kind, name in self.touched:
                if kind == 'wrenches':
                    part = top[kind] = list(document[kind])
                    for variable in self.inside[kind, name]:
                        _set_copying(part, variable.tokens[1:], values[variable.path])
                    continue
                top[kind] = dict(top[kind])
                part = top[kind][name] = dict(document[kind][name])
                for variable in self.inside[kind, name]:
                    _set_copying(part, variable.tokens[2:], values[variable.path])
            return reparse(model, top, source=_source(self.spec, k),
                           bodies=self._parts['bodies'], joints=self._parts['joints'],
                           wrenches=('wrenches', '') in self.touched)
        except Exception:   # noqa: B902
            return self.full(k, values)


def _shared(document) -> bool:
    """Tell whether a mapping or list sits in two places in document (a YAML alias)."""
    seen = set()
    stack = [document]
    while stack:
        node = stack.pop()
        if isinstance(node, (dict, list)):
            if id(node) in seen:
                return True
            seen.add(id(node))
            stack.extend(node.values() if isinstance(node, dict) else node)
    return False


def _set_copying(part: dict, tokens, value):
    """
    Set a key path in part (a copy of a section) to value, copying what it goes through.

    Only the mappings and lists on the path are copied (the rest is shared
    with the base document, which the parse only reads): what a deep copy
    of the section would give, in a fraction of its time, when nothing in
    the document sits in two places (``_shared``).
    """
    node = part
    for token in tokens[:-1]:   # a path that does not lead anywhere raises: a whole parse
        child = node[token]
        node[token] = child = dict(child) if isinstance(child, dict) else list(child)
        node = child
    container, last, _, _ = resolve(node, tokens[-1:])
    container[last] = copy.deepcopy(value)


#: The runs' simulators log here: all but the redundant-joint message, given once
#: per sweep (``warn_once``) instead of once per run, in every worker's log.
RUNS_LOG = logging.getLogger('cfem_ros.sweep.runs')
RUNS_LOG.addFilter(lambda record: record.msg not in REDUNDANT_MESSAGES)
_ONCE_LOG = logging.getLogger('cfem_ros.sweep')
_ONCE_LOG.addFilter(lambda record: record.msg in REDUNDANT_MESSAGES)   # only it


def warn_once(spec: SweepSpec):
    """Give the redundant-joint warning of the sweep's first run, once for the whole sweep."""
    try:
        Simulator(Models(spec).model(0, spec.run_values(0)), logger=_ONCE_LOG)
    except Exception:   # noqa: B902 (an invalid first run is that run's failed row)
        pass


def run_one(spec: SweepSpec, k: int, record: Optional[str] = None,
            models: Optional[Models] = None) -> dict:
    """
    Run run k of a sweep and return its table row (a dict, columns in order).

    A run whose values the scenario's checks refuse is not run: a row with
    ``status`` 'invalid' (SPEC section 12) and the check's message. A run
    that fails is a row with ``status`` 'failed' and the reason in
    ``message``; its metrics are those of the samples it did take.
    record: the path of an MCAP recording to write of it. models: where the model comes from (a
    ``Models`` of spec, shared by a task's runs); the whole parse if None.
    """
    values = spec.run_values(k)
    row = {'run': k}
    row.update((v.path, column_value(values[v.path], numeric(v))) for v in spec.variables)
    row.update(status='ok', message='')
    try:
        model = full_model(spec, k, values) if models is None else models.model(k, values)
        sim = Simulator(model, logger=RUNS_LOG)
    except ScenarioError as err:   # the scenario's own checks refuse the draw: not run
        row.update(status=INVALID, message=str(err))
        row.update(empty(spec.metrics))
        return row
    except Exception as err:   # noqa: B902 (any other refusal is this run's failure)
        row.update(status='failed', message=str(err))
        row.update(empty(spec.metrics))
        return row
    try:
        if record is None:
            collector = Collector(sim)
            _session_run(sim, model, spec, collector)
        else:
            from cfem_ros.recording.recorder import Recorder, run_metadata, StateRecorder
            meta = run_metadata(model, spec.scenario, spec.rate_hz, 0,
                                sweep=os.path.abspath(spec.path), run=k,
                                values=json.dumps(values))
            with Recorder(record, overwrite=True, metadata=meta) as recorder:
                collector = Collector(sim, forward=StateRecorder(recorder, sim))
                _session_run(sim, model, spec, collector)
        row.update(compute(collector.samples(), spec.metrics))
    except Exception as err:   # noqa: B902
        if record is not None and recording_failure(err):
            raise   # a recording that cannot be written is no result of the run
        row.update(status='failed', message=f'{type(err).__name__}: {err}')
        row.update(empty(spec.metrics))
        return row
    if sim.status in ('contact', 'aero_outside'):   # stopped as the scenario asks (SPEC 8, 10)
        row.update(status=sim.status, message=sim.message)
    elif sim.status != 'running':
        row.update(status='failed', message=f'the run failed {sim.message}')
    return row


def _session_run(sim, model, spec, collector):
    Session(sim, rate_hz=spec.rate_hz, duration=model.duration, outputs=[collector]).run()


def run_rows(spec: SweepSpec, runs, outdir: Optional[str] = None,
             record: str = 'none', threads: int = 1) -> list:
    """
    Return the rows of the given runs, recording them under outdir/runs as asked.

    The base scenario is parsed once (``Models``); with threads > 1 the
    runs go to that many threads, which run in parallel (the compiled
    stepping releases the GIL), the rows in the order of runs.
    """
    models = Models(spec)
    unwritten = {}

    def one(k):
        path = None
        if record == 'all':
            path = os.path.join(outdir, 'runs', f'run_{k}.mcap')
        try:
            row = run_one(spec, k, path, models)
            if record == 'failed' and row['status'] == 'failed':
                run_one(spec, k, os.path.join(outdir, 'runs', f'run_{k}.mcap'), models)
        except Exception as err:   # noqa: B902 (run_one lets only a recording failure out)
            unwritten[k] = str(err)
            return None
        return row

    if threads > 1 and len(runs) > 1:
        with ThreadPoolExecutor(max_workers=threads) as pool:
            rows = list(pool.map(one, runs))
    else:
        rows = [one(k) for k in runs]
    if unwritten:   # the runs recorded are kept in a part, the others done again on resume
        raise PartialRows([row for row in rows if row is not None],
                          unrecorded(unwritten, next(iter(unwritten.values())), outdir))
    return rows


def columns(spec: SweepSpec) -> list:
    """Return the table's columns in order."""
    return (['run'] + [v.path for v in spec.variables] + ['status', 'message']
            + spec.metrics.columns())


def frame(rows, names):
    """Return rows as a pandas DataFrame with these columns, in order."""
    import pandas as pd
    return pd.DataFrame.from_records(rows, columns=names)


def write_atomic(table, path: str):
    """Write a DataFrame to Parquet (or CSV for .csv) through a temporary file."""
    write_frame(table, path)


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
    return len(rows), sum(r['status'] == 'failed' for r in rows), failure


def task_done(done: tuple, progress=None, failures=None):
    """Take a task's result: progress(runs, failed); a resource failure kept in failures."""
    if progress:
        progress(done[0], done[1])
    if done[2] is not None and failures is not None:
        failures.append(done[2])


def _done_runs(outdir: str) -> set:
    """Return the runs the finished parts hold (removing leftovers of killed tasks)."""
    import pyarrow.parquet as pq
    done = set()
    for path in glob.glob(os.path.join(outdir, 'parts', '*.tmp-*')):
        os.remove(path)
    for path in sorted(glob.glob(os.path.join(outdir, 'parts', '*.parquet'))):
        try:
            done.update(pq.read_table(path, columns=['run']).column('run').to_pylist())
        except Exception:  # noqa: B902 - a damaged part: said by the reader, in one line
            read_table(path, 'part')
            raise
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
        done = _done_runs(outdir)
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
        raise RuntimeError(f'{outdir}: runs {missing[:10]} are missing from the parts')
    table = decide(spec, outdir, table)
    write_atomic(table, os.path.join(outdir, RESULTS))
    if csv:
        write_atomic(table, os.path.join(outdir, 'results.csv'))
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


def groups(runs, workers: int) -> list:
    """Split runs into about TASKS_PER_WORKER tasks per worker, in order."""
    if not runs:
        return []
    size = max(1, math.ceil(len(runs) / (TASKS_PER_WORKER * max(1, workers))))
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

    def __init__(self, total: int, done: int, stream=None):
        self.total, self.done, self.failed = total, done, 0
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
        line = (f'sweep: {self.done}/{self.total} runs, {self.failed} failed, '
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
            raise ValueError(f'record is {record!r}; expected one of {", ".join(RECORD)}')
        if outdir is None:
            with tempfile.TemporaryDirectory(prefix='cfem-sweep-') as tmp:
                return self.run(client, tmp, record=record, csv=csv, progress=progress,
                                threads=threads)
        todo = prepare(self.spec, outdir, record)
        if todo:
            warn_once(self.spec)
        failures = []
        if client is None:
            threads = threads or os.cpu_count() or 1
            for runs in groups(todo, 1):
                task_done(run_task(self.spec, runs, outdir, record, threads), progress,
                          failures)
        else:
            from dask.distributed import as_completed
            workers = max(1, len(client.scheduler_info().get('workers', {})))
            # each task carries its own runs' values (no shared data to lose with a worker)
            futures = [client.submit(run_task, _part_of(self.spec, runs), runs, outdir,
                                     record, threads or 1, pure=False, retries=2)
                       for runs in groups(todo, workers)]
            try:
                for future in as_completed(futures):
                    task_done(future.result(), progress, failures)
            finally:
                for future in futures:
                    future.cancel()
        if failures:   # the runs written are saved; those not are done again on resume
            raise ResourceFailure(failures[0])
        return assemble(self.spec, outdir, csv=csv)
