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

from cfem_ros.study.evaluate import DESIGNS, Evaluator, METHODS, write_json
from cfem_ros.study.reliability import mc_estimate  # noqa: F401 - for cfem-sim sweep
from cfem_ros.study.spec import SweepSpec

ESTIMATE = 'estimate.json'
SENSITIVITY = 'sensitivity.parquet'


def write_estimate(outdir: str, estimate):
    """Write ``estimate.json`` (SPEC section 9)."""
    write_json(os.path.join(outdir, ESTIMATE), estimate.as_dict())


def run_study(spec: SweepSpec, outdir: str, *, method: str = 'mc',
              design: Optional[str] = None, client=None, target_cov: float = 0.1,
              rows: Optional[Callable] = None, record: str = 'none',
              threads: int = 1, log: Optional[Callable[[str], None]] = None) -> dict:
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

    Returns
    -------
    dict
        'table' (every run, judged), and 'estimate' (``Estimate``) or
        'indices' (a DataFrame).

    """
    if design is not None and design not in DESIGNS:
        raise ValueError(f'design is {design!r}; expected one of {", ".join(DESIGNS)}')
    if method not in METHODS:
        raise ValueError(f'method is {method!r}; expected one of {", ".join(METHODS)}')
    name = design or method
    options = {'runs': spec.runs, 'seed': spec.seed}
    if name == 'form':
        options['target_cov'] = target_cov
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
                      runs=spec.runs)
    write_estimate(outdir, result)
    return {'table': evaluate.assemble(), 'estimate': result}
