# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A study folder by method (SPEC section 9): the runs, then the estimate or the indices.

``run_study(spec, outdir, method=..., design=...)`` runs what the method
asks for through an ``Evaluator`` (every run in ``results.parquet``,
resumable), and writes ``estimate.json`` or ``sensitivity.parquet``.
``mc_estimate`` gives a finished Monte Carlo sweep's estimate.
"""

from __future__ import annotations

import os
from typing import Callable, Optional

from cfem_ros.core.errors import ArgumentError
from cfem_ros.study.errors import SweepError
from cfem_ros.study.evaluate import DESIGNS, Evaluator, METHODS, write_json
from cfem_ros.study.reliability import mc_estimate, REPEAT  # noqa: F401 - for cfem-sim sweep
from cfem_ros.study.spec import SweepSpec

ESTIMATE = 'estimate.json'
SENSITIVITY = 'sensitivity.parquet'
#: Fewest runs (the method's batch: points per level, step, batch, trajectories or base
#: sample) that each method answers with, and the multiple runs must be of.
MINIMUM_RUNS = {'subset': (100, 10), 'nais': (100, 1), 'form': (10, 1), 'morris': (2, 1),
                'sobol': (8, 1)}
WHY = {'subset': 'a level of subset sampling is runs points, whose 10 % lowest (at least 10 '
                 'Markov chains) seed the next',
       'nais': "each step's 10 % quantile must rest on at least 10 points",
       'form': 'each importance-sampling batch needs points to measure its spread',
       'morris': "each elementary effect's spread (sigma) needs a few trajectories",
       'sobol': 'the indices and their intervals need a base sample of a few points'}


def check_size(spec: SweepSpec, name: str):
    """Refuse, before anything runs, a method or design whose runs are too few to answer."""
    least, multiple = MINIMUM_RUNS.get(name, (1, 1))
    if spec.runs < least or spec.runs % multiple:
        times = f', a multiple of {multiple}' if multiple > 1 else ''
        raise SweepError(spec.path, 'runs', f'is {spec.runs} for {name} ({WHY[name]})',
                         f'at least {least}{times} (--runs N)')


def write_estimate(outdir: str, estimate, target: Optional[float] = None):
    """Write ``estimate.json`` (SPEC section 9), with the decision against a target if given."""
    if target is not None:
        from cfem_ros.study.decision import decide_estimate
        found = decide_estimate(estimate, target)
        estimate.target, estimate.decision = target, found.decision
        estimate.decision_sentence = found.sentence()
    write_json(os.path.join(outdir, ESTIMATE), estimate.as_dict())


def run_study(spec: SweepSpec, outdir: str, *, method: str = 'mc',
              design: Optional[str] = None, client=None, target_cov: float = 0.1,
              rows: Optional[Callable] = None, record: str = 'none',
              threads: int = 1, log: Optional[Callable[[str], None]] = None,
              repeat: int = REPEAT) -> dict:
    """
    Run a rare-event method or a sensitivity design and write its results.

    Parameters
    ----------
    spec : SweepSpec
        The sweep: distributions, criteria, runs (the method's budget), seed.
    outdir : str
        The study folder: a folder holds one study (resumed when run again).
    method : str
        One of ``METHODS`` but 'mc' (the sweep itself) when design is None.
    design : str, optional
        'morris' or 'sobol'.
    client, rows, record, threads, log
        As ``Evaluator``'s.
    target_cov : float
        FORM's importance sampling stops at this coefficient of variation.
    repeat : int
        Subset sampling's independent repetitions; FORM's least importance
        sampling batches (``--repeat``).

    Returns
    -------
    dict
        'table' (every run, judged), and 'estimate' (``Estimate``) or
        'indices' (a DataFrame).

    """
    if design is not None and design not in DESIGNS:
        raise ArgumentError(f'design is {design!r}; expected one of {", ".join(DESIGNS)}')
    if method not in METHODS:
        raise ArgumentError(f'method is {method!r}; expected one of {", ".join(METHODS)}')
    name = design or method
    check_size(spec, name)
    options = {'runs': spec.runs, 'seed': spec.seed}
    if name == 'form':
        options['target_cov'] = target_cov
    if name in ('form', 'subset'):
        options['repeat'] = repeat
    evaluate = Evaluator(spec, outdir, name, options, client=client, rows=rows, record=record,
                         threads=threads, log=log)
    if design is not None:
        from cfem_ros.study.sensitivity import run_design
        from cfem_ros.study.sweep import write_atomic
        found, _ = run_design(spec, design, evaluate)
        found.insert(2, 'design', design)
        write_atomic(found, os.path.join(outdir, SENSITIVITY))
        return {'table': evaluate.assemble(), 'indices': found}
    from cfem_ros.study.reliability import estimate
    result = estimate(spec, method, evaluate, spec.criteria, target_cov=target_cov,
                      runs=spec.runs, repeat=repeat)
    table = evaluate.assemble()
    from cfem_ros.study.criteria import valid_runs   # invalid draws: no pass, no failure
    result.failed_runs = int((~valid_runs(table)['pass'].to_numpy(dtype=bool)).sum())
    write_estimate(outdir, result, spec.target)
    return {'table': table, 'estimate': result}
