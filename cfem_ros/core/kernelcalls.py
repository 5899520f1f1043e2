# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The simulator's two compiled calls, and what their result codes mean.

``advance`` takes a simulator's steps until a target, a release time, a
limit or a release condition (``cpp/step.cpp``); ``locate`` takes one step
and locates in it the release conditions, stroke ends and contacts on the
step's own RK4 map (``cpp/events.cpp``). Both read and update the
simulator's state; ``engine.Simulator`` decides what follows.
"""

from __future__ import annotations

import math
from typing import Optional

from cfem_ros.core import kernel, sampling
from cfem_ros.core.releases import TRIGGER_CAUSES
from cfem_ros.core.sampling import NumericalFailure
import numpy as np

#: Constraint violation (m, or rad for rotation rows) beyond which a run is
#: declared diverged: a million times what the stabilized integration keeps.
DIVERGENCE_VIOLATION = 1e-3

#: Why a run failed when its state is no longer finite.
NOT_FINITE = 'the state is no longer finite (the system diverged)'

#: What ``kernel.advance`` gets for no sample grid.
_NO_GRID = np.zeros(3)
_NO_ROWS = np.empty((0, 0))


def diverged(violation: float) -> NumericalFailure:
    """Return the failure of a constraint violation beyond ``DIVERGENCE_VIOLATION``."""
    return NumericalFailure(f'constraint violation {violation:.3g} exceeds '
                            f'{DIVERGENCE_VIOLATION:g} (the system diverged; try a smaller dt)')


def kernel_error(code: int, value: float) -> Optional[Exception]:
    """
    Return the error a code of ``kernel.advance`` or ``kernel.locate`` stands for.

    None for a normal end; value is the violation (VIOLATION) or where the
    in-step search stopped (``kernel.locate``'s codes, those of the Python
    search: ``roots.brentq``'s errors).
    """
    if code == kernel.NOT_FINITE:
        return NumericalFailure(NOT_FINITE)
    if code == kernel.VIOLATION:
        return diverged(value)
    if code == kernel.SINGULAR:
        return NumericalFailure(sampling.SINGULAR)
    if code == kernel.LOADS_NOT_FINITE:
        return NumericalFailure(sampling.LOADS_NOT_FINITE)
    if code == kernel.NAN_VALUE:
        return ValueError('The function value at x=%f is NaN; solver cannot continue.' % value)
    if code == kernel.SAME_SIGNS:
        return ValueError('f(a) and f(b) must have different signs')
    if code == kernel.NO_CONVERGENCE:
        return RuntimeError('Failed to converge after %d iterations, value is %f'
                            % (kernel.CROSSING_MAXITER, value))
    return None


def advance(sim, t_target, due, limit, samples=None) -> int:
    """Take sim's steps in the kernel until a target, a release time, limit or a condition."""
    top = sim._topology
    rel = sim.releases
    info = sim._info
    info[:] = (sim.t, 0.0, sim.max_violation, kernel.REACHED, DIVERGENCE_VIOLATION, 0.0)
    grid, rows = (_NO_GRID, _NO_ROWS) if samples is None else (samples.state, samples.rows)
    try:
        kernel.advance(sim.y, info, t_target, due, limit, sim.dt, *top.kernel_args(sim),
                       sim.joints.joints_i, sim.joints.joints_f, rel.watch,
                       rel.watch_limits, rel.watch_lines, grid, sim._outputs_order, rows)
    except np.linalg.LinAlgError:
        info[3] = kernel.SINGULAR
    finally:
        sim.t = float(info[0])
        sim.steps += int(info[1])
        sim.max_violation = float(info[2])
    result = int(info[3])
    error = kernel_error(result, info[5])
    if error is not None:
        raise error
    return result


def locate(sim, y0, h):
    """
    Take the step of h from y0 and locate its release conditions and stroke ends.

    One call of ``kernel.locate``, the compiled form of ``Releases.crossing``
    and ``ScheduledLoads.crossing`` (the same bits). Returns y1 (the step's
    end), ys (the state at the s the step is cut at, if before h), the
    release crossing (s, joints, causes) or None and the stroke end
    (s, wrenches) or None.
    """
    rel = sim.releases
    y1, ys = np.empty_like(y0), np.empty_like(y0)
    info = np.empty(7)
    info[0] = sim._stage_violation
    joints = np.empty((len(rel.watch), 2), dtype=np.int64)
    wrenches = np.empty(sim._scheduled.count + len(sim._scheduled.pairs), dtype=np.int64)
    try:
        kernel.locate(y0, float(h), y1, ys, *sim._topology.kernel_args(sim),
                      sim.joints.joints_i, sim.joints.joints_f, rel.watch,
                      rel.watch_triggers, rel.watch_lines, joints, wrenches, info)
    except np.linalg.LinAlgError:
        info[1] = kernel.SINGULAR
    sim._stage_violation = float(info[0])
    code = int(info[1])
    if code != kernel.REACHED:
        raise kernel_error(code, float(info[2]))
    crossing = stroke = None
    if not math.isnan(info[3]):
        found = joints[:int(info[4])]
        crossing = (float(info[3]), found[:, 0].tolist(),
                    [TRIGGER_CAUSES[1 + col] for col in found[:, 1]])
    if not math.isnan(info[5]):
        stroke = (float(info[5]), wrenches[:int(info[6])].tolist())
    return y1, ys, crossing, stroke
