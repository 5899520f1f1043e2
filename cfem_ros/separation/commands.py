# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The separation outputs of the command line (SPEC section 12).

``cfem-sim export`` (a run's time histories as CSV or Parquet) and the
``--relative-to``/``--snapshots`` figures of ``cfem-sim plot``, for a run
and for a sweep folder. Each function raises ``CfemError`` for a user's
mistake (the command line prints it as one ``ERROR:`` line, exit 2) and
returns the paths it wrote.
"""

from __future__ import annotations

import math
import os
import sys

from cfem_ros.core.errors import CfemError
from cfem_ros.recording.errors import RecordingError


def add_export_parser(sub):
    """Add ``cfem-sim export`` to the command line's subparsers; return its parser."""
    export = sub.add_parser('export', help="a run's time histories as a CSV or Parquet table",
                            description='Write one row per sample of a recording: time, each '
                            "body's position, attitude, velocity and rates, each joint's "
                            "load, each aero body's alpha, beta, Mach and dynamic pressure "
                            '(SPEC section 12). Composed from the recorded poses.')
    export.add_argument('recording', metavar='RUN.mcap', help='recording to read')
    export.add_argument('-o', '--output', required=True, metavar='FILE.csv|FILE.parquet',
                        help='table to write (the format by its extension)')
    export.add_argument('--relative-to', metavar='BODY',
                        help="positions and attitudes in this body's axes, from its CG, and "
                        'time_from_release')
    export.add_argument('--point', metavar='carriage|[x,y,z]',
                        help='with --relative-to: positions from this point of the carrier '
                        "instead of its CG: carriage (the mean of the released joints' "
                        "anchors) or [x,y,z] (m, the carrier's axes, from its CG)")
    export.add_argument('--rate', type=float, metavar='HZ',
                        help='keep the samples at multiples of 1/HZ s (HZ divides the '
                        "recording's rate)")
    export.add_argument('--overwrite', action='store_true', help='replace an existing table')
    return export


def add_plot_options(plot):
    """Add ``--relative-to`` and ``--snapshots`` to ``cfem-sim plot``."""
    plot.add_argument('--relative-to', metavar='BODY',
                      help='also the separation trajectory sheet and outline snapshots in '
                      "this body's axes (a sweep folder: the envelope over its recorded runs)")
    plot.add_argument('--snapshots', default='0.1,0.2,0.3', metavar='S,S,...',
                      help='with --relative-to: snapshot times, s after the release '
                      '(default 0.1,0.2,0.3)')


def export(recording: str, output: str, relative_to=None, rate=None,
           overwrite: bool = False, point=None) -> str:
    """Write a recording's table (``recording.export``); return the path."""
    from cfem_ros.recording.analysis import open_run
    from cfem_ros.recording.export import export_table, write_table
    from cfem_ros.recording.outputs import output_problem
    refused = output_problem(output, exists_ok=True, what='a table')
    if refused:
        raise RecordingError(refused)
    if not overwrite and os.path.lexists(output):
        raise RecordingError(f'{output}: already exists; pass --overwrite to replace it')
    if os.path.splitext(output)[1].lower() not in ('.csv', '.parquet'):
        raise RecordingError(f'-o {output}: expected FILE.csv or FILE.parquet (the format is '
                             'told by the extension)')
    run = open_run(recording)
    warnings = []   # said once the table is written: a refusal says its ERROR line alone
    table = export_table(run, relative_to, rate, warn=warnings.append, point=point)
    try:
        path = write_table(table, output)
    except OSError as err:
        raise RecordingError(f'{output}: cannot write ({err.strerror or err})') from err
    for line in warnings:
        print(f'WARNING: {line}', file=sys.stderr)
    return path


def snapshot_times(text: str) -> tuple:
    """Return the ``--snapshots`` times (s after the release), or raise CfemError."""
    try:
        times = tuple(float(part) for part in str(text).split(',') if part.strip())
    except ValueError:
        times = None
    if not times or not all(math.isfinite(t) and t >= 0 for t in times):
        raise CfemError(f'--snapshots {text}: expected times >= 0 s after the release, '
                        'separated by commas (0.1,0.2,0.3)')
    return times


def check_relative(run, reference: str, snapshots: str) -> tuple:
    """Return the snapshot times, or raise CfemError if reference or the times are wrong."""
    after = snapshot_times(snapshots)
    if reference not in run.bodies:
        raise RecordingError(f'{run.path}: --relative-to {reference}: no such body in the '
                             f'recording; expected one of {", ".join(run.bodies)}')
    return after


def plot_relative(run, reference: str, directory: str, snapshots: str) -> list:
    """Write a run's separation sheet and snapshots in reference's axes; return the paths."""
    after = check_relative(run, reference, snapshots)
    from cfem_ros.separation.figures import write_relative_figures
    return write_relative_figures(run, reference, directory, after)


def plot_sweep_relative(outdir: str, reference: str, directory: str) -> list:
    """Write a sweep folder's envelope in reference's axes; return the paths."""
    from cfem_ros.separation.envelopes import write_envelope
    return write_envelope(outdir, reference, directory)
