# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
One run of a sweep to its table row, and a group of runs on threads.

A run's row holds its values, its status and message, and its metrics; a
run the scenario's checks refuse is ``invalid``, one that fails ``failed``.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
import json
import logging
import os
from typing import Optional

from cfem_ros.core.engine.dynamics import redundant_record
from cfem_ros.core.engine.events import Status
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.run.session import Session
from cfem_ros.study.criteria import INVALID
from cfem_ros.study.draws import RANDOM_NUMBERS
from cfem_ros.study.metrics import Collector, compute, empty
from cfem_ros.study.resources import PartialRows, recording_failure, unrecorded
from cfem_ros.study.runmodels import full_model, Models
from cfem_ros.study.spec import SweepSpec


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


#: The runs' simulators log here: all but the redundant-joint message, given once
#: per sweep (``warn_once``) instead of once per run, in every worker's log.
RUNS_LOG = logging.getLogger('cfem_ros.sweep.runs')
RUNS_LOG.addFilter(lambda record: not redundant_record(record))
_ONCE_LOG = logging.getLogger('cfem_ros.sweep')
_ONCE_LOG.addFilter(redundant_record)   # only it


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
    ``status`` ``Status.INVALID`` (SPEC section 12) and the check's message;
    so is one that ends within its first step of a draw ``cfem-sim check``
    refuses (``Simulator.refusal``: check's line; no metrics). A run that
    fails is a row with ``status`` ``Status.FAILED`` and the reason in
    ``message``; its metrics are those of the samples it did take.
    record: the path of an MCAP recording to write of it. models: where the model comes from (a
    ``Models`` of spec, shared by a task's runs); the whole parse if None.
    """
    values = spec.run_values(k)
    row = {'run': k}
    row.update((v.path, column_value(values[v.path], numeric(v))) for v in spec.variables)
    row.update(status=Status.OK, message='')
    try:
        model = full_model(spec, k, values) if models is None else models.model(k, values)
        sim = Simulator(model, logger=RUNS_LOG)
    except ScenarioError as err:   # the scenario's own checks refuse the draw: not run
        row.update(status=INVALID, message=str(err))
        row.update(empty(spec.metrics))
        return row
    except Exception as err:   # noqa: B902 (any other refusal is this run's failure)
        row.update(status=Status.FAILED, message=str(err))
        row.update(empty(spec.metrics))
        return row
    try:
        if record is None:
            collector = Collector(sim)
            session_run(sim, model, spec, collector)
        else:
            from cfem_ros.recording.container import Recorder
            from cfem_ros.recording.recorder import run_metadata, StateRecorder
            meta = run_metadata(model, spec.scenario, spec.rate_hz, model.start_ns,
                                sweep=os.path.abspath(spec.path), run=k,
                                values=json.dumps(values))
            with Recorder(record, overwrite=True, metadata=meta) as recorder:
                collector = Collector(sim, forward=StateRecorder(recorder, sim,
                                                                 start_ns=model.start_ns))
                session_run(sim, model, spec, collector)
        row.update(compute(collector.samples(), spec.metrics))
    except Exception as err:   # noqa: B902
        if record is not None and recording_failure(err):
            raise   # a recording that cannot be written is no result of the run
        row.update(status=Status.FAILED, message=f'{type(err).__name__}: {err}')
        if sim.refusal:
            row.update(status=INVALID, message=sim.refusal)
        row.update(empty(spec.metrics))
        return row
    if sim.refusal:   # check refuses the draw (asked as its run ended at its start)
        row.update(status=INVALID, message=sim.refusal)
        row.update(empty(spec.metrics))
    elif sim.status.stopped_by_scenario:   # stopped as the scenario asks (SPEC 8, 10)
        row.update(status=sim.status, message=sim.message)
    elif sim.status is Status.FAILED:
        row.update(status=Status.FAILED, message=f'the run failed {sim.message}')
    return row


def session_run(sim, model, spec, collector):
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
            if record == 'failed' and row['status'] == Status.FAILED:
                run_one(spec, k, os.path.join(outdir, 'runs', f'run_{k}.mcap'), models)
        except Exception as err:   # noqa: B902 (run_one lets only a recording failure out)
            if not recording_failure(err):
                raise   # not the disk's: a run the spec does not have, a defect; said as it is
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
