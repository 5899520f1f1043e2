# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Sweep files (SPEC section 6): YAML in, a checked ``SweepSpec`` out, with its draws.

Everything is checked before any run starts, with a ``SweepError`` naming
the file, the key path, the value and what would be right. The random
values are drawn here, once, from the seed (``draws``). The sections have
modules of their own: ``keypaths`` (key paths into the scenario), ``draws``
(``vary``, ``correlate``), ``metricspec`` (``metrics``); criteria are parsed by
``expressions`` and judged by ``criteria``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import hashlib
import json
import math
import os
import re
from typing import Optional

from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio.messages import show
from cfem_ros.core.fileio.textfile import read_text
from cfem_ros.core.fileio.yamlfile import load_yaml
from cfem_ros.core.scenario.checker import Checker
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.study.draws import (
    check_draws, draw, MAX_RUNS, parse_correlate, parse_vary, RANDOM_NUMBERS)
from cfem_ros.study.errors import SweepError
from cfem_ros.study.keypaths import apply_values, format_key_path, resolve
from cfem_ros.study.metricspec import check_unique_at, Metrics, parse_metrics
from cfem_ros.study.shape_metrics import Window

TOP_KEYS = ('scenario', 'runs', 'seed', 'rate_hz', 'vary', 'correlate', 'metrics', 'criteria',
            'confidence', 'target')


@dataclass
class SweepSpec:
    """
    A checked sweep: the base scenario, what varies, what is measured, the draws.

    Attributes
    ----------
    path : str
        The sweep file.
    scenario : str
        The base scenario file.
    document : dict
        The base scenario as loaded from YAML.
    runs : int
        Random draws; the table has ``runs`` times the grids' sizes rows.
    seed : int
    rate_hz : float
        Sample rate the metrics are computed at.
    variables : list of Variable
    metrics : Metrics
    values : dict of str to list
        Each varied key path's value for every run (run k is index k).
    correlations : list of (str, str, float)
        The ``correlate`` pairs (key path, key path, rho), each pair once.
    criteria : list of criteria.Criterion
        The ``criteria`` rules, in file order (SPEC section 9).
    confidence : float
        The level of the intervals (``confidence``, default 0.95).
    target : float, optional
        The P(any criterion fails) a decision is made against (``target``).

    """

    path: str
    scenario: str
    document: dict
    runs: int
    seed: int
    rate_hz: float
    variables: list
    metrics: Metrics
    values: dict
    correlations: list = field(default_factory=list)
    criteria: list = field(default_factory=list)
    confidence: float = 0.95
    target: Optional[float] = None

    @property
    def total(self) -> int:
        """Return the number of runs (rows of the table)."""
        return self.runs * math.prod(len(v.params) for v in self.variables if v.kind == 'grid')

    def run_values(self, k: int) -> dict:
        """Return run k's value of every varied key path."""
        return {path: values[k] for path, values in self.values.items()}

    def run_document(self, k: int) -> dict:
        """Return run k's scenario document: the base with run k's values set."""
        return apply_values(self.document, self.variables, self.run_values(k))

    def digest(self) -> str:
        """Return a hash of everything that decides the table (SHA-256, hex)."""
        return hashlib.sha256(self.describe().encode()).hexdigest()

    def describe(self) -> str:
        """Return the resolved sweep as JSON text (what the hash is of)."""
        resolved = {
            'scenario': os.path.abspath(self.scenario), 'document': self.document,
            'runs': self.runs, 'seed': self.seed, 'rate_hz': repr(self.rate_hz),
            'vary': [[v.path, v.kind, v.params] for v in self.variables],
            'metrics': {
                'clearance': [[c.body_a, c.body_b, c.points_a.tolist(), c.points_b.tolist()]
                              for c in self.metrics.clearance],
                'at': [[a.time, a.body, a.relative_to] for a in self.metrics.at],
                'joints': self.metrics.joints},
            'total': self.total}
        windows = [c.window.describe() for c in self.metrics.clearance]
        if self.metrics.distance or any(w != Window().describe() for w in windows):
            # absent otherwise: a sweep without them keeps its hash
            resolved['metrics']['windows'] = windows
            resolved['metrics']['distance'] = [
                [d.body_a, d.body_b, d.window.describe()] for d in self.metrics.distance]
        if any(a.point is not None for a in self.metrics.at):   # absent otherwise, as windows
            resolved['metrics']['at_point'] = [a.point for a in self.metrics.at]
        if any(a.after for a in self.metrics.at) or self.metrics.extremes:   # as windows
            resolved['metrics']['at_after'] = [a.after for a in self.metrics.at]
            resolved['metrics']['extremes'] = [e.describe() for e in self.metrics.extremes]
        if self.correlations:   # absent otherwise: a sweep without it keeps its hash
            resolved['correlate'] = [[a, b, repr(rho)] for a, b, rho in self.correlations]
        return json.dumps(resolved, sort_keys=True, default=repr)


def load_sweep(path: str, runs: Optional[int] = None) -> SweepSpec:
    """
    Read and check a sweep file, load its base scenario and draw the values.

    Parameters
    ----------
    path : str
        The sweep file (SPEC section 6).
    runs : int, optional
        Overrides the file's ``runs``.

    Raises
    ------
    SweepError
        For anything wrong in the sweep file; a ``ScenarioError`` (its
        parent) if the base scenario itself is not valid.

    """
    document = _load_yaml(path, 'sweep file as in SPEC section 6')

    fail = Checker(path, SweepError).fail   # the scenario's idiom: file, key path, value

    if not isinstance(document, dict):
        fail('', f'is {show(document)}', 'a mapping with scenario, runs, seed, vary, metrics')
    for key in document:
        if key not in TOP_KEYS:
            fail(str(key), 'unknown key', 'one of ' + ', '.join(TOP_KEYS))
    if 'scenario' not in document:
        fail('scenario', 'missing', 'the base scenario file, relative to the sweep file')
    if not isinstance(document['scenario'], str):
        fail('scenario', f'is {show(document["scenario"])}', 'a file name')
    scenario = os.path.join(os.path.dirname(os.path.abspath(path)), document['scenario'])
    base = _load_yaml(scenario, 'scenario file (SPEC section 1)')
    model = parse_scenario(base, source=scenario)   # the base scenario must be valid
    for key, count in (('runs', document.get('runs', 1)), ('--runs', runs)):
        if key == 'runs' or count is not None:   # the file's runs too, even when overridden
            _check_runs(fail, key, count)
    count = document.get('runs', 1) if runs is None else runs
    seed = document.get('seed', 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        fail('seed', f'is {show(seed)}', 'a whole number >= 0')
    rate = document.get('rate_hz', 100.0)
    if isinstance(rate, bool) or not isinstance(rate, (int, float)) \
            or not math.isfinite(rate) or rate <= 0:
        fail('rate_hz', f'is {show(rate)}', 'a sample rate > 0 Hz')
    rate = float(rate)
    _check_rate(fail, rate, model)
    variables = parse_vary(fail, document.get('vary') or {}, base)
    check_draws(fail, variables, count)
    correlate = document.get('correlate')
    correlations = parse_correlate(fail, [] if correlate is None else correlate, variables)
    metrics = parse_metrics(fail, document.get('metrics') or {}, base, rate, model)
    check_unique_at(fail, metrics)
    criteria, confidence = _parse_decision(fail, document, variables, metrics)
    target = _parse_target(fail, document, criteria)
    values = draw(variables, count, seed, correlations)
    _check_new_keys(fail, base, variables, values, scenario)
    return SweepSpec(path=path, scenario=scenario, document=base, runs=count, seed=seed,
                     rate_hz=rate, variables=variables, metrics=metrics, values=values,
                     correlations=correlations, criteria=criteria, confidence=confidence,
                     target=target)


def _load_yaml(path: str, what: str):
    """Read a YAML file within the scenario loader's bounds (size, kind, depth, aliases)."""
    try:
        return load_yaml(read_text(path), source=path)
    except ScenarioError as err:
        expected = err.expected or f'a readable {what}'
        if 'SPEC section 6' in what and 'SPEC section 1' in expected:
            expected = ('a YAML mapping as in SPEC section 6 (key paths with brackets '
                        "in a [...] list must be quoted: ['wrenches[1].force[2]', dt])")
        raise SweepError(path, err.key, err.problem, expected) from err


def _parse_decision(fail, document, variables, metrics) -> tuple:
    """
    Check ``criteria`` and ``confidence`` (SPEC section 9); return (criteria, level).

    A rule may name any number column of the table: a metric or a varied
    key path drawn as numbers.
    """
    from cfem_ros.study.criteria import RULE
    from cfem_ros.study.expressions import parse_criterion
    level = document.get('confidence', 0.95)
    if isinstance(level, bool) or not isinstance(level, (int, float)) \
            or not 0 < level < 1:
        fail('confidence', f'is {show(level)}', 'a confidence level 0 < c < 1 (0.95)')
    rules = document.get('criteria') or {}
    if not isinstance(rules, dict):
        fail('criteria', f'is {show(rules)}', 'a mapping of name -> rule ' + RULE)
    allowed = [c for c in metrics.columns() if not c.endswith('_cause')] + [
        v.path for v in variables if v.kind in RANDOM_NUMBERS
        or all(isinstance(p, (int, float)) and not isinstance(p, bool) for p in v.params)]
    criteria = []
    for name, text in rules.items():
        key = f'criteria.{name}'
        if not isinstance(name, str) or not re.fullmatch(r'[A-Za-z_][\w-]*', name):
            fail(key, f'{show(name)} is not a name', 'letters, digits, _ or -')
        try:
            criterion = parse_criterion(name, text)
        except ValueError as err:
            fail(key, str(err), RULE)
        for column in criterion.columns:
            if column not in allowed:
                fail(key, f'{column!r} is not a number column of the table',
                     'one of ' + ', '.join(allowed))
        criteria.append(criterion)
    return criteria, float(level)


def _parse_target(fail, document, criteria) -> Optional[float]:
    """Check ``target`` (SPEC section 9): a probability, with criteria to decide on."""
    target = document.get('target')
    if target is None:
        return None
    if isinstance(target, bool) or not isinstance(target, (int, float)) \
            or not 0 < target < 1:
        fail('target', f'is {show(target)}', 'the probability P(any criterion fails) must '
             'be shown below, 0 < target < 1 (1.0e-6)')
    if not criteria:
        fail('target', f'is {target!r} but the sweep has no criteria',
             'criteria (SPEC section 9): the target is a probability that one fails')
    return float(target)


def _check_runs(fail, key: str, count):
    """Refuse a ``runs`` (or ``--runs``) that is not a whole number from 1 to ``MAX_RUNS``."""
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        fail(key, f'is {show(count)}', 'a whole number of runs >= 1')
    if count > MAX_RUNS:
        fail(key, f'is {count:,}', f'at most {MAX_RUNS:,} runs (each run is a row of the '
             'table and a task; split a larger study into several sweeps)')


def _check_rate(fail, rate: float, model):
    """Refuse a ``rate_hz`` outside ``cfem-sim run``'s range or giving runs too large."""
    from cfem_ros.recording import offline
    low, high = offline.RATE_RANGE
    if not low <= rate <= high:
        fail('rate_hz', f'is {rate:g}', f'a sample rate from {low:g} to {high:g} Hz, as '
             'cfem-sim run --rate')
    samples = offline.expected_samples(rate, model.duration)
    size = offline.estimate_bytes(model, samples)
    if samples > offline.MAX_SAMPLES or size > offline.MAX_GB * 1e9:
        fail('rate_hz', f'is {rate:g} Hz over {model.duration:g} s: {samples:.4g} samples '
             f'(about {size / 1e9:.3g} GB) in each run', f'at most {offline.MAX_SAMPLES:.4g} '
             f'samples and {offline.MAX_GB:g} GB a run, as cfem-sim run; lower rate_hz')


def _check_new_keys(fail, base, variables, values, scenario):
    """
    Refuse a key path that adds a key the scenario format does not have (a typo).

    Each path that is not in the base scenario is set alone to run 0's value
    and the document parsed: an unknown key there, or one that conflicts
    with a key of the scenario whatever its value (``flight.airspeed`` with
    ``mach`` given), is the sweep file's mistake, found before any run (a
    value a draw makes invalid is left to that run, a failed row with its
    reason).
    """
    for variable in variables:
        if resolve(base, variable.tokens)[3]:
            continue
        document = apply_values(base, [variable], {variable.path: values[variable.path][0]})
        try:
            parse_scenario(document, source=scenario)
        except ScenarioError as err:
            if not err.key.startswith(format_key_path(variable.tokens[:-1])):
                continue
            if err.problem == 'unknown key':
                fail(f'vary.{variable.path}', f'adds {err.key}, a key the scenario format '
                     f'does not have', err.expected or 'a key path of the scenario format')
            if err.problem.startswith('given together with'):   # whatever value is drawn
                fail(f'vary.{variable.path}', f'is not in {scenario}, and with it {err.key} '
                     f'is {err.problem}: every run would be refused', err.expected)
