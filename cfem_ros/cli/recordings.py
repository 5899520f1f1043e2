# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The commands that read recordings: ``info``, ``recover``, ``plot``, ``export``, ``compare``."""

from __future__ import annotations

import argparse
import os
import sys

from cfem_ros.cli.cluster import study_imports
from cfem_ros.cli.common import error, EXIT_FAILED, EXIT_OK, output_refused, same_file
from cfem_ros.cli.figures import write_figures
from cfem_ros.core.engine.events import describe_event, Event
from cfem_ros.core.errors import CfemError
from cfem_ros.recording.errors import OutputError
from cfem_ros.separation import commands as separation


def add_plot_parser(sub):
    """Add ``cfem-sim plot`` to the command line's subparsers."""
    plot = sub.add_parser('plot', help='draw the figures of a recording',
                          description='Write PNG figures of a recording: per body CG, '
                          'attitude and rates; per joint force and moment; a 3D view.')
    plot.add_argument('recording', metavar='RUN.mcap|OUTDIR',
                      help='recording to read, or a sweep folder')
    plot.add_argument('-o', '--output', required=True, metavar='DIR',
                      help='folder to write the PNG files to')
    plot.add_argument('--overwrite', action='store_true',
                      help='replace figures of the same names in DIR')
    plot.add_argument('--metric', metavar='COLUMN',
                      help='sweep folder: metric to scatter against the varied parameters '
                      '(default the first clearance minimum)')
    separation.add_plot_options(plot)
    plot.set_defaults(func=plot_command)


def add_export_parser(sub):
    """Add ``cfem-sim export`` (SPEC section 12) to the command line's subparsers."""
    separation.add_export_parser(sub).set_defaults(func=export_command)


def add_info_parser(sub):
    """Add ``cfem-sim info`` to the command line's subparsers."""
    info = sub.add_parser('info', help='summarize a recording',
                          description='Print topics, message counts, time range, chunks, '
                          "metadata and events, from the file's summary.")
    info.add_argument('recording', metavar='RUN.mcap', help='recording to read')
    info.set_defaults(func=info_command)


def add_recover_parser(sub):
    """Add ``cfem-sim recover`` to the command line's subparsers."""
    rec = sub.add_parser('recover', help='salvage a cut recording',
                         description='Copy every complete message of a recording cut by a '
                         'hard kill (no footer) into a new, indexed file.')
    rec.add_argument('broken', metavar='BROKEN.mcap', help='cut recording to read')
    rec.add_argument('-o', '--output', required=True, metavar='FIXED.mcap',
                     help='new recording to write (must not exist)')
    rec.set_defaults(func=recover_command)


def add_compare_parser(sub):
    """Add ``cfem-sim compare`` to the command line's subparsers."""
    compare = sub.add_parser('compare', help='compare two recordings',
                             description='Print the largest difference of each quantity '
                             'between two recordings of the same topics (B resampled onto '
                             "A's times), and optionally overlay them.")
    compare.add_argument('first', metavar='A.mcap', help='reference recording')
    compare.add_argument('second', metavar='B.mcap', help='recording to compare with A')
    compare.add_argument('-o', '--output', metavar='DIR', help='write overlay figures here')
    compare.add_argument('--overwrite', action='store_true',
                         help='replace figures of the same names in DIR')
    compare.add_argument('--map', action='append', default=[], metavar='A_TOPIC=B_TOPIC',
                         help="read B's topic B_TOPIC as A's A_TOPIC (repeatable); a pose "
                         "whose frame_id is a body of A is that body's pose relative to it")
    compare.add_argument('--relative-to', metavar='BODY',
                         help="compare every other body's position and attitude in BODY's "
                         'axes (a carrier), each run as its poses give them')
    compare.set_defaults(func=compare_command)


def info_command(args: argparse.Namespace) -> int:
    """Print a recording's topics, message counts, time range, chunks and events; exit 0 or 2."""
    from cfem_ros.recording.summary import read_summary
    recording = args.recording
    try:
        summary = read_summary(recording)
    except CfemError as err:
        return error(str(err))
    ours = summary.metadata.get('cfem_ros', {})
    start_ns = int(ours.get('start_stamp_ns', summary.start_ns))
    span = (summary.end_ns - summary.start_ns) / 1e9 if summary.message_count else 0.0
    print(f'{recording}: {summary.message_count} messages in {summary.chunk_count} chunks, '
          f'log times {summary.start_ns} to {summary.end_ns} ns ({span:.6g} s; '
          f't = 0 at stamp {start_ns} ns)')
    for name, values in sorted(summary.metadata.items()):
        print(f'  metadata {name}: ' + ', '.join(f'{k} {v}' for k, v in sorted(values.items())))
    width = max([len(topic) for topic in summary.topics] + [5])
    print(f'  {"topic":<{width}}  {"messages":>8}  type')
    for topic, (kind, count) in sorted(summary.topics.items()):
        print(f'  {topic:<{width}}  {count:>8}  {kind}')
    _print_names(summary.topics)
    _print_events(summary.events)
    return EXIT_OK


def _print_names(topics):
    """Print the bodies and joints a recording's topics are about."""
    from cfem_ros.recording import schema
    bodies = sorted({m['body'] for t in topics for m in [schema.POSE.pattern.match(t)] if m})
    joints = sorted({m['joint'] for t in topics for m in [schema.JOINT_WRENCH.pattern.match(t)]
                     if m})
    print(f'  bodies: {", ".join(bodies) or "none"}; joints: {", ".join(joints) or "none"}')


def _print_events(events):
    """Print a recording's releases, end-of-stroke figures, brace contacts and contacts."""
    # a recording's events are read as found: a key a reader needs is checked first
    releases = sorted(({'joint': '?', 'cause': '?', **e} for e in events
                       if e.get('event') == Event.RELEASE and 'time' in e),
                      key=lambda e: (e['time'], e['joint'], e['cause']))
    for event in releases:
        print(f'  {describe_event(event)}')
    if not releases:
        print('  no release event')
    for event in events:   # end-of-stroke figures (SPEC section 7), braces (11)
        if event.get('event') == Event.STROKE_END and 'velocity' in event and 'rates' in event:
            print(f'  {describe_event(event)}')
        if (event.get('event') == Event.BRACE_CONTACT and 'time' in event and 'brace' in event
                and 'contact' in event):
            print(f'  {describe_event(event)}')
    for event in events:
        if (event.get('event') == Event.CONTACT and 'time' in event
                and len(event.get('bodies', ())) == 2 and len(event.get('point', ())) == 3):
            print(f'  {describe_event(event)}')


def recover_command(args: argparse.Namespace) -> int:
    """Copy the verifiably intact messages of a cut or damaged recording; exit 0, 1 or 2."""
    broken, fixed = args.broken, args.output
    if same_file(broken, fixed):
        return error(f'-o {fixed}: is the broken file itself; choose another output')
    refused = output_refused(fixed, overwrite=False)
    if refused:
        return error(refused)
    try:
        from cfem_ros.recording.recover import recover
        report = recover(broken, fixed)
    except OutputError as err:
        print(f'ERROR: {err}', file=sys.stderr)
        return EXIT_FAILED
    except CfemError as err:
        return error(str(err))
    if report.complete:
        where = 'the file was complete (data end found)'
    else:
        where = (f'the file was cut at byte {report.cut_at} of {report.size} '
                 f'({report.note})')
    unverified = (f', {report.unverified} of them from the cut last chunk (no CRC to check; '
                  'they decode)' if report.unverified else '')
    print(f'{fixed}: {report.messages} messages recovered from {report.chunks} complete '
          f'chunks{unverified}, up to log time {report.end_ns} ns; {where}')
    if report.skipped or report.bad_chunks or report.damage:
        print(f'  skipped: {report.skipped} message(s), {report.bad_chunks} damaged chunk(s)')
        for place in report.damage:
            print(f'  damage at {place}')
    return EXIT_OK


def plot_command(args: argparse.Namespace) -> int:
    """Write the figures of a recording (or a sweep folder) under -o; exit 0 or 2."""
    if os.path.isdir(args.recording):
        return _plot_sweep(args)
    from cfem_ros.recording import analysis   # the reader only for the commands that read
    directory, relative_to = args.output, args.relative_to
    try:
        run = analysis.open_run(args.recording)
        if relative_to is not None:   # before anything is drawn
            separation.check_relative(run, relative_to, args.snapshots)
    except CfemError as err:
        return error(str(err))

    def draw(folder):
        from cfem_ros import plots   # matplotlib only for the commands that draw
        paths = plots.write_figures(run, folder)
        if relative_to is not None:
            paths += separation.plot_relative(run, relative_to, folder, args.snapshots)
        return paths
    try:
        paths = write_figures(directory, args.overwrite, draw)
    except CfemError as err:
        return error(str(err))
    except OSError as err:
        return error(f'{directory}: cannot write ({err.strerror or err})')
    for path in paths:
        print(path)
    return EXIT_OK


def _plot_sweep(args) -> int:
    """Write a sweep folder's figures (its envelope: --relative-to), or an envelope's chart."""
    outdir, directory = args.recording, args.output
    envelope = os.path.exists(os.path.join(outdir, 'envelope.json'))   # SPEC section 14
    if not envelope and not os.path.exists(os.path.join(outdir, 'results.parquet')):
        return error(f'{outdir}: no results.parquet; expected a finished sweep folder '
                     '(cfem-sim sweep ... -o OUTDIR), an envelope folder (cfem-sim envelope) '
                     'or a recording')

    def draw(folder):
        study_imports()
        if envelope:   # its chart (each condition's folder is a sweep folder to plot)
            from cfem_ros.separation.envelope_chart import write_chart
            return [write_chart(outdir, folder)]
        from cfem_ros import study_plots
        paths = study_plots.write_sweep_figures(outdir, folder, args.metric)
        if args.relative_to is not None:
            paths += separation.plot_sweep_relative(outdir, args.relative_to, folder)
        return paths
    try:
        paths = write_figures(directory, args.overwrite, draw)
    except (CfemError, ValueError) as err:
        return error(str(err))
    except OSError as err:
        return error(f'{directory}: cannot write ({err.strerror or err})')
    print('\n'.join(paths))
    return EXIT_OK


def export_command(args: argparse.Namespace) -> int:
    """Write a recording's time histories as a table (SPEC section 12); exit 0 or 2."""
    try:
        print(separation.export(args.recording, args.output, args.relative_to, args.rate,
                                args.overwrite, args.point))
    except CfemError as err:
        return error(str(err))
    return EXIT_OK


def compare_command(args: argparse.Namespace) -> int:
    """Print the largest differences of two recordings (and overlay figures); exit 0 or 2."""
    from cfem_ros.recording import analysis   # the reader only for the commands that read
    first, second = args.first, args.second
    topic_map = {}
    for item in args.map or ():
        ours, sep, theirs = item.partition('=')
        if not sep or not ours.startswith('/') or not theirs.startswith('/'):
            return error(f'--map {item!r}; expected A_TOPIC=B_TOPIC, absolute topic names '
                         '(e.g. /cfem/bodies/store/pose=/flight/store/pose)')
        topic_map[theirs] = ours
    reference = getattr(args, 'relative_to', None)
    try:
        a = analysis.open_run(first)
        # a pose of B whose frame_id names a body of A is relative to that body (SPEC 15)
        b = analysis.open_run(second, topic_map=topic_map, frames=set(a.bodies))
    except CfemError as err:
        return error(str(err))
    if reference is not None and reference not in a.bodies:
        return error(f'--relative-to {reference}: not a body of {first}; expected one of '
                     + ', '.join(sorted(a.bodies)[:8]))
    rows, only_a, only_b = analysis.compare_runs(a, b, relative_to=reference)
    if not rows:
        return error(f'{first} and {second} share no body or joint; nothing to compare')
    _print_comparison(args, _compared_span(a, b), rows, only_a, only_b)
    if args.output:
        def draw(folder):
            from cfem_ros import plots
            if reference is not None:
                return (plots.write_comparison(a, b, folder)
                        + plots.write_relative_comparison(a, b, reference, folder))
            return plots.write_comparison(a, b, folder)
        try:
            paths = write_figures(args.output, args.overwrite, draw)
        except CfemError as err:
            return error(str(err))
        except OSError as err:
            return error(f'{args.output}: cannot write ({err.strerror or err})')
        for path in paths:
            print(path)
    return EXIT_OK


def _compared_span(a, b):
    """Return (first, last) of the times both runs' shared bodies cover, or None."""
    spans = [(max(ta.time[0], tb.time[0]), min(ta.time[-1], tb.time[-1]))
             for name, ta in a.bodies.items()
             for tb in [b.bodies.get(name)] if tb is not None and len(ta.time) and len(tb.time)]
    spans = [(float(lo), float(hi)) for lo, hi in spans if lo <= hi]
    if not spans:
        return None
    return min(lo for lo, _ in spans), max(hi for _, hi in spans)


def _print_comparison(args, span, rows, only_a, only_b):
    """Print the table of ``analysis.compare_runs`` and what only one run holds."""
    print(f'A = {args.first}')
    print(f"B = {args.second} (interpolated onto A's sample times)")
    if span:
        print(f"compared: t = {span[0]:.6g} to {span[1]:.6g} s (A's samples inside B's "
              'span); every column is over these times only')
    print('vectors: the largest component (position: world axes; rates p, q, r and '
          'velocity u, v, w: body axes)')
    print("attitude: the angle from A's attitude to B's; its max |A|: A's turn from its start")
    width = max(len(r.quantity) for r in rows)
    print(f'{"quantity":<{width}}  {"max |A - B|":>12}  {"unit":<5}  {"at t [s]":>10}  '
          f'{"max |A|":>12}  {"samples":>7}')
    for r in rows:
        print(f'{r.quantity:<{width}}  {r.max_abs:>12.4g}  {r.unit:<5}  {r.at_time:>10.4f}  '
              f'{r.scale:>12.4g}  {r.samples:>7d}')
    for name in only_a:
        print(f'only in A: {name}')
    for name in only_b:
        print(f'only in B: {name}')
