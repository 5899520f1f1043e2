# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The tail check (SPEC section 9): P(unsafe) again with each normal input's tails heavier.

Each ``normal: [mean, sd]`` input becomes a Student-t with ``DOF`` degrees
of freedom, the same median and standard deviation (scale
``sd sqrt((DOF - 2) / DOF)``); the other inputs and the copula stay.
Monte Carlo's runs are reweighted; the other methods are run again:

- Monte Carlo: the estimate is the mean of f_heavy / f over the failed
  runs; its bound is exact, not statistical beyond Clopper-Pearson's: for
  the box B_r (every normal input within r standard deviations),
  P_heavy(F) <= W_r U + P_heavy(outside B_r), with W_r the largest
  f_heavy / f in B_r and U the Clopper-Pearson bound of P(F) (one event of
  probability 1 - c, so the least over r is a bound at c too). It needs
  independent normal inputs; with correlated ones no check is made (said);
- subset simulation cannot be reweighted (its runs are Markov chains), and
  importance sampling (FORM's, NAIS) must not be: its density q has
  lighter tails than the heavier inputs, so the weights f_heavy / q have
  no finite variance and the batches' spread misses what the far tail
  holds (a batch bound found 5.4e-4 +- 8 % where P was 1.35e-3). Each
  is run again on the heavier-tailed inputs, with its own seeds
  (``reliability``).
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Optional

import numpy as np

#: Degrees of freedom of the heavier tails.
DOF = 5
#: Student-t scale per unit of standard deviation (its variance is DOF / (DOF - 2)).
SCALE = math.sqrt((DOF - 2) / DOF)
#: Box half-widths (standard deviations) the Monte Carlo bound is the least over.
RADII = np.linspace(0.5, 40.0, 400)


@dataclass(frozen=True)
class Tail:
    """The heavier-tailed estimate, its one-sided bound (NaN: none) and why it has none."""

    probability: float
    p_upper: float
    note: str = ''


def normals(spec) -> list:
    """Return (index, mean, sd) of each input drawn from a normal distribution."""
    return [(i, float(v.params[0]), float(v.params[1])) for i, v in enumerate(spec.variables)
            if v.kind == 'normal']


def log_ratio_1d(z: np.ndarray) -> np.ndarray:
    """Return log(f_heavy / f) of one normal input at z standard deviations from its mean."""
    from scipy.stats import norm, t
    z = np.asarray(z, dtype=float)
    return t.logpdf(z / SCALE, DOF) - math.log(SCALE) - norm.logpdf(z)


def _independent(spec) -> bool:
    """Tell whether no ``correlate`` pair names a normal input."""
    named = {path for a, b, _ in spec.correlations for path in (a, b)}
    return not any(v.kind == 'normal' and v.path in named for v in spec.variables)


def mc_tail(spec, points: np.ndarray, failed: np.ndarray, confidence: float) -> Optional[Tail]:
    """
    Return the tail check of Monte Carlo runs (None: no normal input to make heavier).

    Parameters
    ----------
    spec : SweepSpec
        The sweep: its inputs' distributions and correlations.
    points : array (n, d)
        The valid runs' inputs, in ``spec.variables`` order.
    failed : array of bool (n,)
        Which of them failed a criterion.
    confidence : float
        The level of the Clopper-Pearson bound the tail bound rests on.

    """
    from cfem_ros.study.confidence import upper_bound
    from scipy.stats import t
    found = normals(spec)
    if not found:
        return None
    points = np.asarray(points, dtype=float)
    failed = np.asarray(failed, dtype=bool)
    n, k = len(failed), int(failed.sum())
    if not _independent(spec):
        return Tail(math.nan, math.nan, 'not made: a normal input is correlated, and the '
                    'reweighting of Monte Carlo runs needs independent ones')
    z = np.column_stack([(points[:, i] - mean) / sd for i, mean, sd in found])
    weights = np.exp(log_ratio_1d(z).sum(axis=1))
    estimate = float(np.sum(weights[failed]) / n)
    bound = upper_bound(k, n, confidence)
    grid = np.linspace(0, RADII[-1], 40001)
    peak = np.maximum.accumulate(log_ratio_1d(grid))   # log of the largest ratio in [0, z]
    log_w = len(found) * peak[np.searchsorted(grid, RADII)]
    outside = -np.expm1(len(found) * np.log1p(-2 * t.sf(RADII / SCALE, DOF)))
    with np.errstate(over='ignore'):
        p_upper = float(min(1.0, np.min(np.exp(log_w + math.log(bound)) + outside)))
    return Tail(estimate, max(p_upper, estimate))
