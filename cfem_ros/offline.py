# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Offline runs: step a simulator over a sample grid, apply inputs, record."""

from __future__ import annotations

import logging
import math
import time
from typing import Callable, Optional

from cfem_ros.inputs import apply_input


def sample_times(rate_hz: float, duration: float) -> int:
    """Count the samples after t = 0 on the grid k / rate_hz up to duration."""
    return int(math.floor(duration * rate_hz * (1.0 + 1e-12)))


def run(sim, recorder, *, rate_hz: float, duration: float, inputs=(),
        log: Optional[logging.Logger] = None,
        progress: Optional[Callable[[float], None]] = None) -> bool:
    """
    Run sim to duration, recording a sample at every multiple of 1/rate_hz.

    Parameters
    ----------
    sim : Simulator
        The simulation, at t = 0.
    recorder : StateRecorder or None
        Where samples, inputs and events go; None records nothing.
    rate_hz : float
        Sample rate, Hz; sample k is at exactly k / rate_hz s.
    duration : float
        s.
    inputs : sequence of Input
        Applied at their times; an input at or before a sample time is applied
        before that sample is taken. A bad input is skipped with a warning.
    log : logging.Logger, optional
        Where those warnings go.
    progress : callable, optional
        Called now and then with the simulated time.

    Returns
    -------
    bool
        False if the run failed (``sim.message`` says when and why).

    """
    log = log or logging.getLogger('cfem_ros')
    pending = list(inputs)
    cursor = 0

    def feed(t_limit):
        nonlocal cursor
        while cursor < len(pending) and pending[cursor].time <= t_limit:
            item = pending[cursor]
            cursor += 1
            if not sim.advance_to(item.time):
                return False
            if recorder is not None:
                if item.kind == 'wrench':
                    recorder.input_wrench(item.target, item.force, item.torque,
                                          item.frame_id, item.stamp_ns)
                else:
                    recorder.input_release(item.target, item.stamp_ns)
            try:
                apply_input(sim, item)
            except ValueError as err:
                topic = 'release' if item.kind == 'release' else f'bodies/{item.target}/wrench'
                log.warning('input on %s at t = %.9g s not applied: %s', topic, item.time, err)
        return True

    def take_sample():
        if recorder is not None:
            recorder.events()
            recorder.sample()

    n_samples = sample_times(rate_hz, duration)
    if not feed(0.0):
        return False
    take_sample()
    wall = time.monotonic()
    for k in range(1, n_samples + 1):
        t_k = k / rate_hz
        if not (feed(t_k) and sim.advance_to(t_k)):
            if recorder is not None:
                recorder.events()
            return False
        take_sample()
        if progress is not None and time.monotonic() - wall > 1.0:
            wall = time.monotonic()
            progress(sim.t)
    ok = feed(duration) and sim.advance_to(duration)
    if recorder is not None:
        recorder.events()
    return ok
