# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The commands over a sweep's outputs: ``report``, ``rerun`` and ``summarize``."""

from __future__ import annotations

import argparse
import os
import sys

from cfem_ros.cli.cluster import close, dask_client, study_imports
from cfem_ros.cli.common import (error, EXIT_FAILED, EXIT_OK, failed, output_refused,
                                 table_refused, warn)
from cfem_ros.core.engine.events import Status
from cfem_ros.core.errors import CfemError, InputError


def add_report_parser(sub):
    """Add ``cfem-sim report`` to the command line's subparsers."""
    report = sub.add_parser('report', help='one self-contained HTML page of a study folder',
                            description='Write the scenario, sweep, criteria with their '
                            'probabilities, worst runs, sensitivities and figures of a '
                            'sweep folder as one HTML file (SPEC section 9); of an envelope '
                            'folder, its conditions, decisions and chart (section 14).')
    report.add_argument('outdir', metavar='OUTDIR', help='sweep or envelope folder')
    report.add_argument('-o', '--output', required=True, metavar='REPORT.html',
                        help='page to write')
    report.add_argument('--overwrite', action='store_true',
                        help='replace REPORT.html if it exists (never a device or folder)')
    report.set_defaults(func=report_command)


def add_rerun_parser(sub):
    """Add ``cfem-sim rerun`` to the command line's subparsers."""
    rerun = sub.add_parser('rerun', help='run one run of a sweep folder again and record it',
                           description='Run run RUN of a sweep folder alone, with its values, '
                           'and record it to MCAP.')
    rerun.add_argument('outdir', metavar='OUTDIR', help='sweep folder')
    rerun.add_argument('run', type=int, metavar='RUN', help='run number (column run)')
    rerun.add_argument('-o', '--output', required=True, metavar='RUN.mcap',
                       help='recording to write')
    rerun.set_defaults(func=rerun_command)


def add_summarize_parser(sub):
    """Add ``cfem-sim summarize`` to the command line's subparsers."""
    summ = sub.add_parser('summarize', help="a sweep file's metrics over recordings",
                          description='Compute the metrics of a sweep file over recordings, '
                          'one row per file, in parallel on Dask.')
    summ.add_argument('recordings', nargs='+', metavar='RUN.mcap', help='recordings to read')
    summ.add_argument('--metrics', required=True, metavar='SWEEP.yaml',
                      help='sweep file whose metrics to compute')
    summ.add_argument('-o', '--output', required=True, metavar='TABLE.parquet',
                      help='table to write')
    where = summ.add_mutually_exclusive_group()
    where.add_argument('--workers', type=int, metavar='N', help='local worker processes')
    where.add_argument('--scheduler', metavar='ADDRESS', help='use a running Dask scheduler')
    summ.add_argument('--csv', action='store_true', help='also write TABLE.csv')
    summ.add_argument('--overwrite', action='store_true',
                      help='replace an existing table (else refused)')
    summ.set_defaults(func=summarize_command)


def summarize_command(args: argparse.Namespace) -> int:
    """Compute a sweep file's metrics over recordings into a table; exit 0, 1 or 2."""
    output = args.output
    csv = os.path.splitext(output)[0] + '.csv'
    for table in [output] + ([csv] if args.csv else []):
        refused = table_refused(table, args.overwrite, 'a table')
        if refused:
            return error(refused)
    try:
        study = study_imports()
        spec = study.load_sweep(args.metrics, runs=1)
    except CfemError as err:
        return error(str(err))
    client = cluster = None
    try:
        if len(args.recordings) > 1 or args.scheduler:
            client, cluster = dask_client(args.workers, args.scheduler)
        table = study.summarize(args.recordings, spec.metrics, client)
    finally:
        close(client, cluster)
    from cfem_ros.study.summarize import UNITS
    from cfem_ros.study.sweep import write_atomic
    try:   # each column's unit: Parquet field metadata, or the CSV's header
        write_atomic(table, output, spec.document, UNITS)
        if args.csv:
            write_atomic(table, csv, spec.document, UNITS)
    except OSError as err:
        return error(f'{output}: cannot write ({err.strerror or err})')
    unread = table[table['status'] == Status.FAILED]
    for _, row in unread.iterrows():
        print(f'  {row["message"]}', file=sys.stderr)
    print(f'{output}: {len(table)} recordings, {len(unread)} unreadable')
    return EXIT_FAILED if len(unread) else EXIT_OK


def report_command(args: argparse.Namespace) -> int:
    """Write a study folder's self-contained HTML report; exit 0 or 2."""
    outdir, output = args.outdir, args.output
    refused = table_refused(output, args.overwrite, 'a report')
    if refused:
        return error(refused)
    envelope = os.path.exists(os.path.join(outdir, 'envelope.json'))
    if not envelope and not os.path.exists(os.path.join(outdir, 'results.parquet')):
        return error(f'{outdir}: no results.parquet; expected a finished sweep folder '
                     '(cfem-sim sweep ... -o OUTDIR) or envelope folder (cfem-sim envelope)')
    try:
        study_imports()
        if envelope:
            _write_envelope_report(outdir, output)
        else:
            from cfem_ros.study.folder import check_folder
            check_folder(outdir)
            _write_report(outdir, output)
    except CfemError as err:
        return error(str(err))
    except OSError as err:
        return error(f'{output}: cannot write ({err.strerror or err})')
    print(output)
    return EXIT_OK


def _write_report(outdir: str, output: str):
    """Draw a sweep folder's figures in a temporary folder and write the page with them."""
    import tempfile
    from cfem_ros import study_plots
    from cfem_ros.study.report import write_report
    with tempfile.TemporaryDirectory(prefix='cfem-report-') as tmp:
        figures = study_plots.write_sweep_figures(outdir, tmp, None)
        from cfem_ros.separation.envelopes import report_figures   # SPEC section 12
        figures = report_figures(outdir, tmp, warn) + figures
        first = [p for p in figures if not os.path.basename(p).startswith('hist_')]
        write_report(outdir, output, first + [p for p in figures if p not in first])


def _write_envelope_report(outdir: str, output: str):
    """Draw an envelope folder's chart in a temporary folder and write the page with it."""
    import tempfile
    from cfem_ros.separation.envelope_chart import write_chart
    from cfem_ros.study.report import write_report
    with tempfile.TemporaryDirectory(prefix='cfem-report-') as tmp:
        write_report(outdir, output, [write_chart(outdir, tmp)])


def rerun_command(args: argparse.Namespace) -> int:
    """Run one run of a sweep folder again, alone, and record it; exit 0, 1 or 2."""
    outdir, run, output = args.outdir, args.run, args.output
    try:
        spec = _rerun_spec(outdir, run)
    except CfemError as err:
        return error(str(err))
    refused = output_refused(output, overwrite=False)
    if refused:
        return error(refused)
    from cfem_ros.study.runs import run_one
    try:
        row = run_one(spec, run, record=output)
    except (CfemError, OSError) as err:   # the recording could not be written
        return failed(f'{output}: run {run} of {outdir} could not be recorded: '
                      f'{getattr(err, "strerror", None) or err}')
    print(f'{output}: run {run} of {outdir}, status {row["status"]}'
          + (f' ({row["message"]})' if row['message'] else ''))
    return EXIT_OK if row['status'] == Status.OK else EXIT_FAILED


def _rerun_spec(outdir: str, run: int):
    """Return the spec of a sweep folder with run's values; CfemError if it cannot be had."""
    import dataclasses
    import json
    study_imports()
    from cfem_ros.study.folder import check_folder, read_table
    manifest = check_folder(outdir)
    table = read_table(os.path.join(outdir, 'results.parquet'))
    if 'run' not in table.columns or not isinstance(manifest.get('resolved'), dict):
        raise InputError(f'{outdir}: its results.parquet or sweep.json is not what a sweep '
                         'writes; expected a sweep folder (sweep.json, results.parquet)')
    rows = table[table['run'] == run]
    if rows.empty:
        raise InputError(f'{outdir}: no run {run}; expected 0 to {len(table) - 1}')
    from cfem_ros.study.envelope import folder_spec   # a sweep's folder, or an envelope's point
    spec = folder_spec(outdir, manifest)
    if json.loads(spec.describe()) != manifest['resolved']:
        raise InputError(f'{manifest["sweep"]}: changed since {outdir} was run; expected the '
                         'sweep file and scenario the folder was made with')
    if manifest.get('method', 'mc') != 'mc':   # the method chose the values: the table's
        spec = dataclasses.replace(spec, values={
            v.path: {run: float(rows.iloc[0][v.path])} for v in spec.variables})
    return spec
