# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""``cfem-sim sweep``: a sweep's runs on Dask, a study (``studies``), or a plan's run count."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time
from typing import Optional

from cfem_ros.cli import studies
from cfem_ros.cli.cluster import close, dask_client, raise_interrupted, study_imports
from cfem_ros.cli.common import error, EXIT_FAILED, EXIT_OK, failed, signals_to, STOPS
from cfem_ros.core.engine.events import Status
from cfem_ros.core.errors import CfemError
from cfem_ros.interrupts import exit_now, Interrupted
from cfem_ros.study.resources import ResourceFailure


def add_parser(sub):
    """Add ``cfem-sim sweep`` to the command line's subparsers."""
    sweep = sub.add_parser('sweep', help='run a separation study (many runs) on Dask',
                           description='Run the runs of a sweep file (SPEC section 6) on a '
                           'Dask cluster and write OUTDIR/results.parquet, one row per run. '
                           'Run again with the same OUTDIR to resume.')
    sweep.add_argument('sweep', metavar='SWEEP.yaml', nargs='?', help='sweep file')
    sweep.add_argument('-o', '--output', metavar='OUTDIR',
                       help='sweep folder (results.parquet, parts/, runs/)')
    where = sweep.add_mutually_exclusive_group()
    where.add_argument('--workers', type=int, metavar='N',
                       help='local worker processes (default: the CPU count)')
    where.add_argument('--scheduler', metavar='ADDRESS',
                       help='use a running Dask scheduler, e.g. tcp://10.0.0.5:8786')
    sweep.add_argument('--runs', type=int, metavar='K',
                       help="overrides the file's runs: random draws (mc), points per level, "
                       'step or batch (subset, nais, form), trajectories (morris), base '
                       'sample (sobol)')
    sweep.add_argument('--record', choices=('none', 'failed', 'all'), default='none',
                       help='write OUTDIR/runs/run_<k>.mcap for these runs (default none)')
    sweep.add_argument('--csv', action='store_true', help='also write results.csv')
    sweep.add_argument('--method', choices=('mc', 'subset', 'nais', 'form'), default='mc',
                       help='mc: the runs of the file (default); subset, nais, form: estimate '
                       'P(a criterion fails) with OpenTURNS, runs points per level/step/batch')
    sweep.add_argument('--design', choices=('morris', 'sobol'),
                       help='sensitivity indices with SALib: runs Morris trajectories, or '
                       "Sobol's base sample")
    sweep.add_argument('--cov', type=float, default=0.1, metavar='COV',
                       help='--method form: sample until this coefficient of variation '
                       '(default 0.1)')
    sweep.add_argument('--repeat', type=int, default=5, metavar='K',
                       help='--method subset: independent repetitions, each with its own '
                       'seed; --method form: least importance-sampling batches; their spread '
                       'gives the one-sided bound p_upper (default 5)')
    sweep.add_argument('--plan', metavar='P,C',
                       help='print how many runs without failure show P(success) >= P at '
                       'confidence C (0.95,0.95 -> 59), and exit')
    sweep.set_defaults(func=sweep_command)


def sweep_command(args: argparse.Namespace) -> int:
    """Run a sweep on Dask into -o (resuming it), a study, or a plan; exit 0, 1 or 2."""
    if args.plan is not None:
        return plan_command(args.plan)
    refused = _refused(args)
    if refused:
        return error(refused)
    if args.design is not None or args.method != 'mc':
        return studies.study_command(args)
    return _run_sweep(args)


def plan_command(plan: str) -> int:
    """Print how many runs without a failure show P(success) >= P at confidence C."""
    from cfem_ros.study.confidence import runs_needed
    try:
        success, level = (float(v) for v in plan.split(','))
        n = runs_needed(success, level)
    except ValueError:
        return error(f'--plan {plan!r}; expected P,C: a success probability and a '
                     'confidence, each between 0 and 1 (0.95,0.95)')
    print(f'{n} runs without a failure show P(success) >= {success:g} at {100 * level:g} % '
          f'confidence (P(fail) <= {1 - success:.3g}); with failures, more runs are needed')
    return EXIT_OK


def _refused(args) -> Optional[str]:
    """Return why the arguments of a sweep or study cannot be run (None if they can)."""
    if args.sweep is None or args.output is None:
        return 'cfem-sim sweep: expected SWEEP.yaml -o OUTDIR (or --plan P,C)'
    if args.workers is not None and args.workers < 1:
        return f'--workers: is {args.workers}; expected a number of workers >= 1'
    if args.design is not None and args.method != 'mc':
        return f'--method {args.method} and --design {args.design}: expected one of them'
    if getattr(args, 'repeat', 5) < 2:
        return (f'--repeat: is {args.repeat}; expected at least 2 independent repetitions '
                '(their spread is the bound; 5 by default)')
    if os.path.exists(args.output) and not os.path.isdir(args.output):
        return (f'-o {args.output}: is not a folder; expected the sweep folder (new, or one '
                'to resume)')
    return None


def _run_sweep(args) -> int:
    """Run the runs of a sweep file not yet in its folder; exit 0, 1 (failed runs) or 2."""
    try:
        study = study_imports()
        sweep = study.Sweep.from_file(args.sweep, runs=args.runs)
        outdir = os.path.abspath(args.output)
        from cfem_ros.study.sweep import prepare
        todo = prepare(sweep.spec, outdir, args.record)
    except CfemError as err:
        return error(str(err))
    total = sweep.total
    print(f'{args.sweep}: {total} runs, {total - len(todo)} already in {outdir}',
          file=sys.stderr)
    started = time.monotonic()
    status, table, late = _on_cluster(args, sweep, outdir, todo)
    if status is not None:
        return status
    if late is not None:
        print(f'{signal.Signals(late).name} while the cluster was closing: the sweep had '
              f'finished, its table is complete in {outdir}', file=sys.stderr)
    runs_failed = _print_sweep(sweep, table, outdir, time.monotonic() - started)
    from cfem_ros.study.criteria import no_valid_draw
    nothing = no_valid_draw(table)
    if late is not None:
        return 128 + late
    if nothing is not None:   # the table is kept: each draw's reason is in it
        return error(f'{args.sweep}: {nothing}')
    return EXIT_FAILED if runs_failed else EXIT_OK


def _on_cluster(args, sweep, outdir: str, todo: list) -> tuple:
    """
    Run a sweep's runs left to do on Dask.

    Return (status, table, late): status an exit status if the sweep was
    stopped or failed (else None), table its results, late the signal held
    while the cluster was closing (or None).
    """
    from cfem_ros.study.sweep import Progress
    client = cluster = None
    # SIGINT and SIGTERM stop the waiting here, so that the cluster is closed (no leaked
    # worker processes or semaphores) and the user is told what is kept
    with signals_to(raise_interrupted):
        try:
            if todo:
                try:
                    client, cluster = dask_client(args.workers, args.scheduler)
                except OSError as err:
                    return error(f'{args.scheduler or "local cluster"}: {err}'), None, None
            meter = Progress(sweep.total, sweep.total - len(todo))
            table = sweep.run(client, outdir, record=args.record, csv=args.csv,
                              progress=meter.update)
        except Interrupted as stop:
            for s in STOPS:   # a second one ends at once
                signal.signal(s, exit_now)
            close(client, cluster, hold=False)
            client = cluster = None
            from cfem_ros.study.sweep import saved_runs
            print(f'\ninterrupted by {stop}: {saved_runs(outdir)} of {sweep.total} runs are '
                  f'saved in {outdir}; run the same command again to resume', file=sys.stderr)
            return stop.exit_status, None, None
        except ResourceFailure as err:
            return failed(str(err)), None, None
        except OSError as err:   # writing the sweep's files: what is written is kept
            return failed(f'{err.filename2 or err.filename or outdir}: cannot write '
                          f'({err.strerror or err}); the runs done are '
                          'saved: run the same command again to resume'), None, None
        finally:
            late = close(client, cluster)
    return None, table, late


def _print_sweep(sweep, table, outdir: str, wall: float) -> int:
    """Print what a sweep found and write its estimate; return how many runs failed."""
    runs_failed = int((table['status'] == Status.FAILED).sum())
    touched = int((table['status'] == Status.CONTACT).sum())
    contact = f'{touched} stopped at a contact, ' if touched else ''
    invalid = int((table['status'] == Status.INVALID).sum())
    if invalid:   # SPEC section 12: reported, never counted as failures
        contact += (f"{invalid} invalid draws (refused by the scenario's checks, not run, "
                    'left out of every probability), ')
    print(f'{os.path.join(outdir, "results.parquet")}: {sweep.total} runs, {runs_failed} '
          f'failed, {contact}{wall:.3g} s')
    for _, row in table[table['status'] == Status.FAILED].head(5).iterrows():
        print(f'  run {row["run"]} failed: {row["message"]}', file=sys.stderr)
    from cfem_ros.study.criteria import no_valid_draw
    if sweep.spec.criteria and no_valid_draw(table) is None:   # else nothing to estimate
        from cfem_ros.study import methods
        from cfem_ros.study.confidence import fractions
        for fraction in fractions(table, sweep.spec.criteria, sweep.spec.confidence):
            print(fraction.sentence())
        found = methods.mc_estimate(sweep.spec, table)
        methods.write_estimate(outdir, found, sweep.spec.target)
        if found.decision_sentence:
            print(found.decision_sentence)
    return runs_failed
