# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""``cfem-sim envelope``: a grid of flight conditions, each with its dispersions (SPEC 14)."""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import time

from cfem_ros.cli.cluster import close, dask_client, raise_interrupted, study_imports
from cfem_ros.cli.common import error, EXIT_FAILED, EXIT_OK, failed, signals_to, STOPS
from cfem_ros.core.errors import CfemError
from cfem_ros.interrupts import exit_now, Interrupted
from cfem_ros.study.resources import MethodFailed, ResourceFailure


def add_parser(sub):
    """Add ``cfem-sim envelope`` to the command line's subparsers."""
    env = sub.add_parser(
        'envelope', help='the release envelope: a grid of conditions, each with its '
        'dispersions and decision',
        description='Run the sweep of a sweep file at each point of the grid of two or three '
        "of its vary grids (--x, --y, --z), each with the file's other variables drawn, and "
        'judge each point by its criteria (and target): OUTDIR/envelope.parquet, the chart '
        'OUTDIR/envelope.png, each point in OUTDIR/points/point_<k> (SPEC section 14). Run '
        'again with the same OUTDIR to resume.')
    env.add_argument('sweep', metavar='SWEEP.yaml', help='sweep file (grids and dispersions)')
    env.add_argument('-o', '--output', required=True, metavar='OUTDIR',
                     help='envelope folder (envelope.parquet, envelope.png, points/)')
    env.add_argument('--x', required=True, metavar='KEY', help='key path across the chart, '
                     'a grid of vary (flight.mach)')
    env.add_argument('--y', required=True, metavar='KEY', help='key path up the chart, a '
                     'grid of vary (flight.altitude)')
    env.add_argument('--z', metavar='KEY', help='key path of a third grid: one panel per '
                     'value (flight.load_factor)')
    where = env.add_mutually_exclusive_group()
    where.add_argument('--workers', type=int, metavar='N',
                       help='local worker processes (default: the CPU count)')
    where.add_argument('--scheduler', metavar='ADDRESS',
                       help='use a running Dask scheduler, e.g. tcp://10.0.0.5:8786')
    env.add_argument('--runs', type=int, metavar='K', help="overrides the file's runs at each "
                     'point: random draws (mc), points per level, step or batch (subset, '
                     'nais, form)')
    env.add_argument('--method', choices=('mc', 'subset', 'nais', 'form'), default='mc',
                     help='mc: the runs of the file at each point (default); subset, nais, '
                     "form: estimate each point's P(a criterion fails) with OpenTURNS")
    env.add_argument('--cov', type=float, default=0.1, metavar='COV',
                     help='--method form: sample until this coefficient of variation (0.1)')
    env.add_argument('--repeat', type=int, default=5, metavar='K',
                     help='--method subset and form: independent repetitions or least '
                     'batches, whose spread gives the bound (default 5)')
    env.set_defaults(func=envelope_command)


def _refused(args):
    """Return why the arguments cannot be run (None if they can)."""
    if args.workers is not None and args.workers < 1:
        return f'--workers: is {args.workers}; expected a number of workers >= 1'
    if args.repeat < 2:
        return (f'--repeat: is {args.repeat}; expected at least 2 independent repetitions '
                '(their spread is the bound; 5 by default)')
    if not (math.isfinite(args.cov) and 0 < args.cov < 1):
        return (f'--cov: is {args.cov!r}; expected a coefficient of variation between 0 and '
                '1 (0.1)')
    if os.path.exists(args.output) and not os.path.isdir(args.output):
        return (f'-o {args.output}: is not a folder; expected the envelope folder (new, or '
                'one to resume)')
    return None


def _checked(args):
    """Return the envelope, checked (axes, points, the method's size) before any run."""
    study_imports()
    from cfem_ros.study import envelope
    axes = [a for a in (args.x, args.y, args.z) if a is not None]
    found = envelope.load_envelope(args.sweep, axes, runs=args.runs)
    if args.method != 'mc':
        from cfem_ros.study import methods
        from cfem_ros.study.reliability import distribution
        spec = found.point_spec(0)
        distribution(spec)   # refuses what it cannot map, before any run
        methods.check_size(spec, args.method)
    envelope.write_manifest(found, os.path.abspath(args.output), args.method)
    return found


def envelope_command(args: argparse.Namespace) -> int:
    """Run an envelope into -o (resuming it) and draw its chart; exit 0, 1 or 2."""
    refused = _refused(args)
    if refused:
        return error(refused)
    try:
        found = _checked(args)
    except CfemError as err:
        return error(str(err))
    except ImportError as err:
        return error(f'--method {args.method} needs {err.name}, which is not installed; '
                     "install the study extra: pip install -e '.[study]'")
    from cfem_ros.study.envelope import point_done
    outdir = os.path.abspath(args.output)
    count = len(found.points)
    done = sum(point_done(outdir, k) for k in range(count))
    per = found.point_spec(0).total if args.method == 'mc' else f'{found.spec.runs} a step of'
    print(f'{args.sweep}: {count} conditions ({" x ".join(found.axes)}), {per} runs each '
          f'({args.method}), {done} already in {outdir}', file=sys.stderr)
    started = time.monotonic()
    status, table = _on_cluster(args, found, outdir, everything_done=done == count)
    if status is not None:
        return status
    return _finish(table, found, outdir, time.monotonic() - started)


def _on_cluster(args, found, outdir: str, everything_done: bool = False) -> tuple:
    """Run every point on Dask; return (exit status if stopped or failed, else None, table)."""
    from cfem_ros.study.envelope import run_envelope
    client = cluster = None
    overall = _overall(found, outdir, args.method)

    def say(line):   # over a progress line drawn in place on a terminal, if there is one
        clear = '\r\x1b[K' if overall is not None and overall.in_place else ''
        print(clear + line, file=sys.stderr, flush=True)
    options = {} if args.method == 'mc' else {'repeat': args.repeat, 'target_cov': args.cov}
    with signals_to(raise_interrupted):
        try:
            try:   # no cluster to gather what is done (the points' tables are reread)
                if not everything_done:
                    client, cluster = dask_client(args.workers, args.scheduler)
            except OSError as err:
                return error(f'{args.scheduler or "local cluster"}: {err}'), None
            table = run_envelope(found, outdir, method=args.method, client=client, log=say,
                                 progress=None if overall is None else (lambda k: overall.update),
                                 **options)
        except Interrupted as stop:
            for s in STOPS:   # a second one ends at once
                signal.signal(s, exit_now)
            close(client, cluster, hold=False)
            client = cluster = None
            print(f'\ninterrupted by {stop}: the points and runs done are saved in {outdir}; '
                  'run the same command again to resume', file=sys.stderr)
            return stop.exit_status, None
        except (ResourceFailure, MethodFailed) as err:
            return failed(str(err)), None
        except CfemError as err:
            return error(str(err)), None
        except OSError as err:   # writing the folder's files: what is written is kept
            return failed(f'{err.filename2 or err.filename or outdir}: cannot write '
                          f'({err.strerror or err}); the points done are saved: run the same '
                          'command again to resume'), None
        finally:
            close(client, cluster)
    return None, table


def _overall(found, outdir: str, method: str):
    """Return the progress line over every condition's Monte Carlo runs (None for others)."""
    if method != 'mc':   # a rare-event method's runs are not known beforehand: its log says
        return None
    from cfem_ros.study.envelope import point_folder
    from cfem_ros.study.sweep import Progress, saved_runs
    done = sum(saved_runs(point_folder(outdir, k)) for k in range(len(found.points)))
    return Progress(found.point_spec(0).total * len(found.points), done, what='envelope')


def _finish(table, found, outdir: str, wall: float) -> int:
    """Draw the chart, print the count of each decision and the files; exit 0 or 1."""
    from cfem_ros.separation.envelope_chart import write_chart
    from cfem_ros.study.envelope import ENVELOPE
    chart = write_chart(outdir)
    counts = table['decision'].value_counts().to_dict()
    said = ', '.join(f'{n} {d.replace("_", " ")}' for d, n in counts.items())
    unfinished = int(table['unfinished_runs'].sum())
    print(f'{os.path.join(outdir, ENVELOPE)}: {len(table)} conditions: {said}; '
          f'{wall:.3g} s')
    if unfinished:
        print(f'{unfinished} runs failed (a singular or diverging system), each counted as '
              "failing every criterion; see each point's results.parquet", file=sys.stderr)
    unanswered = table[table['note'] != '']
    for _, row in unanswered.iterrows():   # the method found nothing there: no number shown
        print(f'ERROR: point {int(row["point"]) + 1} ({row["folder"]}): {row["note"]}',
              file=sys.stderr)
    print(chart)
    return EXIT_FAILED if unfinished or len(unanswered) else EXIT_OK
