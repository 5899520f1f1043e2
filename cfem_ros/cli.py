# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The ``cfem-sim`` command line (SPEC section 2): typed commands, exit codes."""

from __future__ import annotations

import argparse
import logging
import math
import os
import signal
import sys
import time
from typing import Optional

from cfem_ros.core import rotations
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.engine.strokes import describe_event
from cfem_ros.core.errors import CfemError, InputError
from cfem_ros.core.scenario.aeroparse import describe as describe_aero
from cfem_ros.core.scenario.parse import load_scenario
from cfem_ros.interrupts import exit_now, Interrupted, quiet_broken_pipe
from cfem_ros.recording import offline
from cfem_ros.recording.errors import OutputError
from cfem_ros.recording.recorder import Recorder, run_metadata, StateRecorder
from cfem_ros.study.resources import MethodFailed, ResourceFailure
import numpy as np

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_BAD_INPUT = 2
#: ``cfem-sim run``: the run stopped at a contact (``contacts: on_contact: stop``).
EXIT_CONTACT = 3

LOG = logging.getLogger('cfem_ros')


def _error(message: str) -> int:
    print(f'ERROR: {message}', file=sys.stderr)
    return EXIT_BAD_INPUT


def _failed(message: str) -> int:
    """Say what stopped a command that had started working (a full disk); exit 1."""
    print(f'ERROR: {message}', file=sys.stderr)
    return EXIT_FAILED


def _vec(values, fmt='{:+.6g}') -> str:
    return '[' + ', '.join(fmt.format(v) for v in values) + ']'


def _describe_release(joint) -> str:
    rel = joint.release
    parts = []
    if rel.time is not None:
        parts.append(f'time {rel.time:g} s')
    if rel.angle is not None:
        parts.append(f'angle {math.degrees(rel.angle):g} deg')
    if rel.distance is not None:
        parts.append(f'distance {rel.distance:g} m')
    if rel.force is not None:
        parts.append(f'force {rel.force:g} N')
    return ', '.join(parts) if parts else 'never (or on command)'


def _cannot_start(scenario: str, errors: list) -> str:
    """Return the error line of a scenario that check and run both refuse."""
    more = f' (and {len(errors) - 1} more problem(s))' if len(errors) > 1 else ''
    return f'{scenario}: cannot start: {errors[0]}{more}'


def cmd_check(scenario: str) -> int:
    """Validate a scenario and print a summary; exit status 0 or 2."""
    from cfem_ros.core.run.startcheck import start_problems
    try:
        model = load_scenario(scenario)
        with np.errstate(all='raise', under='ignore'):
            sim = Simulator(model)
        errors, warnings = start_problems(sim)
    except CfemError as err:
        return _error(str(err))
    except (ArithmeticError, np.linalg.LinAlgError) as err:
        why = ' '.join(str(err).split())[:120]
        return _error(f'{scenario}: the joints cannot be analysed at t = 0 '
                      f'({type(err).__name__}: {why}); expected a regular configuration')
    if errors:
        return _error(_cannot_start(scenario, errors))
    for text in warnings:
        print(f'WARNING: {scenario}: {text}', file=sys.stderr)
    print(f'{scenario}: valid scenario {model.name!r}')
    print(f'  world frame {model.frame_id!r}, gravity {_vec(model.gravity)} m/s^2, '
          f'dt {model.dt:g} s, duration {model.duration:g} s, '
          f'baumgarte {model.baumgarte:g} 1/s')
    print(f'  bodies ({len(model.bodies)}):')
    for body in model.bodies:
        if body.fixed:
            detail = 'fixed'
        elif body.motion is not None:
            detail = (f'kinematic, a table of {len(body.motion.times)} rows' if len(
                body.motion.times) else f'kinematic, velocity {_vec(body.motion.velocity)} m/s, '
                f'rates {_vec(np.degrees(body.motion.rates))} deg/s')
        else:
            detail = (f'{body.mass:g} kg, principal inertia '
                      f'{_vec(np.linalg.eigvalsh(body.inertia), "{:.6g}")} kg m^2')
        moved = (f' (cg_offset {_vec(body.cg_offset)} m from the nominal CG)'
                 if np.any(body.cg_offset) else '')
        print(f'    {body.name:<16} {detail}; CG {_vec(body.position)} m{moved}')
    print(f'  joints ({len(model.joints)}):')
    for joint in model.joints:
        trans, rot = joint.rows.dof
        print(f'    {joint.name:<16} {joint.kind:<11} '
              f'{model.bodies[joint.parent].name} -> {model.bodies[joint.child].name}; '
              f'frees {trans} translation(s), {rot} rotation(s); '
              f'release: {_describe_release(joint)}'
              + ('' if joint.compliance is None
                 else f'; compliance {_vec(joint.compliance, "{:.3g}")}'))
    for group in model.release_groups:
        members = ', '.join(model.joints[k].name for k in group.joints)
        print(f'  release group {group.name}: {members} (one instant)')
    if model.wrenches:
        _print_wrenches(model)
    names = [b.name for b in model.bodies]
    for aero in model.aero:
        density = (f'density {aero.density:.6g} kg/m^3' if aero.altitude is None else
                   f'ISA from {aero.altitude:g} m (density {aero.density:.6g} kg/m^3 there)')
        print(f'  aero on {names[aero.body]}: S {aero.area:g} m^2, '
              f'L {aero.length:g} m, {density}, '
              f'air {_vec(aero.freestream)} m/s, '
              f'table {len(aero.alpha)} alpha x {len(aero.beta)} beta x {len(aero.mach)} Mach')
        more = describe_aero(aero, names)
        if more:
            print(f'    {more}')
    for brace in model.braces:
        damping = f', damping {brace.damping:g} N s/m' if brace.damping else ''
        print(f'  sway brace {brace.name}: {names[brace.carrier]} pushes {names[brace.body]} '
              f'at {_vec(brace.point)} m along {_vec(brace.direction, "{:.4g}")} '
              f'({names[brace.body]} axes); preload {brace.preload:g} N, '
              f'stiffness {brace.stiffness:g} N/m{damping}')
    for pair in model.contacts:
        a, b = (names[i] for i in pair.bodies)
        print(f'  contact watched: {a} - {b} ({"stop" if pair.stop else "continue"} at contact)')
    free = sum(b.dynamic for b in model.bodies)
    print(f'  degrees of freedom: {sim.dof} '
          f'({6 * free} of {free} free bodies less {6 * free - sim.dof} '
          f'removed by the joints)')
    return EXIT_OK


def _print_wrenches(model):
    """Print the scheduled loads of a model (cfem-sim check)."""
    print(f'  wrenches ({len(model.wrenches)}):')
    names = [body.name for body in model.bodies]
    for w in model.wrenches:
        axes = model.frame_id if w.frame < 0 else names[w.frame]
        force = (f'{w.table_against} table of {len(w.table)} rows' if len(w.table)
                 else f'{_vec(w.force)} N')
        until = ('' if w.end is None else f' to {_when(w.end, w.end_release)}') + (
            '' if w.stroke is None else f' over a stroke of {w.stroke:g} m')
        reacts = '' if w.reacts_on < 0 else f'; reacts on {names[w.reacts_on]}'
        print(f'    {w.name:<16} on {names[w.body]} at {_vec(w.point)} m: force {force} '
              f'({axes} axes), from {_when(w.start, w.start_release)}{until}{reacts}')


def _when(time: float, release) -> str:
    """Return a wrench's start or end: a time, or a delay after a release."""
    return f'{time:g} s' if release is None else f'{time:g} s after the release of {release}'


def _print_state(sim):
    print(f'final state at t = {sim.t:.9g} s:')
    position, quat = sim.position, sim.orientation
    velocity, rates = sim.velocity, np.degrees(sim.rates)
    with np.errstate(all='ignore'):
        norms = np.linalg.norm(quat, axis=1)
    # a failed run's state may hold overflowing numbers: such an attitude has no angles
    rotation = np.isfinite(norms) & (norms > 0.0) & np.isfinite(quat).all(axis=1)
    rpy = np.full((len(quat), 3), np.nan)
    if rotation.any():
        rpy[rotation] = rotations.to_rpy_deg(quat[rotation] / norms[rotation, None])
    for i, body in enumerate(sim.model.bodies):
        if body.fixed:
            continue
        attitude = f'{_vec(rpy[i])} deg' if rotation[i] else 'undefined (no finite attitude)'
        print(f'  {body.name}: CG {_vec(position[i])} m, roll/pitch/yaw {attitude}, '
              f'velocity {_vec(velocity[i])} m/s (world), '
              f'rates {_vec(rates[i])} deg/s (body)')


def _same_file(a: str, b: str) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


def _output_refused(path: str, overwrite: bool, what: str = 'a recording') -> Optional[str]:
    """Return why -o path cannot receive a recording (None if it can), before anything runs."""
    from cfem_ros.recording.outputs import output_problem
    return output_problem(path, exists_ok=overwrite, what=what)


def _check_run_size(model, rate: float, max_samples: float, max_gb: float) -> Optional[str]:
    """Return why a run is too large to record (None if it is not)."""
    samples = offline.expected_samples(rate, model.duration)
    size = offline.estimate_bytes(model, samples)
    if samples > max_samples:
        return (f'--rate {rate:g} Hz over {model.duration:g} s: {samples:.4g} samples, more '
                f'than --max-samples {max_samples:.4g}; lower --rate or --duration, or raise '
                '--max-samples')
    if size > max_gb * 1e9:
        return (f'--rate {rate:g} Hz over {model.duration:g} s: about {size / 1e9:.3g} GB '
                f'of recording, more than --max-gb {max_gb:g}; lower --rate or --duration, '
                'or raise --max-gb')
    return None


def cmd_run(scenario: str, output: str, rate: float = 100.0, duration: Optional[float] = None,
            dt: Optional[float] = None, inputs: Optional[str] = None,
            overwrite: bool = False, max_samples: float = offline.MAX_SAMPLES,
            max_gb: float = offline.MAX_GB, odometry: Optional[str] = None) -> int:
    """
    Run a scenario offline and record it; exit status 0, 1, 2, 3 (contact), 130 or 143.

    ``odometry`` ('interpolate' or 'extrapolate') says how replayed
    odometry drives a kinematic body; None: as the node that recorded the
    inputs did (its ``interpolate_odometry``), else interpolate.

    The recording is written to a partial file next to output and moved
    onto it when finished, also after SIGINT (130) or SIGTERM (143), which
    stop the run between two chunks.
    """
    low, high = offline.RATE_RANGE
    if not (math.isfinite(rate) and low <= rate <= high):
        return _error(f'--rate: is {rate:g}; expected a sample rate from {low:g} to {high:g} Hz')
    refused = _output_refused(output, overwrite=True)
    if refused:
        return _error(refused)
    if _same_file(output, scenario):
        return _error(f'-o {output}: is the scenario file itself; choose another output')
    if inputs and _same_file(output, inputs):
        return _error(f'-o {output}: is the --inputs log itself; choose another output')
    try:
        model = load_scenario(scenario, duration=duration, dt=dt)
        too_large = _check_run_size(model, rate, max_samples, max_gb)
        if too_large:
            return _error(too_large)
        replay = []
        interpolate = odometry != 'extrapolate'
        if inputs:
            # mcap's reader only to replay
            from cfem_ros.recording.replay import read_inputs, recorded_interpolation
            replay = read_inputs(inputs)
            if odometry is None:
                interpolate = recorded_interpolation(inputs) is not False
            late = [item for item in replay if item.time > model.duration]
            if late:
                print(f'warning: {len(late)} input(s) of {inputs} come after the run ends at '
                      f't = {model.duration:g} s (the first at t = {late[0].time:.6g} s) and '
                      'are not replayed; give a longer --duration to replay them',
                      file=sys.stderr)
        if os.path.lexists(output) and not overwrite:
            return _error(f'{output}: already exists; pass --overwrite to replace it')
        sim = Simulator(model)
        from cfem_ros.core.run.startcheck import start_problems
        errors, _ = start_problems(sim)   # what check refuses, run refuses (exit 2)
        if errors:
            return _error(_cannot_start(scenario, errors))
    except CfemError as err:
        return _error(str(err))
    interactive = sys.stderr.isatty()
    stop = []

    def hold(signum, frame):   # while recording: stop at the next safe point
        stop.append(signum)

    def progress(t):
        if stop:
            raise Interrupted(stop[0])
        if interactive:
            print(f'\r  t = {t:.3f} / {model.duration:g} s', end='', file=sys.stderr)

    started = time.monotonic()
    state = None
    ok = True
    previous = [signal.signal(s, hold) for s in (signal.SIGINT, signal.SIGTERM)]
    try:
        with Recorder(output, overwrite=overwrite, atomic=True,
                      metadata=run_metadata(model, scenario, rate, 0)) as recorder:
            try:
                if stop:
                    raise Interrupted(stop[0])
                state = StateRecorder(recorder, sim)
                ok = offline.run(sim, state, rate_hz=rate, duration=model.duration,
                                 inputs=replay, progress=progress, progress_every=0.2,
                                 interpolate_odometry=interpolate)
            except Interrupted:
                pass   # the recording is finished (and moved onto output) on the way out
    except OutputError as err:   # a full disk: the run stopped there, nothing half-written
        samples = state.samples if state is not None else 0
        print(f'ERROR: the recording failed at t = {sim.t:.9g} s ({samples} samples '
              f'taken): {err}', file=sys.stderr)
        return EXIT_FAILED
    except CfemError as err:
        return _error(str(err))
    finally:
        signal.signal(signal.SIGINT, previous[0])
        signal.signal(signal.SIGTERM, previous[1])
    if interactive:
        print('\r' + ' ' * 40 + '\r', end='', file=sys.stderr)
    if stop:
        name = signal.Signals(stop[0]).name
        samples = state.samples if state is not None else 0
        print(f'{name}: stopped at t = {sim.t:.9g} s; {samples} samples '
              f'({recorder.message_count} messages) in {output}, complete', file=sys.stderr)
        return 128 + stop[0]
    wall = time.monotonic() - started
    print(f'{model.name}: {sim.t:.9g} s simulated in {sim.steps} steps, '
          f'{wall:.3g} s wall ({sim.t / wall if wall > 0 else float("inf"):.3g}x real time)')
    for event in sim.events:
        if event['event'] == 'contact':
            a, b = event['bodies']
            x, y, z = event['point']
            print(f'contact {a} {b} at t = {event["time"]:.9f} s, point '
                  f'[{x:.6g}, {y:.6g}, {z:.6g}] m (world){_parts(event)}')
        else:
            print(describe_event(event))
    if not any(e['event'] == 'release' for e in sim.events):
        print('no joint released')
    _print_state(sim)
    print(f'recording: {output} ({recorder.message_count} messages)')
    if sim.status == 'contact':
        print(f'stopped: {sim.message}; the recording holds everything up to then',
              file=sys.stderr)
        return EXIT_CONTACT
    if not ok:
        print(f'ERROR: the run failed {sim.message}; the recording holds everything '
              f'up to t = {sim.t:.9g} s', file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def cmd_info(recording: str) -> int:
    """Print a recording's topics, message counts, time range, chunks and events; exit 0 or 2."""
    from cfem_ros.recording import analysis   # the reader only for the commands that read
    from cfem_ros.recording.summary import read_summary
    try:
        summary = read_summary(recording)
    except CfemError as err:
        return _error(str(err))
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
    bodies = sorted({m['name'] for t in summary.topics for m in [analysis.BODY_TOPIC.match(t)]
                     if m and m['kind'] == 'pose'})
    joints = sorted({m['name'] for t in summary.topics for m in [analysis.JOINT_TOPIC.match(t)]
                     if m})
    print(f'  bodies: {", ".join(bodies) or "none"}; joints: {", ".join(joints) or "none"}')
    releases = sorted((e['time'], e.get('joint', '?'), e.get('cause', '?'))
                      for e in summary.events if e.get('event') == 'release' and 'time' in e)
    for t, joint, cause in releases:
        print(f'  release {joint} at t = {t:.9f} s ({cause})')
    if not releases:
        print('  no release event')
    for event in summary.events:   # end-of-stroke figures (SPEC section 7), braces (11)
        if event.get('event') == 'stroke_end' and 'velocity' in event and 'rates' in event:
            print(f'  {describe_event(event)}')
        if (event.get('event') == 'brace_contact' and 'time' in event and 'brace' in event
                and 'contact' in event):
            print(f'  {describe_event(event)}')
    for e in summary.events:
        if e.get('event') == 'contact' and 'time' in e:
            print(f'  contact {" ".join(e.get("bodies", ()))} at t = {e["time"]:.9f} s, '
                  f'point {e.get("point")} m (world){_parts(e)}')
    return EXIT_OK


def _parts(event: dict) -> str:
    """Return the parts of the two shapes that touched (0 for a convex shape), for a line."""
    parts = event.get('parts')
    return f', parts {parts[0]} and {parts[1]}' if parts and len(parts) == 2 else ''


def cmd_recover(broken: str, fixed: str) -> int:
    """Copy the verifiably intact messages of a cut or damaged recording; exit 0, 1 or 2."""
    if _same_file(broken, fixed):
        return _error(f'-o {fixed}: is the broken file itself; choose another output')
    refused = _output_refused(fixed, overwrite=False)
    if refused:
        return _error(refused)
    try:
        from cfem_ros.recording.recover import recover
        report = recover(broken, fixed)
    except OutputError as err:
        print(f'ERROR: {err}', file=sys.stderr)
        return EXIT_FAILED
    except CfemError as err:
        return _error(str(err))
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


def cmd_plot(recording: str, directory: str, metric: Optional[str] = None,
             relative_to: Optional[str] = None, snapshots: str = '0.1,0.2,0.3') -> int:
    """Write the figures of a recording (or a sweep folder) under directory; exit 0 or 2."""
    from cfem_ros.separation import commands as separation
    if os.path.isdir(recording):
        code = _plot_sweep(recording, directory, metric)
        if code or relative_to is None:
            return code
        try:
            paths = separation.plot_sweep_relative(recording, relative_to, directory)
        except CfemError as err:
            return _error(str(err))
        print('\n'.join(paths))
        return EXIT_OK
    from cfem_ros.recording import analysis   # the reader only for the commands that read
    try:
        run = analysis.open_run(recording)
        if relative_to is not None:   # before anything is drawn
            separation.check_relative(run, relative_to, snapshots)
    except CfemError as err:
        return _error(str(err))
    try:
        from cfem_ros import plots   # matplotlib only for the commands that draw
        paths = plots.write_figures(run, directory)
        if relative_to is not None:
            paths += separation.plot_relative(run, relative_to, directory, snapshots)
    except CfemError as err:
        return _error(str(err))
    except OSError as err:
        return _error(f'{directory}: cannot write ({err.strerror or err})')
    for path in paths:
        print(path)
    return EXIT_OK


def cmd_export(args) -> int:
    """Write a recording's time histories as a table (SPEC section 12); exit 0 or 2."""
    from cfem_ros.separation import commands as separation
    try:
        print(separation.export(args.recording, args.output, args.relative_to, args.rate,
                                args.overwrite))
    except CfemError as err:
        return _error(str(err))
    return EXIT_OK


def _plot_sweep(outdir: str, directory: str, metric: Optional[str]) -> int:
    if not os.path.exists(os.path.join(outdir, 'results.parquet')):
        return _error(f'{outdir}: no results.parquet; expected a finished sweep folder '
                      '(cfem-sim sweep ... -o OUTDIR) or a recording')
    try:
        _study_imports()
        from cfem_ros import study_plots
        paths = study_plots.write_sweep_figures(outdir, directory, metric)
    except CfemError as err:
        return _error(str(err))
    except ValueError as err:
        return _error(str(err))
    except OSError as err:
        return _error(f'{directory}: cannot write ({err.strerror or err})')
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


def cmd_compare(first: str, second: str, directory: Optional[str] = None, maps=()) -> int:
    """Print the largest differences of two recordings (and overlay figures); exit 0 or 2."""
    from cfem_ros.recording import analysis   # the reader only for the commands that read
    topic_map = {}
    for item in maps or ():
        ours, sep, theirs = item.partition('=')
        if not sep or not ours.startswith('/') or not theirs.startswith('/'):
            return _error(f'--map {item!r}; expected A_TOPIC=B_TOPIC, absolute topic names '
                          '(e.g. /cfem/bodies/store/pose=/flight/store/pose)')
        topic_map[theirs] = ours
    try:
        a, b = analysis.open_run(first), analysis.open_run(second, topic_map=topic_map)
    except CfemError as err:
        return _error(str(err))
    rows, only_a, only_b = analysis.compare_runs(a, b)
    if not rows:
        return _error(f'{first} and {second} share no body or joint; nothing to compare')
    print(f'A = {first}')
    print(f"B = {second} (interpolated onto A's sample times)")
    span = _compared_span(a, b)
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
    if directory:
        try:
            from cfem_ros import plots
            paths = plots.write_comparison(a, b, directory)
        except OSError as err:
            return _error(f'{directory}: cannot write ({err.strerror or err})')
        for path in paths:
            print(path)
    return EXIT_OK


def _dask_client(workers: Optional[int], scheduler: Optional[str]):
    """Return (client, cluster or None): a LocalCluster of processes, or a scheduler's."""
    from dask.distributed import Client, LocalCluster
    if scheduler:
        client = Client(scheduler, timeout='30s')
        client.wait_for_workers(1, timeout=60)
        return client, None
    # the worker processes start with SIGINT ignored (and keep it so): a Ctrl-C at the
    # terminal, sent to every process of the group, stops only this one, which then closes
    # the cluster (no tracebacks from the workers, no leaked semaphores)
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1,
                               threads_per_worker=1, processes=True, dashboard_address=':0',
                               silence_logs=logging.ERROR)
        return Client(cluster), cluster
    finally:
        signal.signal(signal.SIGINT, previous)


def _study_imports():
    """Import the study layer and Dask, or say how to install them."""
    try:
        import dask.distributed  # noqa: F401
        import pandas  # noqa: F401
        import pyarrow  # noqa: F401
    except ImportError as err:
        raise InputError(f'cfem-sim sweep/summarize need {err.name}, which is not installed; '
                         "install the study extra: pip install -e '.[study]' "
                         '(dask[distributed], pandas, pyarrow)') from None
    from cfem_ros import study
    return study


def _raise_interrupted(signum, frame):
    raise Interrupted(signum)


def _close(client, cluster, hold: bool = True):
    """
    Close a Dask client and its local cluster (either may be None), whatever comes meanwhile.

    A SIGINT or SIGTERM during the closing is held until it is done (an
    exception raised inside Dask's shutdown would leave its comms half
    closed and their tracebacks on stderr); Dask's own logs of connections
    closing under it are not shown. Return the signal held, or None.
    """
    held = []
    previous = [signal.signal(s, (lambda signum, frame: held.append(signum)) if hold
                              else signal.getsignal(s))
                for s in (signal.SIGINT, signal.SIGTERM)]
    quiet = logging.getLogger('distributed')
    level = quiet.level
    quiet.setLevel(logging.CRITICAL)
    try:
        for thing in (client, cluster):
            if thing is None:
                continue
            try:
                thing.close()
            except Exception:  # noqa: B902 - a comm already closed: nothing left to close
                pass
    finally:
        quiet.setLevel(level)
        signal.signal(signal.SIGINT, previous[0])
        signal.signal(signal.SIGTERM, previous[1])
    return held[0] if held else None


def cmd_plan(plan: str) -> int:
    """Print how many runs without a failure show P(success) >= P at confidence C."""
    from cfem_ros.study.confidence import runs_needed
    try:
        success, level = (float(v) for v in plan.split(','))
        n = runs_needed(success, level)
    except ValueError:
        return _error(f'--plan {plan!r}; expected P,C: a success probability and a '
                      'confidence, each between 0 and 1 (0.95,0.95)')
    print(f'{n} runs without a failure show P(success) >= {success:g} at {100 * level:g} % '
          f'confidence (P(fail) <= {1 - success:.3g}); with failures, more runs are needed')
    return EXIT_OK


def _print_fractions(spec, table):
    """Print the failure fraction of each criterion and of any, with exact intervals."""
    from cfem_ros.study.confidence import fractions
    for fraction in fractions(table, spec.criteria, spec.confidence):
        print(fraction.sentence())


def cmd_study(sweep_file: str, outdir: str, method: str, design: Optional[str],
              workers: Optional[int], scheduler: Optional[str], runs: Optional[int],
              record: str, target_cov: float) -> int:
    """Run a rare-event method or a sensitivity design (SPEC section 9); exit 0 or 2."""
    if not (math.isfinite(target_cov) and 0 < target_cov < 1):
        return _error(f'--cov is {target_cov!r}; expected a coefficient of variation '
                      'between 0 and 1 (0.1)')
    try:
        study = _study_imports()
        spec = study.load_sweep(sweep_file, runs=runs)
        from cfem_ros.study import methods
        if design is None:
            from cfem_ros.study.reliability import distribution
            if not spec.criteria:
                return _error(f'{sweep_file}: criteria: missing; --method {method} estimates '
                              'P(a criterion fails): expected criteria as in SPEC section 9')
            distribution(spec)   # refuses what it cannot map, before any run
        else:
            from cfem_ros.study.sensitivity import problem
            problem(spec, design)
        methods.check_size(spec, design or method)   # before the cluster starts
    except CfemError as err:
        return _error(str(err))
    except ImportError as err:
        return _error(f'--{"design" if design else "method"} needs {err.name}, which is not '
                      "installed; install the study extra: pip install -e '.[study]'")
    outdir = os.path.abspath(outdir)
    started = time.monotonic()
    client = cluster = None
    previous = [signal.signal(s, _raise_interrupted) for s in (signal.SIGINT, signal.SIGTERM)]
    try:
        client, cluster = _dask_client(workers, scheduler)
        found = methods.run_study(spec, outdir, method=method, design=design, client=client,
                                  target_cov=target_cov, record=record,
                                  log=lambda line: print(f'{design or method}: {line}',
                                                         file=sys.stderr, flush=True))
    except Interrupted as stop:
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, exit_now)
        _close(client, cluster)
        client = cluster = None
        print(f'\ninterrupted by {stop}: the runs done are saved in {outdir}; run the same '
              'command again to resume', file=sys.stderr)
        return stop.exit_status
    except (ResourceFailure, MethodFailed) as err:   # while working: the runs are saved
        return _failed(str(err))
    except CfemError as err:
        return _error(str(err))
    except OSError as err:
        return _error(f'{scheduler or "local cluster"}: {err}')
    finally:
        _close(client, cluster)
        signal.signal(signal.SIGINT, previous[0])
        signal.signal(signal.SIGTERM, previous[1])
    table = found['table']
    failed = int((table['status'] != 'ok').sum())
    print(f'{os.path.join(outdir, "results.parquet")}: {len(table)} runs, {failed} did not '
          f'finish, {time.monotonic() - started:.3g} s')
    if design is None:
        print(found['estimate'].sentence())
        print(os.path.join(outdir, methods.ESTIMATE))
    else:
        _print_indices(found['indices'], design)
        print(os.path.join(outdir, methods.SENSITIVITY))
    return EXIT_OK


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


def cmd_sweep(sweep_file: Optional[str], outdir: Optional[str], workers: Optional[int] = None,
              scheduler: Optional[str] = None, runs: Optional[int] = None,
              record: str = 'none', csv: bool = False, method: str = 'mc',
              design: Optional[str] = None, plan: Optional[str] = None,
              target_cov: float = 0.1) -> int:
    """Run a sweep on Dask into outdir (resuming it); exit 0, 1 (failed runs) or 2."""
    if plan is not None:
        return cmd_plan(plan)
    if sweep_file is None or outdir is None:
        return _error('cfem-sim sweep: expected SWEEP.yaml -o OUTDIR (or --plan P,C)')
    if workers is not None and workers < 1:
        return _error(f'--workers: is {workers}; expected a number of workers >= 1')
    if design is not None and method != 'mc':
        return _error(f'--method {method} and --design {design}: expected one of them')
    if os.path.exists(outdir) and not os.path.isdir(outdir):
        return _error(f'-o {outdir}: is not a folder; expected the sweep folder (new, or one '
                      'to resume)')
    if design is not None or method != 'mc':
        return cmd_study(sweep_file, outdir, method, design, workers, scheduler, runs,
                         record, target_cov)
    try:
        study = _study_imports()
        sweep = study.Sweep.from_file(sweep_file, runs=runs)
        outdir = os.path.abspath(outdir)
        from cfem_ros.study.sweep import prepare, Progress
        todo = prepare(sweep.spec, outdir, record)
    except CfemError as err:
        return _error(str(err))
    total = sweep.total
    print(f'{sweep_file}: {total} runs, {total - len(todo)} already in {outdir}',
          file=sys.stderr)
    started = time.monotonic()
    client = cluster = late = None
    # SIGINT and SIGTERM stop the waiting here, so that the cluster is closed (no leaked
    # worker processes or semaphores) and the user is told what is kept
    previous = [signal.signal(s, _raise_interrupted) for s in (signal.SIGINT, signal.SIGTERM)]
    try:
        if todo:
            client, cluster = _dask_client(workers, scheduler)
        meter = Progress(total, total - len(todo))
        table = sweep.run(client, outdir, record=record, csv=csv, progress=meter.update)
    except Interrupted as stop:
        for s in (signal.SIGINT, signal.SIGTERM):   # a second one ends at once
            signal.signal(s, exit_now)
        _close(client, cluster, hold=False)
        client = cluster = None
        from cfem_ros.study.sweep import saved_runs
        print(f'\ninterrupted by {stop}: {saved_runs(outdir)} of {total} runs are saved in '
              f'{outdir}; run the same command again to resume', file=sys.stderr)
        return stop.exit_status
    except ResourceFailure as err:
        return _failed(str(err))
    except OSError as err:
        return _error(f'{scheduler or "local cluster"}: {err}')
    finally:
        late = _close(client, cluster)
        signal.signal(signal.SIGINT, previous[0])
        signal.signal(signal.SIGTERM, previous[1])
    if late is not None:
        print(f'{signal.Signals(late).name} while the cluster was closing: the sweep had '
              f'finished, its table is complete in {outdir}', file=sys.stderr)
    failed = int((table['status'] == 'failed').sum())
    wall = time.monotonic() - started
    touched = int((table['status'] == 'contact').sum())
    contact = f'{touched} stopped at a contact, ' if touched else ''
    invalid = int((table['status'] == 'invalid').sum())
    if invalid:   # SPEC section 12: reported, never counted as failures
        contact += (f"{invalid} invalid draws (refused by the scenario's checks, not run, "
                    'left out of every probability), ')
    print(f'{os.path.join(outdir, "results.parquet")}: {total} runs, {failed} failed, '
          f'{contact}{wall:.3g} s')
    for _, row in table[table['status'] == 'failed'].head(5).iterrows():
        print(f'  run {row["run"]} failed: {row["message"]}', file=sys.stderr)
    if sweep.spec.criteria:
        from cfem_ros.study import methods
        _print_fractions(sweep.spec, table)
        methods.write_estimate(outdir, methods.mc_estimate(sweep.spec, table))
    if late is not None:
        return 128 + late
    return EXIT_FAILED if failed else EXIT_OK


def cmd_summarize(recordings, metrics_file: str, output: str, workers: Optional[int] = None,
                  scheduler: Optional[str] = None, csv: bool = False,
                  overwrite: bool = False) -> int:
    """Compute a sweep file's metrics over recordings into a table; exit 0, 1 or 2."""
    tables = [output] + ([os.path.splitext(output)[0] + '.csv'] if csv else [])
    for table in tables:   # a device or folder is never replaced by the table
        refused = _output_refused(table, overwrite=True, what='a table')
        if refused:
            return _error(refused)
        if not overwrite and os.path.lexists(table):
            return _error(f'{table}: already exists; pass --overwrite to replace it')
    try:
        study = _study_imports()
        spec = study.load_sweep(metrics_file, runs=1)
    except CfemError as err:
        return _error(str(err))
    client = cluster = None
    try:
        if len(recordings) > 1 or scheduler:
            client, cluster = _dask_client(workers, scheduler)
        table = study.summarize(recordings, spec.metrics, client)
    finally:
        _close(client, cluster)
    from cfem_ros.study.sweep import write_atomic
    try:
        write_atomic(table, output)
        if csv:
            write_atomic(table, os.path.splitext(output)[0] + '.csv')
    except OSError as err:
        return _error(f'{output}: cannot write ({err.strerror or err})')
    failed = table[table['status'] == 'failed']
    for _, row in failed.iterrows():
        print(f'  {row["message"]}', file=sys.stderr)
    print(f'{output}: {len(table)} recordings, {len(failed)} unreadable')
    return EXIT_FAILED if len(failed) else EXIT_OK


def cmd_report(outdir: str, output: str, overwrite: bool = False) -> int:
    """Write a study folder's self-contained HTML report; exit 0 or 2."""
    refused = _output_refused(output, overwrite=True, what='a report')
    if refused:
        return _error(refused)
    if not overwrite and os.path.lexists(output):
        return _error(f'{output}: already exists; pass --overwrite to replace it')
    if not os.path.exists(os.path.join(outdir, 'results.parquet')):
        return _error(f'{outdir}: no results.parquet; expected a finished sweep folder '
                      '(cfem-sim sweep ... -o OUTDIR)')
    import tempfile
    try:
        _study_imports()
        from cfem_ros.study.folder import check_folder
        check_folder(outdir)
        from cfem_ros import study_plots
        from cfem_ros.study.report import write_report
        with tempfile.TemporaryDirectory(prefix='cfem-report-') as tmp:
            figures = study_plots.write_sweep_figures(outdir, tmp, None)
            from cfem_ros.separation.envelopes import report_figures   # SPEC section 12
            figures = report_figures(outdir, tmp, lambda line: print(
                f'WARNING: {line}', file=sys.stderr)) + figures
            first = [p for p in figures if not os.path.basename(p).startswith('hist_')]
            write_report(outdir, output, first + [p for p in figures if p not in first])
    except CfemError as err:
        return _error(str(err))
    except OSError as err:
        return _error(f'{output}: cannot write ({err.strerror or err})')
    print(output)
    return EXIT_OK


def cmd_rerun(outdir: str, run: int, output: str) -> int:
    """Run one run of a sweep folder again, alone, and record it; exit 0, 1 or 2."""
    import dataclasses
    import json
    try:
        study = _study_imports()
        from cfem_ros.study.folder import check_folder, read_table
        manifest = check_folder(outdir)
        table = read_table(os.path.join(outdir, 'results.parquet'))
        if 'run' not in table.columns or not isinstance(manifest.get('resolved'), dict):
            return _error(f'{outdir}: its results.parquet or sweep.json is not what a sweep '
                          'writes; expected a sweep folder (sweep.json, results.parquet)')
    except CfemError as err:
        return _error(str(err))
    rows = table[table['run'] == run]
    if rows.empty:
        return _error(f'{outdir}: no run {run}; expected 0 to {len(table) - 1}')
    try:
        spec = study.load_sweep(manifest['sweep'], runs=manifest['resolved']['runs'])
    except CfemError as err:
        return _error(str(err))
    if json.loads(spec.describe()) != manifest['resolved']:
        return _error(f'{manifest["sweep"]}: changed since {outdir} was run; expected the '
                      'sweep file and scenario the folder was made with')
    if manifest.get('method', 'mc') != 'mc':   # the method chose the values: the table's
        spec = dataclasses.replace(spec, values={
            v.path: {run: float(rows.iloc[0][v.path])} for v in spec.variables})
    refused = _output_refused(output, overwrite=False)
    if refused:
        return _error(refused)
    from cfem_ros.study.sweep import run_one
    try:
        row = run_one(spec, run, record=output)
    except (CfemError, OSError) as err:   # the recording could not be written
        return _failed(f'{output}: run {run} of {outdir} could not be recorded: '
                       f'{getattr(err, "strerror", None) or err}')
    print(f'{output}: run {run} of {outdir}, status {row["status"]}'
          + (f' ({row["message"]})' if row['message'] else ''))
    return EXIT_OK if row['status'] == 'ok' else EXIT_FAILED


def cmd_fit(fit_file: str, outdir: str, threads: Optional[int] = None,
            overwrite: bool = False) -> int:
    """Fit a scenario's parameters to measured poses (SPEC section 13); exit 0, 1 or 2."""
    from cfem_ros.study.fit.outputs import OUTPUTS
    held = [name for name in OUTPUTS if os.path.lexists(os.path.join(outdir, name))]
    if held and not overwrite:
        return _error(f'-o {outdir}: already holds {", ".join(held)}; pass --overwrite to '
                      'replace them, or choose a new folder')
    if threads is not None and threads < 1:
        return _error(f'--threads: is {threads}; expected a whole number >= 1')
    from cfem_ros.study.fit.run import fit_file as fit
    from cfem_ros.study.fit.spec import FitError
    try:
        _, _, found = fit(fit_file, outdir, threads=threads)
    except FitError as err:
        if err.key == 'parameters':   # a run failed within the bounds: not the file's form
            print(f'ERROR: {err}', file=sys.stderr)
            return EXIT_FAILED
        return _error(str(err))
    except CfemError as err:
        return _error(str(err))
    except OSError as err:
        return _error(f'{outdir}: cannot write ({err.strerror or err})')
    print(found)
    print(f'outputs: {outdir}/ (fit.json, fitted.yaml, fitted.mcap, fit_trajectory.png, '
          'fit_residuals.png)')
    return EXIT_OK


class _Parser(argparse.ArgumentParser):
    """argparse's parser, whose usage errors are one ERROR line (exit 2), as every other."""

    def error(self, message: str):
        """Print one ``ERROR:`` line naming the command and where to look; exit 2."""
        text = ' '.join(message.split())
        print(f'ERROR: {self.prog}: {text}; see {self.prog} --help', file=sys.stderr)
        sys.exit(EXIT_BAD_INPUT)


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser of cfem-sim."""
    parser = _Parser(
        prog='cfem-sim',
        description='Simulate rigid bodies joined by releasable joints (CFEM), no ROS needed.')
    sub = parser.add_subparsers(dest='command', required=True, metavar='COMMAND')
    run = sub.add_parser('run', help='run a scenario as fast as possible and record it',
                         description='Run a scenario and record it to MCAP (SPEC section 4).')
    run.add_argument('scenario', metavar='SCENARIO', help='scenario file (YAML)')
    run.add_argument('-o', '--output', required=True, metavar='OUT.mcap',
                     help='recording to write')
    run.add_argument('--rate', type=float, default=100.0, metavar='HZ',
                     help='sample rate of the recording (default 100 Hz)')
    run.add_argument('--duration', type=float, metavar='S',
                     help="run length, overriding the scenario's")
    run.add_argument('--dt', type=float, metavar='S', help="RK4 step, overriding the scenario's")
    run.add_argument('--inputs', metavar='LOG.mcap',
                     help='replay the wrenches and release commands of a recording')
    run.add_argument('--odometry', choices=('interpolate', 'extrapolate'),
                     help='how replayed odometry drives a kinematic body: on the cubic between '
                     'messages, or extrapolated from the latest (default: as the node that '
                     'recorded the log did, else interpolate)')
    run.add_argument('--overwrite', action='store_true',
                     help='replace OUT if it exists (once the new recording is complete)')
    run.add_argument('--max-samples', type=float, default=offline.MAX_SAMPLES, metavar='N',
                     help='refuse a run of more samples (default %(default).0f)')
    run.add_argument('--max-gb', type=float, default=offline.MAX_GB, metavar='GB',
                     help='refuse a run whose recording would exceed this size '
                     '(default %(default)g GB)')
    check = sub.add_parser('check', help='validate a scenario and summarize it',
                           description='Validate a scenario and print its bodies, joints '
                           'and degrees of freedom.')
    check.add_argument('scenario', metavar='SCENARIO', help='scenario file (YAML)')
    plot = sub.add_parser('plot', help='draw the figures of a recording',
                          description='Write PNG figures of a recording: per body CG, '
                          'attitude and rates; per joint force and moment; a 3D view.')
    plot.add_argument('recording', metavar='RUN.mcap|OUTDIR',
                      help='recording to read, or a sweep folder')
    plot.add_argument('-o', '--output', required=True, metavar='DIR',
                      help='folder to write the PNG files to')
    plot.add_argument('--metric', metavar='COLUMN',
                      help='sweep folder: metric to scatter against the varied parameters '
                      '(default the first clearance minimum)')
    from cfem_ros.separation import commands as separation
    separation.add_plot_options(plot)
    separation.add_export_parser(sub)
    info = sub.add_parser('info', help='summarize a recording',
                          description='Print topics, message counts, time range, chunks, '
                          "metadata and events, from the file's summary.")
    info.add_argument('recording', metavar='RUN.mcap', help='recording to read')
    rec = sub.add_parser('recover', help='salvage a cut recording',
                         description='Copy every complete message of a recording cut by a '
                         'hard kill (no footer) into a new, indexed file.')
    rec.add_argument('broken', metavar='BROKEN.mcap', help='cut recording to read')
    rec.add_argument('-o', '--output', required=True, metavar='FIXED.mcap',
                     help='new recording to write (must not exist)')
    compare = sub.add_parser('compare', help='compare two recordings',
                             description='Print the largest difference of each quantity '
                             'between two recordings of the same topics (B resampled onto '
                             "A's times), and optionally overlay them.")
    compare.add_argument('first', metavar='A.mcap', help='reference recording')
    compare.add_argument('second', metavar='B.mcap', help='recording to compare with A')
    compare.add_argument('-o', '--output', metavar='DIR', help='write overlay figures here')
    compare.add_argument('--map', action='append', default=[], metavar='A_TOPIC=B_TOPIC',
                         help="read B's topic B_TOPIC as A's A_TOPIC (repeatable)")
    play = sub.add_parser('play', help='publish a recording over ROS 2',
                          description='Publish the messages of a recording over ROS 2 at '
                          'their log times, with their recorded types and QoS, like ros2 '
                          'bag play.')
    play.add_argument('recording', metavar='LOG.mcap', help='recording to play')
    play.add_argument('--clock', action='store_true',
                      help='publish /clock with the log time (for use_sim_time nodes)')
    play.add_argument('--rate', type=float, default=1.0, metavar='R',
                      help='playback speed (default 1: real time)')
    play.add_argument('--topics', nargs='+', metavar='TOPIC', help='play only these topics')
    play.add_argument('--remap', action='append', default=[], metavar='FROM:=TO',
                      help='publish topic FROM on TO (repeatable)')
    play.add_argument('--wait', type=float, default=5.0, metavar='S',
                      help='wait up to S s for every topic to have a subscriber (default 5)')
    play.add_argument('--delay', type=float, default=2.0, metavar='S',
                      help='then wait S s more before the first message (default 2)')
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
    sweep.add_argument('--plan', metavar='P,C',
                       help='print how many runs without failure show P(success) >= P at '
                       'confidence C (0.95,0.95 -> 59), and exit')
    fit = sub.add_parser('fit', help="fit a scenario's parameters to a measured trajectory",
                         description='Find the parameters (key paths) that make the simulated '
                         'poses of a body match measured ones, with their standard errors and '
                         'correlations; write fit.json, fitted.yaml, fitted.mcap and figures '
                         '(SPEC section 13).')
    fit.add_argument('fit', metavar='FIT.yaml', help='fit file')
    fit.add_argument('-o', '--output', required=True, metavar='OUTDIR', help='folder to write')
    fit.add_argument('--threads', type=int, metavar='N',
                     help="runs of one Jacobian at once (default: the machine's cores)")
    fit.add_argument('--overwrite', action='store_true', help="replace a folder's fit outputs")
    report = sub.add_parser('report', help='one self-contained HTML page of a study folder',
                            description='Write the scenario, sweep, criteria with their '
                            'probabilities, worst runs, sensitivities and figures of a '
                            'sweep folder as one HTML file (SPEC section 9).')
    report.add_argument('outdir', metavar='OUTDIR', help='sweep folder')
    report.add_argument('-o', '--output', required=True, metavar='REPORT.html',
                        help='page to write')
    report.add_argument('--overwrite', action='store_true',
                        help='replace REPORT.html if it exists (never a device or folder)')
    rerun = sub.add_parser('rerun', help='run one run of a sweep folder again and record it',
                           description='Run run RUN of a sweep folder alone, with its values, '
                           'and record it to MCAP.')
    rerun.add_argument('outdir', metavar='OUTDIR', help='sweep folder')
    rerun.add_argument('run', type=int, metavar='RUN', help='run number (column run)')
    rerun.add_argument('-o', '--output', required=True, metavar='RUN.mcap',
                       help='recording to write')
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
    return parser


def cmd_play(recording: str, *, clock: bool = False, rate: float = 1.0, topics=None,
             remaps=(), wait: float = 2.0, delay: float = 1.0) -> int:
    """Publish a recording's messages over ROS 2; exit status 0, or 2 for bad input."""
    if not (math.isfinite(rate) and rate > 0.0):
        return _error(f'--rate is {rate!r}; expected a playback speed > 0 (1: real time)')
    for name, value in (('--wait', wait), ('--delay', delay)):
        if not (math.isfinite(value) and value >= 0.0):
            return _error(f'{name} is {value!r}; expected seconds >= 0')
    try:
        from cfem_ros.ros import player
    except ImportError as err:
        return _error(f'cfem-sim play needs rclpy ({err}); install the ros extra')

    def warn(text):
        print(f'WARNING: {text}', file=sys.stderr)

    try:
        mapping = player.parse_remaps(remaps)
        count = player.play(recording, clock=clock, rate=rate, topics=topics, remaps=mapping,
                            wait=wait, delay=delay, log=warn)
    except CfemError as err:
        return _error(str(err))
    except ValueError as err:
        return _error(str(err))
    print(f'{recording}: {count} messages played')
    return EXIT_OK


def main(argv=None) -> int:
    """Run cfem-sim (SIGINT exits 130, SIGTERM 143; a running recording is finished first)."""
    previous = [signal.signal(s, exit_now) for s in (signal.SIGINT, signal.SIGTERM)]
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter('WARNING: %(message)s'))
    LOG.addHandler(handler)
    LOG.propagate = False
    try:
        args = build_parser().parse_args(argv)
        if args.command == 'check':
            return cmd_check(args.scenario)
        if args.command == 'info':
            return cmd_info(args.recording)
        if args.command == 'recover':
            return cmd_recover(args.broken, args.output)
        if args.command == 'plot':
            return cmd_plot(args.recording, args.output, args.metric, args.relative_to,
                            args.snapshots)
        if args.command == 'export':
            return cmd_export(args)
        if args.command == 'sweep':
            return cmd_sweep(args.sweep, args.output, workers=args.workers,
                             scheduler=args.scheduler, runs=args.runs, record=args.record,
                             csv=args.csv, method=args.method, design=args.design,
                             plan=args.plan, target_cov=args.cov)
        if args.command == 'fit':
            return cmd_fit(args.fit, args.output, threads=args.threads,
                           overwrite=args.overwrite)
        if args.command == 'report':
            return cmd_report(args.outdir, args.output, overwrite=args.overwrite)
        if args.command == 'rerun':
            return cmd_rerun(args.outdir, args.run, args.output)
        if args.command == 'summarize':
            return cmd_summarize(args.recordings, args.metrics, args.output,
                                 workers=args.workers, scheduler=args.scheduler, csv=args.csv,
                                 overwrite=args.overwrite)
        if args.command == 'compare':
            return cmd_compare(args.first, args.second, args.output, args.map)
        if args.command == 'play':
            return cmd_play(args.recording, clock=args.clock, rate=args.rate,
                            topics=args.topics, remaps=args.remap, wait=args.wait,
                            delay=args.delay)
        return cmd_run(args.scenario, args.output, rate=args.rate, duration=args.duration,
                       dt=args.dt, inputs=args.inputs, overwrite=args.overwrite,
                       max_samples=args.max_samples, max_gb=args.max_gb,
                       odometry=args.odometry)
    except Interrupted as stop:
        print(f'interrupted by {stop}', file=sys.stderr)
        return stop.exit_status
    except BrokenPipeError:
        return quiet_broken_pipe()
    finally:
        LOG.removeHandler(handler)
        signal.signal(signal.SIGINT, previous[0])
        signal.signal(signal.SIGTERM, previous[1])


if __name__ == '__main__':
    sys.exit(main())
