# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Offline runs: step a simulator over a sample grid, apply inputs, record."""

from __future__ import annotations

import logging
import math
from typing import Callable, Optional

from cfem_ros.core.engine.events import Status
from cfem_ros.core.native.kernel import SAMPLE
from cfem_ros.core.run.session import Session
from cfem_ros.recording import loadarrows, schema, viewframes
from cfem_ros.recording.container import encoder
import numpy as np


def run(sim, recorder, *, rate_hz: float, duration: float, inputs=(),
        log: Optional[logging.Logger] = None,
        progress: Optional[Callable[[float], None]] = None,
        progress_every: float = 1.0, interpolate_odometry: bool = True) -> bool:
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
        Called with the simulated time about every ``progress_every`` s of
        wall time, between kernel calls (a safe point to stop at by raising).
    progress_every : float
        s of wall time.
    interpolate_odometry : bool
        Odometry inputs: the cubic between messages, or extrapolated from
        the latest (``Session``).

    Returns
    -------
    bool
        False if the run ended before its duration: it failed, or its scenario
        stopped it (``sim.status``; ``sim.message`` says when and why).

    """
    log = log or logging.getLogger('cfem_ros')
    session = Session(sim, rate_hz=rate_hz, duration=duration,
                      outputs=[recorder] if recorder is not None else [], warn=log.warning,
                      interpolate_odometry=interpolate_odometry)
    for item in inputs:
        session.submit(item, check=False)
    session.run(progress, progress_every)
    # every end before the duration but a contact's (exit 3) is an exit 1: a failure or a
    # table's outside: stop; the recording says why it ends there
    if session.stopped and session.sim.status is not Status.CONTACT and recorder is not None:
        recorder.failed()
    return not session.stopped


#: Sample rates a run accepts, Hz: the node's ``rate_hz`` bounds.
RATE_RANGE = (0.01, 1e5)
#: Default bounds of a run's size: samples, and recording size in GB.
MAX_SAMPLES = 10_000_000
MAX_GB = 20.0


def expected_samples(rate_hz: float, duration: float) -> int:
    """Return the number of samples of a run: k / rate_hz for k = 0, 1, ... up to duration."""
    return int(math.floor(duration * rate_hz * (1 + 1e-12))) + 1


def estimate_bytes(model, samples: int) -> float:
    """
    Return about how many bytes a run of so many samples records.

    Per sample: a pose (7 float64) and a twist (6) per body and two wrenches
    (6) per joint (its axes and world axes), each a Message record (31
    bytes), CDR header and stamp (12), frame_id (about 16) and its index
    entry (16); a /tf message with a transform (7 float64, stamp, two
    frame names) per moving body and per view or chase frame
    (``viewframes``); and the load arrows (``arrows_bytes``).
    """
    doubles = SAMPLE.BODY * len(model.bodies) + 2 * SAMPLE.JOINT * len(model.joints)
    messages = 2 * len(model.bodies) + 2 * len(model.joints)
    moving = sum(not body.fixed for body in model.bodies)
    views = viewframes.of_model(model)
    frames = moving + (len(views.names) if views is not None else 0)
    tf = (31 + 8 + 16 + frames * (8 * 7 + 8 + 32)) if moving else 0
    return float(samples) * (8 * doubles + (31 + 12 + 16 + 16) * messages + tf
                             + arrows_bytes(model))


def arrows_bytes(model, namespace: str = '/cfem') -> int:
    """
    Return about the bytes of a sample's ``load_markers`` message, record and index entry.

    One arrow per joint, scheduled wrench, sway brace and aero table (a
    reaction on a moving carrier not counted), encoded as a recording
    encodes them; none without joints or applied loads (nothing is drawn).
    """
    bodies = model.bodies
    zero, one = np.zeros(3), np.ones(3)
    arrows = [('joint_loads', k, joint.name, 'joint', joint.name, zero, one)
              for k, joint in enumerate(model.joints)]
    applied = ([(bodies[w.body].name, w.name) for w in model.wrenches]
               + [(bodies[b.body].name, b.name) for b in model.braces]
               + [(bodies[a.body].name, 'aero') for a in model.aero])
    arrows += [('applied_loads', j, body, 'load', source, zero, one)
               for j, (body, source) in enumerate(applied)]
    if not arrows:
        return 0
    drawing = loadarrows.LoadArrows(model, namespace, ())
    message, _ = drawing.array({'sec': 0, 'nanosec': 0}, arrows, 1.0)
    return len(encoder(schema.LOAD_MARKERS.msgtype)(message)) + 31 + 16
