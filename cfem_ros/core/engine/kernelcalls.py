# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The simulator's two compiled calls, and what their result codes mean.

``advance`` takes steps until a target, a release time, a limit or a
release condition (``cpp/step.cpp``); ``locate`` takes one step and locates
in it the release conditions, stroke ends and contacts on the step's own
RK4 map (``cpp/events.cpp``). Both take the topology's ``kernel.System``
and the state; ``engine.Simulator`` keeps the time and decides what follows.
"""

from __future__ import annotations

import math
from typing import NamedTuple, Optional

from cfem_ros.core.engine import sampling
from cfem_ros.core.engine.events import Failure

from cfem_ros.core.engine.releases import TRIGGER_CAUSES
from cfem_ros.core.engine.sampling import NumericalFailure
from cfem_ros.core.native import kernel
from cfem_ros.core.native.kernel import ADVANCE_INFO, LOCATE_INFO
import numpy as np

#: Constraint violation (m, or rad for rotation rows) beyond which a run is
#: declared diverged: a million times what the stabilized integration keeps.
DIVERGENCE_VIOLATION = 1e-3

#: Why a run failed when its state is no longer finite.
NOT_FINITE = 'the state is no longer finite (the system diverged)'

#: The advice a diverged run's message ends with (``diverged``); a caller that knows a
#: likelier cause replaces it (``ros.stamps.divergence_advice``).
SMALLER_DT = '; try a smaller dt'

#: What ``kernel.advance`` gets for no sample grid.
_NO_GRID = np.zeros(3)
_NO_ROWS = np.empty((0, 0))


class Advanced(NamedTuple):
    """Where a call of ``advance`` left the run."""

    #: ``kernel.REACHED``, ``CONDITION`` or ``ROWS_FULL`` (the failures raise).
    result: int
    #: The time reached, s.
    t: float
    #: Steps taken.
    steps: int
    #: The largest constraint violation so far (m, or rad).
    violation: float
    #: Why the run failed (None if it did not): raise it once the above are kept.
    error: Optional[NumericalFailure]


def diverged(violation: float) -> NumericalFailure:
    """Return the failure of a constraint violation beyond ``DIVERGENCE_VIOLATION``."""
    return NumericalFailure(f'constraint violation {violation:.3g} exceeds '
                            f'{DIVERGENCE_VIOLATION:g} (the system diverged{SMALLER_DT})',
                            Failure.DIVERGED)


def kernel_error(code: int, value: float) -> Optional[NumericalFailure]:
    """
    Return the failure a code of ``kernel.advance`` or ``kernel.locate`` stands for.

    None for a normal end; value is the violation (VIOLATION) or where in
    the step the search for a crossing stopped, s (``kernel.locate``'s
    search codes).
    """
    if code == kernel.NOT_FINITE:
        return NumericalFailure(NOT_FINITE, Failure.NOT_FINITE)
    if code == kernel.VIOLATION:
        return diverged(value)
    if code == kernel.SINGULAR:
        return NumericalFailure(sampling.SINGULAR, Failure.SINGULAR)
    if code == kernel.LOADS_NOT_FINITE:
        return NumericalFailure(sampling.LOADS_NOT_FINITE,
                                Failure.LOADS_NOT_FINITE)
    if code == kernel.NAN_VALUE:
        return NumericalFailure(f'a release condition or stroke is not a number at '
                                f'{value:.9g} s into the step, where its crossing was sought')
    if code == kernel.SAME_SIGNS:
        return NumericalFailure('a release condition or stroke reached at the end of a step '
                                'is not reached at its start, nor crossed in between (the '
                                'condition is not continuous over the step)')
    if code == kernel.NO_CONVERGENCE:
        return NumericalFailure(f'the crossing of a release condition or stroke was not found '
                                f'in {kernel.CROSSING_MAXITER} iterations (stopped at '
                                f'{value:.9g} s into the step)')
    return None


def advance(system, y: np.ndarray, info: np.ndarray, t: float, violation: float,
            t_target: float, due: float, limit: float, dt: float, samples=None) -> Advanced:
    """
    Take steps of y (in place) from time t until a target, a release time, limit or a condition.

    ``info`` is a scratch array of ``ADVANCE_INFO.WIDTH`` numbers; ``samples``
    a ``sampling.SampleGrid`` whose samples are taken on the way, or None.
    """
    info[_T], info[_STEPS], info[_VIOLATION] = t, 0.0, violation
    info[_RESULT], info[_DIVERGENCE], info[_VALUE] = kernel.REACHED, DIVERGENCE_VIOLATION, 0.0
    grid, rows = (_NO_GRID, _NO_ROWS) if samples is None else (samples.state, samples.rows)
    kernel.advance(system, y, info, t_target, due, limit, dt, grid, rows)
    result = int(info[_RESULT])
    return Advanced(result, float(info[_T]), int(info[_STEPS]), float(info[_VIOLATION]),
                    kernel_error(result, info[_VALUE]))


def locate(system, y0: np.ndarray, h: float, violation: float):
    """
    Take the step of h from y0 and locate its release conditions and stroke ends.

    Returns y1 (the step's end), ys (the state at the s the step is cut at,
    if before h), the release crossing (s, joints, causes) or None, the
    stroke end (s, rows: wrenches, then aero rows, contact pairs and braces after
    them) or None,
    and the largest stage violation (the given one or more).
    """
    y1, ys = np.empty_like(y0), np.empty_like(y0)
    info = np.empty(LOCATE_INFO.WIDTH)
    info[LOCATE_INFO.L_VIOLATION] = violation
    joints = np.empty((system.watched, 2), dtype=np.int64)
    wrenches = np.empty(system.scheduled, dtype=np.int64)
    kernel.locate(system, y0, float(h), y1, ys, joints, wrenches, info)
    code = int(info[LOCATE_INFO.L_CODE])
    if code != kernel.REACHED:
        raise kernel_error(code, float(info[LOCATE_INFO.L_VALUE]))
    crossing = stroke = None
    if not math.isnan(info[LOCATE_INFO.L_CROSSING]):
        found = joints[:int(info[LOCATE_INFO.L_JOINTS])]
        crossing = (float(info[LOCATE_INFO.L_CROSSING]), found[:, 0].tolist(),
                    [TRIGGER_CAUSES[1 + col] for col in found[:, 1]])
    if not math.isnan(info[LOCATE_INFO.L_STROKE]):
        stroke = (float(info[LOCATE_INFO.L_STROKE]),
                  wrenches[:int(info[LOCATE_INFO.L_WRENCHES])].tolist())
    return y1, ys, crossing, stroke, float(info[LOCATE_INFO.L_VIOLATION])


_T, _STEPS, _VIOLATION = ADVANCE_INFO.I_T, ADVANCE_INFO.I_STEPS, ADVANCE_INFO.I_VIOLATION
_RESULT, _DIVERGENCE, _VALUE = (ADVANCE_INFO.I_RESULT, ADVANCE_INFO.I_DIVERGENCE,
                                ADVANCE_INFO.I_VALUE)
