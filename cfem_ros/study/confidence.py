# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Failure fractions with exact (Clopper-Pearson) intervals, and how many runs to plan.

With k failures in n independent runs, the two-sided interval at level c
is the pair of beta quantiles that scipy.stats.binomtest(k, n)
.proportion_ci(c, 'exact') gives; the one-sided bound "P(fail) <= x at
c" is the beta quantile at c. Planning follows order statistics
(NASA/TP-2010-216447): with no failure allowed, n runs show success
probability p at confidence c when p^n <= 1 - c (59 runs for 95 %/95 %).
"""

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal, ROUND_CEILING, ROUND_FLOOR
import math

from cfem_ros.core.errors import ArgumentError
from scipy import stats


def _check(failures: int, runs: int, level: float):
    if runs < 1 or not 0 <= failures <= runs:
        raise ArgumentError(f'failures {failures} of runs {runs}; expected 0 <= failures <= runs, '
                            'runs >= 1')
    if not 0 < level < 1:
        raise ArgumentError(f'level is {level!r}; expected a confidence 0 < level < 1 (0.95)')


def up(value: float, digits: int = 3) -> str:
    """
    Return a bound as text, rounded upward to ``digits`` figures (never below it).

    Rounded in decimal from the float's exact value: the text read back
    as a float is never below ``value``, not even by its last bit.
    """
    if not math.isfinite(value) or value <= 0:
        return f'{value:g}'
    exact = Decimal(value)
    step = Decimal(1).scaleb(exact.adjusted() - digits + 1)
    return f'{float(exact.quantize(step, rounding=ROUND_CEILING)):.{digits}g}'


def down(value: float, digits: int = 3) -> str:
    """Return a lower bound as text, rounded downward to ``digits`` figures (never above it)."""
    if not math.isfinite(value) or value <= 0:
        return f'{value:g}'
    exact = Decimal(value)
    step = Decimal(1).scaleb(exact.adjusted() - digits + 1)
    return f'{float(exact.quantize(step, rounding=ROUND_FLOOR)):.{digits}g}'


def clopper_pearson(failures: int, runs: int, level: float = 0.95) -> tuple:
    """Return the exact two-sided interval (low, high) of P(fail) at this level."""
    _check(failures, runs, level)
    alpha = 1.0 - level
    low = 0.0 if failures == 0 else float(
        stats.beta.ppf(alpha / 2, failures, runs - failures + 1))
    high = 1.0 if failures == runs else float(
        stats.beta.ppf(1 - alpha / 2, failures + 1, runs - failures))
    return low, high


def upper_bound(failures: int, runs: int, level: float = 0.95) -> float:
    """Return x with "P(fail) <= x at this confidence" (exact, one-sided)."""
    _check(failures, runs, level)
    if failures == runs:
        return 1.0
    return float(stats.beta.ppf(level, failures + 1, runs - failures))


def lower_bound(failures: int, runs: int, level: float = 0.95) -> float:
    """Return x with "P(fail) >= x at this confidence" (exact, one-sided)."""
    _check(failures, runs, level)
    if failures == 0:
        return 0.0
    return float(stats.beta.ppf(1 - level, failures, runs - failures + 1))


def runs_needed(success: float, level: float = 0.95, failures: int = 0) -> int:
    """
    Return the fewest runs that show P(success) >= success at this confidence.

    With up to ``failures`` failed runs allowed among them: the least n
    with P(at most that many failures | P(fail) = 1 - success) <= 1 - level.
    """
    if not 0 < success < 1:
        raise ArgumentError(f'success probability {success!r}; expected 0 < P < 1 (0.95)')
    if not 0 < level < 1:
        raise ArgumentError(f'confidence {level!r}; expected 0 < C < 1 (0.95)')
    if failures < 0:
        raise ArgumentError(f'failures {failures}; expected >= 0')
    n = max(failures + 1, math.ceil(math.log(1 - level) / math.log(success)))
    while stats.binom.cdf(failures, n, 1 - success) > 1 - level:
        n += 1
    return n


@dataclass(frozen=True)
class Fraction:
    """The failures of one criterion (or of any) over the runs, with its intervals."""

    name: str
    failures: int
    runs: int
    level: float

    @property
    def fraction(self) -> float:
        """Return failures / runs."""
        return self.failures / self.runs

    @property
    def interval(self) -> tuple:
        """Return the two-sided Clopper-Pearson interval."""
        return clopper_pearson(self.failures, self.runs, self.level)

    @property
    def bound(self) -> float:
        """Return the one-sided upper bound."""
        return upper_bound(self.failures, self.runs, self.level)

    def sentence(self) -> str:
        """
        Return the line ``cfem-sim sweep`` and ``plot`` print.

        Bounds and interval ends rounded outward (``up``/``down``):
        a bound shown is never below the bound.
        """
        pct = f'{100 * self.level:g} %'
        low, high = self.interval
        if self.failures == 0:
            return (f'{self.name}: 0 failures in {self.runs} runs: P(fail) <= '
                    f'{up(self.bound)} at {pct} (two-sided {pct}: [0, {up(high)}])')
        return (f'{self.name}: {self.failures} failures in {self.runs} runs: P(fail) = '
                f'{self.fraction:.3g}, {pct} interval [{down(low)}, {up(high)}]; '
                f'P(fail) <= {up(self.bound)} at {pct}')


def fractions(table, criteria, level: float = 0.95) -> list:
    """
    Return a Fraction per criterion and one named 'any' for the runs that fail any.

    Over the valid runs only (``criteria.valid_runs``).
    """
    from cfem_ros.study.criteria import failures, valid_runs
    table = valid_runs(table)   # an invalid draw is neither a pass nor a failure
    failed = failures(table, criteria)
    runs = len(table)
    out = [Fraction(name, int(bad.sum()), runs, level) for name, bad in failed.items()]
    if 'pass' in table:
        out.append(Fraction('any', int((~table['pass'].to_numpy(dtype=bool)).sum()), runs, level))
    return out
