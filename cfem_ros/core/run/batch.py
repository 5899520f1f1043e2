# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Many independent copies of one model in one call, for sweeps.

Each copy is a full ``Simulator`` (its own state, loads and releases, found
exactly as in a single run), built from one parsed model; the copies are
spread over threads, which run in parallel because the compiled step loop
releases the GIL. A copy differs from the model by its initial state and
by constant external wrenches::

    from cfem_ros import load_scenario
    from cfem_ros.core.run import batch
    model = load_scenario('config/store_separation.yaml')
    results = batch.run(model, [{'loads': {'store': ([0, 0, f], [0, 0, 0])}}
                                for f in np.linspace(0, 2e4, 1000)])
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
import logging
import os
from typing import Optional, Sequence

from cfem_ros.core.engine import startcheck
from cfem_ros.core.engine.events import Status
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import ArgumentError
import numpy as np

__all__ = ['Result', 'run']

LOG = logging.getLogger('cfem_ros')


@dataclass
class Result:
    """
    The end of one copy's run.

    Attributes
    ----------
    t : float
        Where it stopped, s (the duration unless it failed).
    y : ndarray, shape (13 n,)
        Its final state (``Simulator.y``).
    events : list of dict
        Its releases (and contacts).
    status : Status
        ``OK`` if the copy ran to its duration, ``CONTACT`` if it stopped at
        a watched contact, ``AERO_OUTSIDE`` if it left a table that says
        ``outside: stop``, ``FAILED`` if it failed.
    message : str
        Why it failed, with the time ('' if ok).
    steps : int
        RK4 steps taken.

    """

    t: float
    y: np.ndarray
    events: list
    status: Status
    message: str
    steps: int


def _copy(model, spec: dict, duration: float) -> Result:
    sim = Simulator(model, logger=spec.get('logger'))
    if 'y0' in spec:
        y0 = np.asarray(spec['y0'], dtype=float)
        if y0.shape != sim.y.shape:
            raise ArgumentError(f'y0 has shape {y0.shape}; expected {sim.y.shape}')
        sim.set_state(y0, start=True)   # strokes, contacts and aero watched from there
    for body, (force, torque, *axes) in spec.get('loads', {}).items():
        sim.set_wrench(body, force, torque, body_axes=bool(axes and axes[0]))
    ok = sim.advance_to(duration)
    status = Status.OK if ok else sim.status   # FAILED, or the scenario's stop
    return Result(sim.t, sim.y, sim.events, status, sim.message, sim.steps)


def run(model, copies: Sequence[dict], *, duration: Optional[float] = None,
        workers: Optional[int] = None) -> list:
    """
    Run copies of a model to ``duration`` (the model's by default).

    Parameters
    ----------
    model : Model
        Parsed once (``load_scenario``), shared by every copy.
    copies : sequence of dict
        One per copy, each with optional keys ``y0`` (the initial state,
        ``Simulator.y`` layout; its velocities are used as given) and
        ``loads`` ({body: (force, torque[, body_axes])}, held constant).
    duration : float, optional
        Simulated seconds per copy.
    workers : int, optional
        Threads; the number of CPUs by default.

    Returns
    -------
    list of Result
        In the order of ``copies``. A copy that fails keeps its last good
        state, with ``status`` ``Status.FAILED``; the others are unaffected.

    Raises
    ------
    startcheck.CannotStart
        If ``cfem-sim check`` refuses the model (its line; no copy is run).

    """
    duration = model.duration if duration is None else float(duration)
    # what cfem-sim check refuses is refused here, in its words, before any copy runs
    startcheck.refuse_start(Simulator(model, logger=startcheck.QUIET), f'scenario {model.name!r}')
    workers = workers or os.cpu_count() or 1
    if workers == 1:
        return [_copy(model, spec, duration) for spec in copies]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(lambda spec: _copy(model, spec, duration), copies))
