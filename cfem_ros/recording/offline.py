# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Offline runs: step a simulator over a sample grid, apply inputs, record."""

from __future__ import annotations

import logging
from typing import Callable, Optional

from cfem_ros.core.session import Session


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
        Applied at their times; an input at a sample time takes effect after
        that sample is taken. A bad input is skipped with a warning.
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
    session = Session(sim, rate_hz=rate_hz, duration=duration,
                      outputs=[recorder] if recorder is not None else [], warn=log.warning)
    for item in inputs:
        session.submit(item, check=False)
    session.run(progress)
    if session.failed and hasattr(recorder, 'failed'):
        recorder.failed()   # the recording says why it ends there
    return not session.failed
