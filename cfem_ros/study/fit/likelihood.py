# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Profile-likelihood intervals of a fit's parameters (``cfem-sim fit --profile``).

For a parameter held at a value, the other determined parameters are
fitted again within their bounds (a bounded refit from the solution); the
profile is the chi-square of that refit. The interval at confidence c is
where the profile is at most the minimum plus s * chi2.ppf(c, 1), s =
max(1, reduced chi-square) (the same scaling as the standard errors). Each
end is found by the secant method from the quadratic guess value ± z *
scaled standard error, to 2 % of the chi-square step; an end that the
profile does not reach within the bounds is the bound (and is said). The
2 x parameters searches run in parallel threads, as a Jacobian's runs do.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
import math

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import chi2

#: An end is found when the profile is within this share of the chi-square step.
TOLERANCE = 0.02
#: Secant steps per end at most.
STEPS = 12
#: Evaluations of one profile point's refit at most.
REFIT_EVALUATIONS = 30


def profile_intervals(fit, result) -> list:
    """Return (low, high) per parameter (NaN for one not determined); note bounds reached."""
    u = result.uncertainty
    free = np.flatnonzero(u.determined)
    scale = max(1.0, u.reduced_chi2) if math.isfinite(u.reduced_chi2) else 1.0
    step = scale * chi2.ppf(fit.spec.confidence, 1)
    tasks = [(j, side) for j in free for side in (-1, 1)]
    with ThreadPoolExecutor(max_workers=fit.threads) as pool:
        ends = list(pool.map(lambda task: _end(fit, result, free, task[0], task[1], step),
                             tasks))
    out = [(math.nan, math.nan)] * len(fit.spec.parameters)
    found = dict(zip(tasks, ends))
    for j in free:
        (low, low_bound), (high, high_bound) = found[(j, -1)], found[(j, 1)]
        out[j] = (low, high)
        name = fit.spec.parameters[j].name
        for at, reached in ((low, low_bound), (high, high_bound)):
            if reached:
                result.problems.append(f'{name}: its profile interval reaches the bound '
                                       f'{at:g}: the data do not close it there')
    return out


def _chi2_at(fit, result, free, j, value, start) -> tuple:
    """Return (chi-square, refitted values) with parameter j held at value."""
    spec = fit.spec
    values = np.array(start, dtype=float)
    values[j] = value
    others = np.array([k for k in free if k != j], dtype=int)
    if others.size == 0:
        r = fit.evaluate(values)
        return float(r @ r), values
    low, high = spec.bounds

    def full(x):
        out = values.copy()
        out[others] = x
        return out

    solution = least_squares(
        lambda x: fit.evaluate(full(x)), np.clip(values[others], low[others], high[others]),
        jac=lambda x: fit.jacobian(full(x), others, threads=1,
                                   base=fit.evaluate(full(x))),
        bounds=(low[others], high[others]), method='trf', x_scale='jac',
        max_nfev=REFIT_EVALUATIONS)
    return float(2.0 * solution.cost), full(solution.x)


def _end(fit, result, free, j, side, step) -> tuple:
    """Return (the interval's end on side of parameter j, whether it is the bound)."""
    parameter = fit.spec.parameters[j]
    best = float(result.values[j])
    minimum = result.uncertainty.chi2
    limit = parameter.high if side > 0 else parameter.low
    error = result.uncertainty.standard_errors[j]
    guess = best + side * math.sqrt(step) * error
    start = result.values
    points = [(best, -step)]     # (value, profile - minimum - step)
    value = guess
    for _ in range(STEPS):
        value = min(max(value, parameter.low), parameter.high)
        profile, start = _chi2_at(fit, result, free, j, value, start)
        excess = profile - minimum - step
        points.append((value, excess))
        if abs(excess) <= TOLERANCE * step:
            return value, False
        if value == limit and excess < 0:
            return value, True
        (a, fa), (b, fb) = _bracket(points, best)
        if fb == fa:
            value = best + 2 * (value - best)
            continue
        value = b - fb * (b - a) / (fb - fa)
        if side * (value - best) <= 0:   # the secant turned back: halve towards the last
            value = best + (b - best) / 2
    return value, False


def _bracket(points, best) -> tuple:
    """Return the two points to take the secant through: a bracket if there is one."""
    below = [p for p in points if p[1] < 0]
    above = [p for p in points if p[1] >= 0]
    if below and above:
        a = max(below, key=lambda p: abs(p[0] - best))
        b = min(above, key=lambda p: abs(p[0] - best))
        return a, b
    return points[-2], points[-1]
