# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""``cfem-sim run`` (a scenario, recorded) and ``cfem-sim play`` (a recording, over ROS 2)."""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import signal
import sys
import time
from typing import Optional

from cfem_ros.cli.common import (cannot_start, error, EXIT_CONTACT, EXIT_FAILED, EXIT_OK,
                                 output_refused, same_file, signals_to, table_refused, vec, warn,
                                 warnings_held)
from cfem_ros.core import rotations
from cfem_ros.core.engine.events import describe_event, Event, Status
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import CfemError, InputError
from cfem_ros.core.fileio.instants import instant_ns, MAX_SECONDS
from cfem_ros.core.model.joints import Release
from cfem_ros.core.scenario.parse import load_scenario
from cfem_ros.interrupts import Interrupted
from cfem_ros.recording import offline
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.errors import OutputError
from cfem_ros.recording.recorder import run_metadata, StateRecorder
import numpy as np


def add_run_parser(sub):
    """Add ``cfem-sim run`` to the command line's subparsers."""
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
    run.add_argument('--start-time', metavar='ISO8601',
                     help="the date and time of simulated t = 0 in the recording's stamps, "
                     'with its UTC offset, e.g. 2026-03-14T09:30:00Z (default: the '
                     "scenario's start_time, else 1970-01-01T00:00:00Z, stamp 0)")
    run.add_argument('--layout', metavar='FILE.json',
                     help='also write a Foxglove/Lichtblick layout for the recording: the '
                     "carrier's and the store's z-up views, the store's position and loads, "
                     'the events')
    run.add_argument('--overwrite', action='store_true',
                     help='replace OUT (and the layout) if it exists (once the new recording '
                     'is complete)')
    run.add_argument('--max-samples', type=float, default=offline.MAX_SAMPLES, metavar='N',
                     help='refuse a run of more samples (default %(default).0f)')
    run.add_argument('--max-gb', type=float, default=offline.MAX_GB, metavar='GB',
                     help='refuse a run whose recording would exceed this size '
                     '(default %(default)g GB)')
    run.set_defaults(func=run_command)


def add_play_parser(sub):
    """Add ``cfem-sim play`` to the command line's subparsers."""
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
    play.set_defaults(func=play_command)


@dataclasses.dataclass
class _Run:
    """A run about to be recorded, and what its recording left."""

    model: object
    sim: Simulator
    replay: list
    interpolate: bool
    #: The stamp of simulated time 0, ns since 1970-01-01T00:00:00Z.
    start_ns: int = 0
    recorder: Optional[Recorder] = None
    state: Optional[StateRecorder] = None
    ok: bool = True
    #: The signal that stopped the run, if one did.
    stop: Optional[int] = None

    @property
    def samples(self) -> int:
        """Return the samples recorded so far."""
        return self.state.samples if self.state is not None else 0


def run_command(args: argparse.Namespace) -> int:
    """
    Run a scenario offline and record it; exit status 0, 1, 2, 3 (contact), 130 or 143.

    ``args.odometry`` ('interpolate' or 'extrapolate') says how replayed
    odometry drives a kinematic body; None: as the node that recorded the
    inputs did (its ``interpolate_odometry``), else interpolate.

    The recording is written to a partial file next to the output and moved
    onto it when finished, also after SIGINT (130) or SIGTERM (143), which
    stop the run between two chunks.
    """
    low, high = offline.RATE_RANGE
    if not (math.isfinite(args.rate) and low <= args.rate <= high):
        return error(f'--rate: is {args.rate:g}; expected a sample rate from {low:g} to '
                     f'{high:g} Hz')
    refused = _output_refused(args)
    if refused:
        return error(refused)
    try:
        with warnings_held():   # a refused run says only its ERROR line
            run = _prepare(args)
    except CfemError as err:
        return error(str(err))
    if args.layout is not None:
        from cfem_ros.recording import viewerlayout
        try:
            viewerlayout.write(run.model, args.layout)
        except OSError as err:
            return error(f'--layout {args.layout}: cannot write ({err.strerror})')
    started = time.monotonic()
    failure = _record(args, run)
    if failure is not None:
        return failure
    if run.stop is not None:
        print(f'{signal.Signals(run.stop).name}: stopped at t = {run.sim.t:.9g} s; '
              f'{run.samples} samples ({run.recorder.message_count} messages) in '
              f'{args.output}, complete', file=sys.stderr)
        return 128 + run.stop
    _print_run(run, time.monotonic() - started)
    print(f'recording: {args.output} ({run.recorder.message_count} messages)')
    if args.layout is not None:
        print(f'layout: {args.layout} (Foxglove/Lichtblick: Layouts > Import from file)')
    sim = run.sim
    if sim.status is Status.CONTACT:
        print(f'stopped: {sim.message}; the recording holds everything up to then',
              file=sys.stderr)
        return EXIT_CONTACT
    if not run.ok:
        print(f'ERROR: the run failed {sim.message}; the recording holds everything '
              f'up to t = {sim.t:.9g} s', file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _output_refused(args) -> Optional[str]:
    """Return why -o cannot receive the run's recording (None if it can)."""
    refused = output_refused(args.output, overwrite=True)
    if refused:
        return refused
    if same_file(args.output, args.scenario):
        return f'-o {args.output}: is the scenario file itself; choose another output'
    if args.inputs and same_file(args.output, args.inputs):
        return f'-o {args.output}: is the --inputs log itself; choose another output'
    if args.layout is not None:
        for path, what in ((args.output, '-o'), (args.scenario, 'the scenario'),
                           (args.inputs, '--inputs')):
            if path and same_file(args.layout, path):
                return f'--layout {args.layout}: is {what} {path} too; choose another file'
        refused = table_refused(args.layout, args.overwrite, 'a layout')
        if refused:
            return f'--layout {refused}'
    return None


def _prepare(args) -> _Run:
    """Load the scenario and the inputs to replay, and check the run; CfemError if refused."""
    model = load_scenario(args.scenario, duration=args.duration, dt=args.dt)
    start_ns = _start_ns(args.start_time, model)
    too_large = _check_run_size(model, args.rate, args.max_samples, args.max_gb)
    if too_large:
        raise InputError(too_large)
    replay = []
    interpolate = args.odometry != 'extrapolate'
    if args.inputs:
        # mcap's reader only to replay
        from cfem_ros.recording.replay import read_inputs, recorded_interpolation
        replay = read_inputs(args.inputs)
        if args.odometry is None:
            interpolate = recorded_interpolation(args.inputs) is not False
        late = [item for item in replay if item.time > model.duration]
        if late:
            print(f'warning: {len(late)} input(s) of {args.inputs} come after the run ends at '
                  f't = {model.duration:g} s (the first at t = {late[0].time:.6g} s) and '
                  'are not replayed; give a longer --duration to replay them',
                  file=sys.stderr)
    if os.path.lexists(args.output) and not args.overwrite:
        raise InputError(f'{args.output}: already exists; pass --overwrite to replace it')
    sim = Simulator(model)
    from cfem_ros.core.engine.startcheck import start_problems
    errors, _ = start_problems(sim)   # what check refuses, run refuses (exit 2)
    if errors:
        raise InputError(cannot_start(args.scenario, errors))
    return _Run(model, sim, replay, interpolate, start_ns=start_ns)


def _start_ns(text: Optional[str], model) -> int:
    """Return the stamp of t = 0: --start-time's, else the scenario's; InputError if refused."""
    if text is None:
        return model.start_ns
    try:
        start_ns = instant_ns(text)
    except ValueError as err:
        raise InputError(f'--start-time: {err}') from None
    if start_ns + model.duration * 1e9 > MAX_SECONDS * 1e9:
        raise InputError(f'--start-time: is {text}, and the run ends {model.duration:g} s '
                         'later, past 2038-01-19T03:14:07Z (the last second a ROS stamp '
                         'holds); expected an earlier start or a shorter --duration')
    return start_ns


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


def _record(args, run: _Run) -> Optional[int]:
    """
    Record the run into args.output; return an exit status if it could not be.

    SIGINT and SIGTERM stop the run at the next chunk (``run.stop``); the
    recording is finished, and moved onto the output, on the way out.
    """
    interactive = sys.stderr.isatty()
    stop = []

    def hold(signum, frame):   # while recording: stop at the next safe point
        stop.append(signum)

    def progress(t):
        if stop:
            raise Interrupted(stop[0])
        if interactive:
            print(f'\r  t = {t:.3f} / {run.model.duration:g} s', end='', file=sys.stderr)

    with signals_to(hold):
        try:
            with Recorder(args.output, overwrite=args.overwrite, atomic=True,
                          metadata=run_metadata(run.model, args.scenario, args.rate,
                                                run.start_ns)) as run.recorder:
                try:
                    if stop:
                        raise Interrupted(stop[0])
                    run.state = StateRecorder(run.recorder, run.sim, start_ns=run.start_ns)
                    run.ok = offline.run(run.sim, run.state, rate_hz=args.rate,
                                         duration=run.model.duration, inputs=run.replay,
                                         progress=progress, progress_every=0.2,
                                         interpolate_odometry=run.interpolate)
                except Interrupted:
                    pass   # the recording is finished (and moved onto output) on the way out
        except OutputError as err:   # a full disk: the run stopped there, nothing half-written
            print(f'ERROR: the recording failed at t = {run.sim.t:.9g} s ({run.samples} '
                  f'samples taken): {err}', file=sys.stderr)
            return EXIT_FAILED
        except CfemError as err:
            return error(str(err))
    if interactive:
        print('\r' + ' ' * 40 + '\r', end='', file=sys.stderr)
    run.stop = stop[0] if stop else None
    return None


def _print_run(run: _Run, wall: float):
    """Print how long the run took, its events and its final state."""
    sim = run.sim
    print(f'{run.model.name}: {sim.t:.9g} s simulated in {sim.steps} steps, '
          f'{wall:.3g} s wall ({sim.t / wall if wall > 0 else float("inf"):.3g}x real time)')
    for event in sim.events:
        print(describe_event(event))
    if not any(e['event'] == Event.RELEASE for e in sim.events):
        print(_no_release(run.model, bool(run.replay)))
    print_state(sim)


def _no_release(model, replayed: bool) -> str:
    """Return the line of a run that released nothing: why, and what would release."""
    if not model.joints:
        return 'no joint released: the scenario has no joint (every body free from t = 0)'
    waiting = [j.name for j in model.joints if j.release == Release()]
    if not waiting:
        return 'no joint released (no release condition was met)'
    names = ', '.join(waiting[:6]) + (f' and {len(waiting) - 6} more' if len(waiting) > 6
                                      else '')
    logged = 'none in the --inputs log took effect' if replayed else 'none was given'
    return (f'no joint released: {names} have no release condition and open only on a '
            f'release command ({logged}); give --inputs LOG.mcap with release commands (the '
            'examples ship theirs in config/inputs/), or a release: time in the scenario')


def print_state(sim):
    """Print each moving body's pose and twist at the simulator's time."""
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
        attitude = f'{vec(rpy[i])} deg' if rotation[i] else 'undefined (no finite attitude)'
        print(f'  {body.name}: CG {vec(position[i])} m, roll/pitch/yaw {attitude}, '
              f'velocity {vec(velocity[i])} m/s (world), '
              f'rates {vec(rates[i])} deg/s (body)')


def play_command(args: argparse.Namespace) -> int:
    """Publish a recording's messages over ROS 2; exit status 0, or 2 for bad input."""
    if not (math.isfinite(args.rate) and args.rate > 0.0):
        return error(f'--rate is {args.rate!r}; expected a playback speed > 0 (1: real time)')
    for name, value in (('--wait', args.wait), ('--delay', args.delay)):
        if not (math.isfinite(value) and value >= 0.0):
            return error(f'{name} is {value!r}; expected seconds >= 0')
    try:
        from cfem_ros.ros import player
    except ImportError as err:
        return error(f'cfem-sim play needs rclpy ({err}); install the ros extra')
    try:
        mapping = player.parse_remaps(args.remap)
        count = player.play(args.recording, clock=args.clock, rate=args.rate,
                            topics=args.topics, remaps=mapping, wait=args.wait,
                            delay=args.delay, log=warn)
    except CfemError as err:
        return error(str(err))
    except ValueError as err:
        return error(str(err))
    print(f'{args.recording}: {count} messages played')
    return EXIT_OK
