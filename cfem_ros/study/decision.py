# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A decision an engineer can sign (SPEC section 9): P(unsafe) against a target.

From an estimate of P(any criterion fails) and its one-sided upper bound
``p_upper`` at a confidence: ``meets`` when p_upper < target,
``undecided`` when the estimate is below the target but the bound is not,
``does_not_meet`` otherwise. The tail check (the same estimate with each
normal input's tails heavier) gives a second decision; when the two
differ the decision is ``undecided``. ``decide`` takes anything with
``probability`` and ``p_upper`` (an ``Estimate``); ``decide_runs`` takes
the failures of a set of Monte Carlo runs (the exact Clopper-Pearson bound).
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Optional

from cfem_ros.core.errors import ArgumentError
from cfem_ros.study.confidence import down, up, upper_bound  # noqa: F401 - down, up: for callers

MEETS = 'meets'
DOES_NOT_MEET = 'does_not_meet'
UNDECIDED = 'undecided'
VERDICTS = (MEETS, DOES_NOT_MEET, UNDECIDED)


def verdict(probability: float, p_upper: Optional[float], target: float) -> str:
    """Return meets, does_not_meet or undecided for an estimate and its bound (None: no bound)."""
    if probability is not None and math.isfinite(probability) and probability >= target:
        return DOES_NOT_MEET
    if p_upper is None or not math.isfinite(p_upper) or probability is None \
            or not math.isfinite(probability):
        return UNDECIDED
    return MEETS if p_upper < target else UNDECIDED


@dataclass(frozen=True)
class Decision:
    """
    P(unsafe) against a target, at a one-sided confidence.

    Attributes
    ----------
    decision : str
        ``meets``, ``does_not_meet`` or ``undecided`` (after the tail check).
    probability, p_upper : float
        The estimate and its one-sided upper bound (NaN: no bound).
    target, confidence : float
    tail_probability, tail_p_upper : float, optional
        The same with heavier-tailed inputs (None: no tail check made).
    tail_note : str
        Why the tail check was not made or has no bound ('' if it has one).

    """

    decision: str
    probability: float
    p_upper: float
    target: float
    confidence: float
    tail_probability: Optional[float] = None
    tail_p_upper: Optional[float] = None
    tail_note: str = ''

    @property
    def nominal(self) -> str:
        """Return the decision of the inputs as given (before the tail check)."""
        return verdict(self.probability, self.p_upper, self.target)

    @property
    def tail(self) -> Optional[str]:
        """Return the decision with heavier tails (None: no tail check)."""
        if self.tail_probability is None:
            return None
        return verdict(self.tail_probability, self.tail_p_upper, self.target)

    def sentence(self) -> str:
        """
        Return the one sentence a report ends with.

        e.g. 'P(unsafe) <= 8.1e-07 at 95 % one-sided: meets the 1e-06 target;
        unchanged with heavier tails (<= 9.2e-07)'.
        """
        pct = f'{100 * self.confidence:g} %'
        if self.p_upper is not None and math.isfinite(self.p_upper):
            digits = 3
            while float(up(self.p_upper, digits)) >= self.target > self.p_upper and digits < 17:
                digits += 1   # a bound below the target never shown as the target
            head = f'P(unsafe) <= {up(self.p_upper, digits)} at {pct} one-sided'
        else:
            head = (f'P(unsafe) estimated {self.probability:.2g}, with no {pct} one-sided '
                    'bound')
        nominal = self.nominal
        what = {MEETS: f'meets the {self.target:g} target',
                DOES_NOT_MEET: f'does not meet the {self.target:g} target (estimate '
                               f'{self.probability:.2g})',
                UNDECIDED: f'undecided against the {self.target:g} target (the estimate '
                           f'{self.probability:.2g} is below it, the bound is not)'}[nominal]
        if nominal == UNDECIDED and not (self.p_upper is not None
                                         and math.isfinite(self.p_upper)):
            what = f'undecided against the {self.target:g} target (no bound)'
        line = f'{head}: {what}'
        tail = self.tail
        if tail is None:
            return line + (f'; {self.tail_note}' if self.tail_note else '')
        bound = (f'<= {up(self.tail_p_upper)}' if self.tail_p_upper is not None
                 and math.isfinite(self.tail_p_upper) else
                 f'estimate {self.tail_probability:.2g}, no bound')
        if tail == nominal:
            return f'{line}; unchanged with heavier tails ({bound})'
        why = f' ({self.tail_note})' if self.tail_note else ''
        said = {MEETS: 'meets it', DOES_NOT_MEET: 'does not meet it', UNDECIDED: 'undecided'}
        return (f'{line}; with heavier tails (Student-t, 5 dof) P(unsafe) {bound}{why}, '
                f'{said[tail]}: '
                'the decision rests on the assumed tails, so undecided')

    def as_dict(self) -> dict:
        """Return the fields as plain JSON values (NaN and inf as None)."""
        def plain(v):
            return None if isinstance(v, float) and not math.isfinite(v) else v
        return {'decision': self.decision, 'probability': plain(self.probability),
                'p_upper': plain(self.p_upper), 'target': self.target,
                'confidence': self.confidence,
                'tail_probability': plain(self.tail_probability),
                'tail_p_upper': plain(self.tail_p_upper), 'tail_decision': self.tail,
                'tail_note': self.tail_note, 'sentence': self.sentence()}


def _check(target: float, confidence: float):
    if not (isinstance(target, (int, float)) and 0 < target < 1):
        raise ArgumentError(f'target is {target!r}; expected a probability 0 < target < 1 (1e-6)')
    if not (isinstance(confidence, (int, float)) and 0 < confidence < 1):
        raise ArgumentError(f'confidence is {confidence!r}; expected 0 < confidence < 1 (0.95)')


def decide(estimate, target: float, confidence: float,
           tail=None, tail_note: str = '') -> Decision:
    """
    Return the decision of an estimate against a target.

    Parameters
    ----------
    estimate
        Anything with ``probability`` and ``p_upper`` (an ``Estimate``); a
        ``p_upper`` of None or NaN is no bound (undecided unless the
        estimate itself is at or above the target).
    target : float
        The probability the study must show P(unsafe) below.
    confidence : float
        The one-sided level of ``p_upper``.
    tail : optional
        The tail check's estimate (``probability``, ``p_upper``), or None.
    tail_note : str
        Why the tail check is missing or has no bound, said in the sentence.

    """
    _check(target, confidence)
    p = float(estimate.probability)
    upper = estimate.p_upper
    upper = math.nan if upper is None else float(upper)
    tail_p = tail_upper = None
    if tail is not None and tail.probability is not None \
            and math.isfinite(tail.probability):   # else: no tail check made (tail_note)
        tail_p = float(tail.probability)
        tail_upper = math.nan if tail.p_upper is None else float(tail.p_upper)
    first = verdict(p, upper, target)
    final = first
    if tail_p is not None and verdict(tail_p, tail_upper, target) != first:
        final = UNDECIDED
    return Decision(final, p, upper, float(target), float(confidence), tail_p, tail_upper,
                    tail_note)


@dataclass(frozen=True)
class _Counted:
    probability: float
    p_upper: float


def decide_runs(failures: int, runs: int, target: float, confidence: float) -> Decision:
    """
    Return the decision of ``failures`` failed runs among ``runs`` Monte Carlo runs.

    The bound is the exact one-sided Clopper-Pearson bound (scipy's beta
    quantile). No tail check here: ``decide`` takes one as ``tail``.
    """
    _check(target, confidence)
    bound = upper_bound(int(failures), int(runs), confidence)
    return decide(_Counted(failures / runs, bound), target, confidence)


def decide_estimate(estimate, target: float) -> Decision:
    """Return the decision of an ``Estimate`` (its bound, its tail check) against a target."""
    tail = None
    if estimate.tail_probability is not None:
        tail = _Counted(estimate.tail_probability, estimate.tail_p_upper)
    return decide(estimate, target, estimate.level, tail, estimate.tail_note)
