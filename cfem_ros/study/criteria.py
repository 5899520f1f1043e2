# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Pass/fail criteria on a sweep table (SPEC section 9): parse, judge, measure the margin.

A rule is ``<column> <op> <number>`` or ``abs(<column>) <op> <number>``
with op one of ``<, <=, >, >=``; a criterion is a rule or rules joined by
``and``, ``or`` and parentheses (``expressions.py``). A NaN value fails its
rule; a run whose status is 'failed' or 'contact' fails every rule. A run
whose status is 'invalid' (its draw refused by the scenario's checks, not
run) is neither: it is left out of every count and probability
(``valid_runs``). The table gains ``pass`` (a nullable bool: NA for an
invalid run) and ``failed_criterion``: the name of the first criterion a
run fails, in file order, or for a run whose status is not 'ok' that
status ('failed', 'contact', 'invalid'), its reason being in ``message``.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
import operator
import re
from typing import Optional

from cfem_ros.core.engine.events import Status
import numpy as np

#: Operator text -> numpy comparison.
OPERATORS = {'<': operator.lt, '<=': operator.le, '>': operator.gt, '>=': operator.ge}
RULE = ('"<column> <op> <number>" or "abs(<column>) <op> <number>", op one of '
        '<, <=, >, >=, or such rules joined by and, or and parentheses (e.g. '
        '"distance_store_pylon_min >= 0.0254 and abs(store_max_pitch_deg) <= 30")')
#: The status of a run whose draw the scenario's checks refuse (SPEC section 12).
INVALID = Status.INVALID
#: The margin of a run that did not finish (or whose value is NaN), in thresholds.
FAILED_MARGIN = -1.0
#: Smallest threshold magnitude that scales a margin (below it, as 0: scale 1).
TINY_THRESHOLD = 1e-150
#: Largest margin magnitude (a quotient that would overflow is held there).
MARGIN_BOUND = 1e300

_RULE = re.compile(r'^\s*(?:(abs)\(\s*([A-Za-z_][\w.\[\]]*)\s*\)|([A-Za-z_][\w.\[\]]*))'
                   r'\s*(<=|>=|<|>)\s*(\S+)\s*$')


@dataclass(frozen=True)
class Criterion:
    """
    One named rule on one column of the table.

    Attributes
    ----------
    name : str
    column : str
    op : str
        One of ``OPERATORS``.
    threshold : float
        In the column's unit.
    absolute : bool
        The rule is on ``abs(column)``.

    """

    name: str
    column: str
    op: str
    threshold: float
    absolute: bool = False

    @property
    def text(self) -> str:
        """Return the rule as written in a sweep file."""
        what = f'abs({self.column})' if self.absolute else self.column
        return f'{what} {self.op} {self.threshold:g}'

    @property
    def columns(self) -> list:
        """Return the column the rule is on, in a list (as ``Expression.columns``)."""
        return [self.column]

    def passes_of(self, table) -> np.ndarray:
        """Return, per run of a table, whether it meets the rule and finished."""
        return self.passes(table[self.column].to_numpy(dtype=float)) & finished_runs(table)

    def margin_of(self, table) -> np.ndarray:
        """Return, per run of a table, the rule's margin (``margin``)."""
        return self.margin(table[self.column].to_numpy(dtype=float))

    def value(self, column_values) -> np.ndarray:
        """Return what the rule compares: the column's values or their magnitudes."""
        values = np.asarray(column_values, dtype=float)
        return np.abs(values) if self.absolute else values

    def passes(self, column_values) -> np.ndarray:
        """Return, per value, whether it meets the rule (NaN does not)."""
        values = self.value(column_values)
        with np.errstate(invalid='ignore'):
            return OPERATORS[self.op](values, self.threshold) & np.isfinite(values)

    def margin(self, column_values) -> np.ndarray:
        """
        Return how far each value is inside the rule, in units of the threshold.

        Positive inside, negative outside: ``(value - threshold) / scale``
        for ``>``/``>=``, ``(threshold - value) / scale`` for ``<``/``<=``,
        scale ``|threshold|`` (1 when the threshold is 0, or so small that
        the quotient would overflow), clipped to +-1e300. NaN gives
        ``FAILED_MARGIN``. What the rare-event methods follow to the failure
        region: the rule fails where the margin is below 0.
        """
        values = self.value(column_values)
        scale = abs(self.threshold) if abs(self.threshold) >= TINY_THRESHOLD else 1.0
        with np.errstate(over='ignore', invalid='ignore'):
            signed = (values - self.threshold) if self.op in ('>', '>=') \
                else (self.threshold - values)
            margin = np.clip(signed / scale, -MARGIN_BOUND, MARGIN_BOUND)
        return np.where(np.isfinite(values), margin, FAILED_MARGIN)


def parse_rule(name: str, text) -> Criterion:
    """
    Return the criterion of a rule's text.

    Raises
    ------
    ValueError
        If the text is not a rule (the message says what a rule is).

    """
    match = _RULE.match(text) if isinstance(text, str) else None
    if match is None:
        raise ValueError(f'{text!r} is not a rule')
    absolute, inner, plain, op, number = match.groups()
    try:
        threshold = float(number)
    except ValueError:
        raise ValueError(f'{number!r} in {text!r} is not a number') from None
    if not math.isfinite(threshold):
        raise ValueError(f'{number!r} in {text!r} is not a finite number')
    return Criterion(name=name, column=inner if absolute else plain, op=op,
                     threshold=threshold, absolute=bool(absolute))


def finished_runs(table) -> np.ndarray:
    """Return, per run, whether its status is 'ok'."""
    return (table['status'] == Status.OK).to_numpy()


def valid_runs(table):
    """Return the runs of a table that are not ``INVALID`` (what every probability counts)."""
    return table[(table['status'] != INVALID).to_numpy()]


def no_valid_draw(table) -> Optional[str]:
    """
    Return why a table has nothing to count when every one of its runs is invalid (else None).

    Said as the sweep file's ``vary`` would be refused: how many draws, the
    first one's reason, and what would be right.
    """
    if not len(table) or (table['status'] != INVALID).any():
        return None
    first = table.iloc[0]
    return (f"vary: gives no valid draw: the scenario's checks refuse every one of the "
            f'{len(table)} draws, none was run (the first: {first["message"]}); '
            'expected distributions whose draws make valid scenarios (for instance '
            'truncnormal within the valid range)')


def to_json(criterion) -> dict:
    """Return what ``criteria.json`` holds of a criterion (``expressions.from_json`` reads it)."""
    if isinstance(criterion, Criterion):
        return {'name': criterion.name, 'rule': criterion.text, 'column': criterion.column,
                'op': criterion.op, 'threshold': criterion.threshold,
                'absolute': criterion.absolute}
    return {'name': criterion.name, 'rule': criterion.text, 'expression': True,
            'columns': criterion.columns}


def failures(table, criteria) -> dict:
    """
    Return, per criterion name, a bool array: the runs that fail it.

    A run whose ``status`` is not 'ok' fails every criterion (leave invalid
    runs out first: ``valid_runs``).
    """
    return {c.name: ~c.passes_of(table) for c in criteria}


def judge(table, criteria):
    """
    Return the table with ``pass`` and ``failed_criterion`` (after the metrics).

    ``failed_criterion`` is '' for a run that passes, the status for a run
    whose status is not 'ok', otherwise the first criterion it fails.
    """
    table = table.drop(columns=[c for c in ('pass', 'failed_criterion') if c in table])
    failed = failures(table, criteria)
    status = table['status'].to_numpy(dtype=object)
    first = np.full(len(table), '', dtype=object)
    for c in reversed(criteria):
        first = np.where(failed[c.name], c.name, first)
    first = np.where(status != Status.OK, status, first)
    table = table.copy()
    import pandas as pd
    passed = pd.array(first == '', dtype='boolean')
    passed[status == INVALID] = pd.NA   # not run: neither a pass nor a failure
    table['pass'] = passed
    table['failed_criterion'] = first.astype(str)
    return table


def margins(table, criteria) -> np.ndarray:
    """
    Return, per run, the least margin over the criteria (``Criterion.margin``).

    Below 0 where any criterion fails: the limit-state function of the
    rare-event methods. A run whose status is not 'ok' has ``FAILED_MARGIN``
    (or less, if a criterion's margin already is).
    """
    finished = finished_runs(table)
    least = np.full(len(table), np.inf)
    for c in criteria:
        least = np.minimum(least, c.margin_of(table))
    return np.where(finished, least, np.minimum(least, FAILED_MARGIN))
