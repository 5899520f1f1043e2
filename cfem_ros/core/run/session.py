# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
One run of a simulator on its sample grid, fed with inputs, paced by anyone.

``Session`` is the stepping logic shared by ``cfem-sim run`` and the ROS
node, so that a recording of the node replays offline to the same numbers:

- samples lie on k / rate_hz, inputs at their own times; these are the only
  points where integration steps are cut (with the engine's release times);
- a sample at time t shows the state and loads before any input at t takes
  effect (the node cannot do otherwise: when a message arrives, the sample
  at the current time has already been published); but odometry known at
  t = 0 replaces the scenario's stand-in motion before the first sample;
- ``advance(limit)`` walks that fixed sequence of steps and stops at the
  last step ending at or before ``limit``: whoever paces the run (a wall
  clock, ``/clock``, nothing) changes when steps are taken, never which;
- an input is recorded at the simulated time it took effect, so replaying
  the recording applies it at that same time;
- odometry submitted ahead of its time is also made known to the simulator
  at once, so that the body moves on the cubic from its previous message to
  it (``interpolate_odometry``); a replay knows every message from the start,
  the node waits for the next one, and both step through the same cubics;
- a numerical failure (in a step, or in a sample's outputs, the first one
  included) sets ``sim.status`` to ``Status.FAILED`` and ends the run: nothing
  non-finite reaches an output, and what was taken before stays.

Outputs are ``Sink``s: ``sample()``, ``events()`` and ``received(item, t)``,
and, for a ``RowSink`` (``takes_rows``), ``sample_rows()`` and
``took_rows(times)``; ``recording.StateRecorder`` is a row sink, the node's
publishers are a sink. This module never imports rclpy.
"""

from __future__ import annotations

import logging
import math
import time
from typing import Callable, ClassVar, Optional, Protocol, Sequence

from cfem_ros.core.engine.events import Status
from cfem_ros.core.engine.sampling import NumericalFailure, SampleGrid
from cfem_ros.core.errors import ArgumentError
from cfem_ros.core.run.inputs import (apply_input, Input, input_topic, InputKind, InputQueue,
                                      validate_input)
import numpy as np

LOG = logging.getLogger('cfem_ros')

#: Samples counted per kernel call when no output takes rows (so that
#: progress is still reported on long runs).
COUNT_ONLY = 1000


class Sink(Protocol):
    """
    A session's output: what it is given of the run, in the run's order.

    A class declares itself a sink by deriving from this one (and a row
    sink from ``RowSink``): ``takes_rows`` tells the session which it is.
    """

    #: True for a ``RowSink``: the kernel may write its samples' rows.
    takes_rows: ClassVar[bool] = False

    def received(self, item: Input, t: float) -> None:
        """Take an input as it takes effect (or is refused) at simulated time t."""

    def events(self) -> None:
        """Take the simulator's events not yet taken."""

    def sample(self) -> None:
        """Take a sample of the simulator's current state."""


class RowSink(Sink, Protocol):
    """A sink whose samples the kernel writes, many at a time (``Session.run``)."""

    takes_rows: ClassVar[bool] = True

    def sample_rows(self) -> np.ndarray:
        """Return rows (k, ``Simulator.outputs`` size) for the next samples."""

    def took_rows(self, times: np.ndarray) -> None:
        """Take the samples at these simulated times (s), in the first rows given."""


class Session:
    """
    Step a simulator from t = 0 to ``duration`` over the sample grid.

    Parameters
    ----------
    sim : Simulator
        The simulation, at t = 0.
    rate_hz : float
        Sample rate; sample k is taken at exactly k / rate_hz s.
    duration : float
        Where the run ends, s; ``math.inf`` runs until the caller stops.
    outputs : sequence of Sink
        Each gets ``received(item, t)`` for every input as it takes effect (or is
        refused), then ``events()`` and ``sample()`` at every sample time.
    warn : callable, optional
        Takes the message of an input that could not be applied; the
        ``cfem_ros`` logger's warning by default.
    interpolate_odometry : bool
        An odometry input submitted ahead of its time is made known to the
        simulator at once (``InputQueue``), so that the body
        moves on the cubic from its previous message to it; False: each
        message is extrapolated from until the next takes effect.

    """

    def __init__(self, sim, *, rate_hz: float, duration: float = math.inf,
                 outputs: Sequence[Sink] = (),
                 warn: Optional[Callable[[str], None]] = None,
                 interpolate_odometry: bool = True):
        if not (math.isfinite(rate_hz) and rate_hz > 0):
            raise ArgumentError(f'rate_hz is {rate_hz!r}; expected a rate > 0')
        self.sim = sim
        self.rate_hz = float(rate_hz)
        self.duration = float(duration)
        self.outputs = list(outputs)
        self.warn = warn or LOG.warning
        self.samples = 0
        self.started = False
        self.inputs = InputQueue(sim, interpolate_odometry=interpolate_odometry)

    @property
    def next_sample_time(self) -> float:
        """Return the simulated time of the next sample, s."""
        return self.samples / self.rate_hz

    @property
    def failed(self) -> bool:
        """Tell whether the run failed, its status ``FAILED``; ``sim.message`` says why."""
        return self.sim.status is Status.FAILED

    @property
    def stopped(self) -> bool:
        """Tell whether the run ended before its duration: it failed or its scenario stops it."""
        return self.sim.status is not Status.RUNNING

    @property
    def finished(self) -> bool:
        """Tell whether the run reached its duration or stopped."""
        return self.stopped or self.sim.t >= self.duration

    def start(self):
        """
        Take the first sample, then apply the inputs due at t = 0.

        Odometry due at t = 0 is applied before the first sample: it is the
        carrier's measured motion at t = 0, which the scenario's ``motion``
        only stands in for until then, so the first sample shows it (and
        the loads it causes) as every later one does.
        """
        if self.started:
            return
        self.started = True
        self._apply_due(InputKind.ODOM)
        if not self.stopped:
            self._sample()
        if not self.stopped:
            self._apply_due()

    def submit(self, item: Input, *, check: bool = True):
        """
        Take an input: apply it now, or at its time if that is still ahead.

        An input whose ``time`` is None or already past takes effect at the
        current simulated time (before the run starts: at t = 0, after the
        first sample). Every input reaches the outputs, as received,
        when it takes effect or is refused.

        Parameters
        ----------
        item : Input
            The input.
        check : bool
            Refuse an input held for later at once if it can never apply
            (unknown frame or body, non-finite numbers); without it, it is
            refused (with a warning) when its time comes.

        Raises
        ------
        ValueError
            If it is refused now; nothing changes in the simulation.

        """
        if not self.started:
            self.inputs.hold(item, item.time or 0.0)
            return
        if item.time is not None and item.time > self.sim.t:
            if check:
                try:
                    validate_input(self.sim, item)
                except ValueError:
                    self._record(item)
                    raise
            self.inputs.hold(item, item.time)
            return
        self._apply(item)

    def advance(self, limit: float, land: bool = False):
        """
        Run on up to simulated time ``limit`` (never beyond it, nor the duration).

        Samples and inputs met on the way are taken and applied; the state
        is left at the last integration step that ends at or before limit,
        or, with ``land``, at limit itself (the last step cut to end there,
        as a sample time cuts one).
        """
        if not self.started:
            self.start()
        sim = self.sim
        while not self.finished and sim.t < limit:
            target = min(self.next_sample_time, self.duration)
            if self.inputs.next_time is not None:
                target = min(target, self.inputs.next_time)
            if land:
                target = min(target, limit)
            ok = sim.advance_to(max(target, sim.t), limit=limit, release_at_end=False)
            if not ok:
                self._emit_events()
                return
            if sim.t < target:
                return
            if sim.t >= self.next_sample_time:
                self._sample()
                if self.stopped:
                    return
            self._release_due()
            if sim.t >= self.duration:
                self._emit_events()

    def run(self, progress: Optional[Callable[[float], None]] = None,
            progress_every: float = 1.0):
        """
        Run to the duration unpaced, the kernel taking the samples on its way.

        The same steps, samples, inputs and events as ``advance`` over
        every sample time, in far fewer calls from Python: a ``RowSink``
        (as ``StateRecorder``) gets its rows filled by the kernel, a
        buffer (``recording.BATCH_CHUNKS`` chunks) at a time. With any
        other output, or more than one, this is ``advance`` sample by
        sample. ``progress`` is called with the simulated time about every
        ``progress_every`` s of wall time: with it, each kernel call is
        limited to the simulated span that takes about half that (measured
        as the run goes), which changes when Python is entered, not which
        steps are taken.
        """
        if not math.isfinite(self.duration):
            raise ArgumentError('run() needs a finite duration')
        self.start()
        sink = self.outputs[0] if len(self.outputs) == 1 else None
        if len(self.outputs) > 1 or (sink is not None and not sink.takes_rows):
            return self._run_per_sample(progress, progress_every)
        sim = self.sim
        grid = SampleGrid(self.rate_hz)
        counting = np.empty((COUNT_ONLY, 0))
        wall = time.monotonic()
        # simulated s per kernel call: a first guess, then what takes progress_every / 2
        span = math.inf if progress is None else 100 * sim.dt
        while not self.stopped and (sim.t < self.duration or self.next_sample_time <= sim.t):
            target = self.duration
            if self.inputs.next_time is not None:
                target = max(min(target, self.inputs.next_time), sim.t)
            grid.reset(self.samples, counting if sink is None else sink.sample_rows())
            called, before = time.monotonic(), sim.t
            ok = sim.advance_to(target, limit=before + span, samples=grid,
                                release_at_end=False)
            if progress is not None and sim.t > before:
                spent = max(time.monotonic() - called, 1e-6)
                span = max(0.5 * progress_every * (sim.t - before) / spent, 10 * sim.dt)
            if grid.taken:
                if sink is not None:
                    sink.took_rows(np.arange(self.samples, self.samples + grid.taken)
                                   / self.rate_hz)
                self.samples += grid.taken
            self._emit_events()
            if not ok:
                return
            if self.next_sample_time > sim.t:   # inputs at t act after the sample at t
                self._release_due()
            if progress is not None and time.monotonic() - wall >= progress_every:
                wall = time.monotonic()
                progress(sim.t)

    def _run_per_sample(self, progress, progress_every):
        wall = time.monotonic()
        while not self.finished:
            self.advance(self.next_sample_time)
            if progress is not None and time.monotonic() - wall >= progress_every:
                wall = time.monotonic()
                progress(self.sim.t)

    # ------------------------------------------------------------- internals

    def _release_due(self):
        """After the samples at t: the inputs at t, then the release times at t."""
        self._apply_due()
        if self.sim.release_due():
            self._emit_events()

    def _apply_due(self, kind: Optional[InputKind] = None):
        for item in self.inputs.due(self.sim.t, kind):
            try:
                self._apply(item)
            except ValueError as err:
                self.warn(f'{input_topic(item)}: input for t = {item.time:.9g} s '
                          f'not applied: {err}')

    def _record(self, item: Input):
        for sink in self.outputs:
            sink.received(item, self.sim.t)

    def _apply(self, item: Input):
        self._record(item)
        apply_input(self.sim, item)
        if item.kind is InputKind.RELEASE:
            self._emit_events()

    def _emit_events(self):
        for sink in self.outputs:
            sink.events()

    def _sample(self):
        """Take a sample; a numerical failure in its outputs fails the run instead."""
        self._emit_events()
        try:
            for sink in self.outputs:
                sink.sample()
        except NumericalFailure as err:
            self.sim.fail(str(err), err.failure)
            self._emit_events()
            return
        self.samples += 1
