# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
One-sided bounds of P(fail) from independent replicates (SPEC section 9, "A decision").

Importance sampling and NAIS give their estimate as the mean of independent
batches of the weighted estimator; subset simulation as the mean of K
independent repetitions. Either way the estimate is a mean of K i.i.d.
replicates, and its bound at confidence c is Student-t's:
``mean + t_c(K - 1) s / sqrt(K)`` with s the replicates' standard
deviation. A bound resting on too few failed runs (``MIN_FAILED``) is not
given: the replicates' spread then says nothing of the tail they missed.
"""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

#: Fewest failed runs under a batch or repetition bound.
MIN_FAILED = 10


@dataclass(frozen=True)
class Bounds:
    """The mean of replicates with its Student-t bounds (one- and two-sided)."""

    probability: float
    cov: float
    ci_low: float        # two-sided at the confidence
    ci_high: float
    p_lower: float       # one-sided at the confidence
    p_upper: float
    replicates: int


def student_bounds(replicates, confidence: float, failed: int = MIN_FAILED) -> Bounds:
    """
    Return the mean of independent replicates and its Student-t bounds at a confidence.

    Parameters
    ----------
    replicates : array of float
        Independent, identically distributed estimates of P (at least 2).
    confidence : float
        The level of the bounds (0.95).
    failed : int
        Failed runs the replicates rest on: with fewer than ``MIN_FAILED``
        the bounds are NaN (no bound), the mean still given.

    """
    from scipy.stats import t
    values = np.asarray(replicates, dtype=float)
    if values.size < 2 or not np.isfinite(values).all():
        raise ValueError(f'{values.size} replicates ({values!r}); expected at least 2 finite')
    k = values.size
    mean = float(values.mean())
    se = float(values.std(ddof=1)) / math.sqrt(k)
    cov = se / mean if mean > 0 else math.inf
    if failed < MIN_FAILED or se == 0.0 and mean == 0.0:
        nan = math.nan
        return Bounds(mean, cov, nan, nan, nan, nan, k)
    one = float(t.ppf(confidence, k - 1)) * se
    two = float(t.ppf((1 + confidence) / 2, k - 1)) * se
    return Bounds(mean, cov, max(0.0, mean - two), min(1.0, mean + two),
                  max(0.0, mean - one), min(1.0, mean + one), k)


def batch_means(values, batches: int) -> np.ndarray:
    """Return the means of ``batches`` consecutive slices of values (sizes within 1)."""
    values = np.asarray(values, dtype=float)
    if values.size < batches:
        raise ValueError(f'{values.size} values in {batches} batches; expected at least one '
                         'value a batch')
    return np.array([part.mean() for part in np.array_split(values, batches)])
