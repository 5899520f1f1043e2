# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""``cfem-sim sweep --method`` and ``--design``: a rare-event method or a sensitivity design."""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import time

from cfem_ros.cli.cluster import close, dask_client, raise_interrupted, study_imports
from cfem_ros.cli.common import error, EXIT_OK, failed, signals_to, STOPS
from cfem_ros.core.engine.events import Status
from cfem_ros.core.errors import CfemError, InputError
from cfem_ros.interrupts import exit_now, Interrupted
from cfem_ros.study.resources import MethodFailed, ResourceFailure


def study_command(args: argparse.Namespace) -> int:
    """Run a rare-event method or a sensitivity design (SPEC section 9); exit 0, 1 or 2."""
    if not (math.isfinite(args.cov) and 0 < args.cov < 1):
        return error(f'--cov is {args.cov!r}; expected a coefficient of variation '
                     'between 0 and 1 (0.1)')
    try:
        spec = _checked_spec(args)
    except CfemError as err:
        return error(str(err))
    except ImportError as err:
        return error(f'--{"design" if args.design else "method"} needs {err.name}, which is '
                     "not installed; install the study extra: pip install -e '.[study]'")
    outdir = os.path.abspath(args.output)
    started = time.monotonic()
    status, found = _on_cluster(args, spec, outdir)
    if status is not None:
        return status
    from cfem_ros.study import methods
    table = found['table']
    not_finished = int((table['status'] != Status.OK).sum())
    print(f'{os.path.join(outdir, "results.parquet")}: {len(table)} runs, {not_finished} did '
          f'not finish, {time.monotonic() - started:.3g} s')
    if args.design is None:
        print(found['estimate'].sentence())
        if found['estimate'].decision_sentence:
            print(found['estimate'].decision_sentence)
        print(os.path.join(outdir, methods.ESTIMATE))
    else:
        _print_indices(found['indices'], args.design)
        print(os.path.join(outdir, methods.SENSITIVITY))
    return EXIT_OK


def _checked_spec(args):
    """Return the sweep file's spec, checked for the method or design before any run."""
    study = study_imports()
    spec = study.load_sweep(args.sweep, runs=args.runs)
    from cfem_ros.study import methods
    if args.design is None:
        from cfem_ros.study.reliability import distribution
        if not spec.criteria:
            raise InputError(f'{args.sweep}: criteria: missing; --method {args.method} '
                             'estimates P(a criterion fails): expected criteria as in SPEC '
                             'section 9')
        distribution(spec)   # refuses what it cannot map, before any run
    else:
        from cfem_ros.study.sensitivity import problem
        problem(spec, args.design)
    methods.check_size(spec, args.design or args.method)   # before the cluster starts
    return spec


def _on_cluster(args, spec, outdir: str) -> tuple:
    """Run the study on Dask; return (exit status if it stopped or failed, else None, found)."""
    from cfem_ros.study import methods
    name = args.design or args.method
    client = cluster = None
    with signals_to(raise_interrupted):
        try:
            try:
                client, cluster = dask_client(args.workers, args.scheduler)
            except OSError as err:
                return error(f'{args.scheduler or "local cluster"}: {err}'), None
            found = methods.run_study(spec, outdir, method=args.method, design=args.design,
                                      client=client, target_cov=args.cov, record=args.record,
                                      repeat=getattr(args, 'repeat', 5),
                                      log=lambda line: print(f'{name}: {line}',
                                                             file=sys.stderr, flush=True))
        except Interrupted as stop:
            for s in STOPS:
                signal.signal(s, exit_now)
            close(client, cluster)
            client = cluster = None
            print(f'\ninterrupted by {stop}: the runs done are saved in {outdir}; run the '
                  'same command again to resume', file=sys.stderr)
            return stop.exit_status, None
        except (ResourceFailure, MethodFailed) as err:   # while working: the runs are saved
            return failed(str(err)), None
        except CfemError as err:
            return error(str(err)), None
        except OSError as err:   # writing the study's files: what is written is kept
            return failed(f'{err.filename2 or err.filename or outdir}: cannot write '
                          f'({err.strerror or err}); the runs done are '
                          'saved: run the same command again to resume'), None
        finally:
            close(client, cluster)
    return None, found


def _print_indices(indices, design: str):
    """Print each metric's parameters, most influential first."""
    key = 'mu_star' if design == 'morris' else 'ST'
    for metric, rows in indices.groupby('metric', sort=False):
        print(f'{metric}:')
        for _, row in rows.sort_values(key, ascending=False).iterrows():
            if design == 'morris':
                print(f'  {row["parameter"]}: mu* {row["mu_star"]:.4g} '
                      f'[{row["mu_star_low"]:.4g}, {row["mu_star_high"]:.4g}], '
                      f'sigma {row["sigma"]:.4g}')
            else:
                print(f'  {row["parameter"]}: S1 {row["S1"]:.3f} [{row["S1_low"]:.3f}, '
                      f'{row["S1_high"]:.3f}], ST {row["ST"]:.3f} [{row["ST_low"]:.3f}, '
                      f'{row["ST_high"]:.3f}]')
