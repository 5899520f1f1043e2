# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Sweep files (SPEC section 6): YAML in, a checked ``SweepSpec`` out, with its draws.

Everything is checked before any run starts, with a ``SweepError`` naming
the file, the key path, the value and what would be right. The random
values are drawn here, once, from the seed: each varied key path has its
own generator (``numpy.random.SeedSequence(seed).spawn``), so the table
never depends on how the runs are shared out. Key paths listed in
``correlate`` are joined by a Gaussian copula: each still draws its own
standard normals from its own generator; these are mixed by a factor of the
correlation matrix and mapped through each declared marginal's inverse CDF.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
import hashlib
import itertools
import json
import math
import os
import re
from typing import Any, Optional

from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio.textfile import read_text
from cfem_ros.core.fileio.yamlfile import load_yaml
from cfem_ros.core.scenario.checker import MAX_MAGNITUDE
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.study import windowed
from cfem_ros.study.shape_metrics import parse_distance, parse_window, Window
import numpy as np

TOP_KEYS = ('scenario', 'runs', 'seed', 'rate_hz', 'vary', 'correlate', 'metrics', 'criteria',
            'confidence')
METRIC_KEYS = ('clearance', 'at', 'distance', 'extremes')
CLEARANCE_KEYS = ('bodies', 'points_a', 'points_b', 'from', 'to')
AT_KEYS = ('time', 'body', 'relative_to', 'after')
#: Distribution name -> what its list holds.
DISTRIBUTIONS = {
    'uniform': '[low, high] with low < high',
    'normal': '[mean, standard deviation >= 0]',
    'truncnormal': '[mean, standard deviation > 0, low, high] with low < high',
    'choice': 'a non-empty list of values, each drawn with equal probability',
    'grid': 'a non-empty list of values, each run with every draw',
}
RANDOM_NUMBERS = ('uniform', 'normal', 'truncnormal')
#: Distributions a key path in ``correlate`` may have.
CORRELATABLE = RANDOM_NUMBERS + ('choice',)
#: A correlation matrix whose smallest eigenvalue is above -this is positive semi-definite.
PSD_TOLERANCE = 1e-10
#: What a ``correlate`` entry holds.
CORRELATE_ENTRY = ('[key path, key path, rho] with -1 <= rho <= 1 (quote a key path '
                   "with brackets: ['wrenches[0].force[2]', 'wrenches[1].force[2]', 0.9])")
#: A sample time within this many samples of the grid is on it.
ON_GRID = 1e-9
#: Most runs in a sweep (draws times grid points): each is a task and a row.
MAX_RUNS = 1_000_000

_TOKEN = re.compile(r'\.?([A-Za-z_][A-Za-z0-9_]*)|\[(\d+)\]')


class SweepError(ScenarioError):
    """A sweep file that cannot be run (file, key path, problem, expected)."""


def parse_key_path(text: str) -> tuple:
    """
    Split a key path into mapping keys (str) and list indices (int).

    ``wrenches[1].force[2]`` -> ('wrenches', 1, 'force', 2). Raises
    ValueError if the text is not a key path.
    """
    if not isinstance(text, str) or not text or text[0] in '.[':
        raise ValueError('not a key path')
    tokens, at = [], 0
    while at < len(text):
        match = _TOKEN.match(text, at)
        if match is None or (at > 0 and match.group(1) and text[at] != '.') \
                or (at == 0 and text[0] == '.'):
            raise ValueError('not a key path')
        tokens.append(match.group(1) if match.group(1) else int(match.group(2)))
        at = match.end()
    return tuple(tokens)


def format_key_path(tokens) -> str:
    """Return the text of a key path (the inverse of ``parse_key_path``)."""
    out = ''
    for token in tokens:
        out += f'[{token}]' if isinstance(token, int) else (f'.{token}' if out else token)
    return out


def resolve(document, tokens) -> tuple:
    """
    Find where a key path points in a document.

    Returns (container, last token, existing value or None, exists). The
    path must lead through existing mappings and lists; its last key may
    be new in an existing mapping. Raises KeyError with what went wrong.
    """
    node = document
    for depth, token in enumerate(tokens[:-1]):
        node = _step(node, token, tokens[:depth + 1])
    last = tokens[-1]
    if isinstance(last, int):
        if not isinstance(node, list):
            raise KeyError(f'{format_key_path(tokens[:-1]) or "the document"} is '
                           f'{_kind(node)}, not a list')
        if last >= len(node):
            raise KeyError(f'index {last} is past the end of a list of {len(node)}')
        return node, last, node[last], True
    if not isinstance(node, dict):
        raise KeyError(f'{format_key_path(tokens[:-1]) or "the document"} is '
                       f'{_kind(node)}, not a mapping')
    return node, last, node.get(last), last in node


def _step(node, token, path):
    if isinstance(token, int):
        if not isinstance(node, list):
            raise KeyError(f'{format_key_path(path[:-1])} is {_kind(node)}, not a list')
        if token >= len(node):
            raise KeyError(f'{format_key_path(path)}: index {token} is past the end of a '
                           f'list of {len(node)}')
        return node[token]
    if not isinstance(node, dict):
        raise KeyError(f'{format_key_path(path[:-1]) or "the document"} is {_kind(node)}, '
                       'not a mapping')
    if token not in node:   # with the keys there are, for the message
        raise KeyError(f'{format_key_path(path)} does not exist in the scenario',
                       [format_key_path([*path[:-1], str(key)]) for key in node])
    return node[token]


def _kind(value) -> str:
    if value is None:
        return 'empty'
    return {dict: 'a mapping', list: 'a list', str: 'a string'}.get(type(value), 'a number')


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + '...'


def _plain(value):
    """Return a value as plain Python (floats, ints, str, lists), as YAML would give it."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


@dataclass
class Variable:
    """One varied key path: its distribution and its parameters."""

    path: str
    tokens: tuple
    kind: str
    params: list


@dataclass
class Clearance:
    """Minimum distance between points carried by two bodies (body axes, m)."""

    body_a: str
    body_b: str
    points_a: np.ndarray
    points_b: np.ndarray
    window: Window = field(default_factory=Window)   # ``from``/``to`` (shape_metrics.py)

    @property
    def prefix(self) -> str:
        """Return the column prefix, ``clearance_<a>_<b>``."""
        return f'clearance_{self.body_a}_{self.body_b}'


@dataclass
class At:
    """
    A body's state at a sample time, optionally in another body's frame.

    With ``after`` (a joint or release group, SPEC section 12) the time is
    counted from that release (``windowed.at_after``); ``groups`` are the
    scenario's release groups, (name, joints) pairs.
    """

    time: float
    body: str
    relative_to: Optional[str] = None
    after: Optional[str] = None
    groups: tuple = ()

    @property
    def prefix(self) -> str:
        """Return the column prefix, ``<body>_at_<time>_`` (``<time>r_`` after a release)."""
        return f'{self.body}_at_{self.time:g}{"r" if self.after else ""}_'


#: Sweep columns of a stroke end, after ``stroke_<wrench>_`` (SPEC section 7).
STROKE_COLUMNS = ('time', 'u', 'v', 'w', 'p', 'q', 'r')


@dataclass
class Metrics:
    """What is measured on every run: clearances, states at times, joints' loads, strokes."""

    clearance: list = field(default_factory=list)
    at: list = field(default_factory=list)
    joints: list = field(default_factory=list)
    strokes: list = field(default_factory=list)
    distance: list = field(default_factory=list)   # shape_metrics.Distance
    aero: list = field(default_factory=list)   # bodies with aero tables
    extremes: list = field(default_factory=list)   # windowed.Extremes

    def columns(self) -> list:
        """Return the metric column names, in table order."""
        names = []
        for c in self.clearance:
            names += [f'{c.prefix}_min', f'{c.prefix}_time', f'{c.prefix}_point_a',
                      f'{c.prefix}_point_b']
        for d in self.distance:
            names += d.columns()
        for joint in self.joints:
            names += [f'release_{joint}_time', f'release_{joint}_cause']
        for joint in self.joints:
            names += [f'peak_force_{joint}', f'peak_moment_{joint}']
        for entry in self.at:
            names += [entry.prefix + s for s in ('x', 'y', 'z', 'roll_deg', 'pitch_deg',
                                                 'yaw_deg')]
        for wrench in self.strokes:
            names += [f'stroke_{wrench}_{s}' for s in STROKE_COLUMNS]
        names += [f'aero_outside_{body}' for body in self.aero]
        for entry in self.extremes:
            names += entry.columns()
        return names


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
        if any(a.after for a in self.metrics.at) or self.metrics.extremes:   # as windows
            resolved['metrics']['at_after'] = [a.after for a in self.metrics.at]
            resolved['metrics']['extremes'] = [e.describe() for e in self.metrics.extremes]
        if self.correlations:   # absent otherwise: a sweep without it keeps its hash
            resolved['correlate'] = [[a, b, repr(rho)] for a, b, rho in self.correlations]
        return json.dumps(resolved, sort_keys=True, default=repr)


def apply_values(document: dict, variables, values: dict) -> dict:
    """Return a copy of document with each variable's key path set to its value."""
    out = copy.deepcopy(document)
    for variable in variables:
        container, last, _, _ = resolve(out, variable.tokens)
        container[last] = copy.deepcopy(values[variable.path])
    return out


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

    def fail(key, problem, expected=''):
        raise SweepError(path, _clip(key, 120), _clip(problem, 240), _clip(expected, 240))

    if not isinstance(document, dict):
        fail('', f'is {_show(document)}', 'a mapping with scenario, runs, seed, vary, metrics')
    for key in document:
        if key not in TOP_KEYS:
            fail(str(key), 'unknown key', 'one of ' + ', '.join(TOP_KEYS))
    if 'scenario' not in document:
        fail('scenario', 'missing', 'the base scenario file, relative to the sweep file')
    if not isinstance(document['scenario'], str):
        fail('scenario', f'is {_show(document["scenario"])}', 'a file name')
    scenario = os.path.join(os.path.dirname(os.path.abspath(path)), document['scenario'])
    base = _load_yaml(scenario, 'scenario file (SPEC section 1)')
    model = parse_scenario(base, source=scenario)   # the base scenario must be valid
    for key, count in (('runs', document.get('runs', 1)), ('--runs', runs)):
        if key == 'runs' or count is not None:   # the file's runs too, even when overridden
            _check_runs(fail, key, count)
    count = document.get('runs', 1) if runs is None else runs
    seed = document.get('seed', 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        fail('seed', f'is {_show(seed)}', 'a whole number >= 0')
    rate = document.get('rate_hz', 100.0)
    if isinstance(rate, bool) or not isinstance(rate, (int, float)) \
            or not math.isfinite(rate) or rate <= 0:
        fail('rate_hz', f'is {_show(rate)}', 'a sample rate > 0 Hz')
    rate = float(rate)
    _check_rate(fail, rate, model)
    variables = _parse_vary(fail, document.get('vary') or {}, base)
    _check_draws(fail, variables, count)
    correlate = document.get('correlate')
    correlations = _parse_correlate(fail, [] if correlate is None else correlate, variables)
    metrics = _parse_metrics(fail, document.get('metrics') or {}, base, rate, model)
    _check_unique_at(fail, metrics)
    criteria, confidence = _parse_decision(fail, document, variables, metrics)
    values = draw(variables, count, seed, correlations)
    _check_new_keys(fail, base, variables, values, scenario)
    return SweepSpec(path=path, scenario=scenario, document=base, runs=count, seed=seed,
                     rate_hz=rate, variables=variables, metrics=metrics, values=values,
                     correlations=correlations, criteria=criteria, confidence=confidence)


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
        fail('confidence', f'is {_show(level)}', 'a confidence level 0 < c < 1 (0.95)')
    rules = document.get('criteria') or {}
    if not isinstance(rules, dict):
        fail('criteria', f'is {_show(rules)}', 'a mapping of name -> rule ' + RULE)
    allowed = [c for c in metrics.columns() if not c.endswith('_cause')] + [
        v.path for v in variables if v.kind in RANDOM_NUMBERS
        or all(isinstance(p, (int, float)) and not isinstance(p, bool) for p in v.params)]
    criteria = []
    for name, text in rules.items():
        key = f'criteria.{name}'
        if not isinstance(name, str) or not re.fullmatch(r'[A-Za-z_][\w-]*', name):
            fail(key, f'{_show(name)} is not a name', 'letters, digits, _ or -')
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


def _clip(text, limit: int) -> str:
    """Return text on one line and at most limit characters (a key path may be long)."""
    text = ' '.join(str(text).split())
    return text if len(text) <= limit else text[:limit - 3] + '...'


def _check_runs(fail, key: str, count):
    """Refuse a ``runs`` (or ``--runs``) that is not a whole number from 1 to ``MAX_RUNS``."""
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        fail(key, f'is {_show(count)}', 'a whole number of runs >= 1')
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


def _check_draws(fail, variables, runs: int):
    """Refuse draws whose arithmetic overflows, and sweeps of more than ``MAX_RUNS`` runs."""
    total = runs
    for variable in variables:
        p = variable.params
        where = f'vary.{variable.path}.{variable.kind}'
        with np.errstate(all='ignore'):
            if variable.kind == 'uniform':
                spans = [p[1] - p[0]]
            elif variable.kind == 'normal':
                spans = [p[0] + 40.0 * p[1], p[0] - 40.0 * p[1]]
            elif variable.kind == 'truncnormal':
                spans = [(p[2] - p[0]) / p[1], (p[3] - p[0]) / p[1], p[3] - p[2]]
            else:
                spans = []
        if not all(math.isfinite(x) for x in spans):
            fail(where, f'is {_show(p)}: its draws overflow (beyond double precision)',
                 'bounds and spreads whose differences are finite numbers')
        if variable.kind == 'grid':
            total *= len(p)
    if total > MAX_RUNS:
        fail('runs', f'{runs:,} draws times the grids give {total:,} runs',
             f'at most {MAX_RUNS:,} runs in a sweep')


def _check_at_time(fail, key: str, t: float, rate: float):
    """Refuse an ``at`` time whose sample number overflows (beyond any run's samples)."""
    from cfem_ros.recording import offline
    if t * rate > offline.MAX_SAMPLES:
        fail(key, f'is {t:g} s, sample {t * rate:.4g} at rate_hz {rate:g}',
             f'a time within a run (at most {offline.MAX_SAMPLES:.4g} samples)')


def _check_unique_at(fail, metrics):
    """Refuse an ``at`` entry given twice (its columns would be duplicates)."""
    seen = {}
    for i, entry in enumerate(metrics.at):
        point = (entry.time, entry.body, entry.relative_to, entry.after)
        if point in seen:
            fail(f'metrics.at[{i}]', f'is the same as metrics.at[{seen[point]}] (time '
                 f'{entry.time:g} s, body {entry.body})', 'each entry once')
        seen[point] = i


def _check_new_keys(fail, base, variables, values, scenario):
    """
    Refuse a key path that adds a key the scenario format does not have (a typo).

    Each path that is not in the base scenario is set alone to run 0's value
    and the document parsed: an unknown key there is the sweep file's
    mistake, found before any run (a value a draw makes invalid is left to
    that run, a failed row with its reason).
    """
    for variable in variables:
        if resolve(base, variable.tokens)[3]:
            continue
        document = apply_values(base, [variable], {variable.path: values[variable.path][0]})
        try:
            parse_scenario(document, source=scenario)
        except ScenarioError as err:
            if err.problem == 'unknown key' and err.key.startswith(
                    format_key_path(variable.tokens[:-1])):
                fail(f'vary.{variable.path}', f'adds {err.key}, a key the scenario format '
                     f'does not have', err.expected or 'a key path of the scenario format')


def _number_list(fail, key, value, length=None):
    if not isinstance(value, list) or (length is not None and len(value) != length):
        fail(key, f'is {_show(value)}', f'a list of {length} numbers' if length
             else 'a list of numbers')
    for v in value:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            fail(key, f'holds {_show(v)}', 'finite numbers')
    return [float(v) for v in value]


def _parse_vary(fail, vary, base) -> list:
    if not isinstance(vary, dict):
        fail('vary', f'is {_show(vary)}', 'a mapping of key path -> distribution')
    variables = []
    for path, spec in vary.items():
        key = f'vary.{path}'
        try:
            tokens = parse_key_path(path)
        except ValueError:
            fail(key, f'{_show(path)} is not a key path',
                 'keys joined by dots, list indices in brackets: wrenches[1].force[2]')
        try:
            _, _, existing, exists = resolve(base, tokens)
        except KeyError as err:
            there = ('one of ' + ', '.join(err.args[1]) + ' (' if len(err.args) > 1
                     and err.args[1] else '(')
            fail(key, f'{err.args[0]}', there + 'a key path to a value of the base '
                 'scenario, or a new key under one of its mappings)')
        if not isinstance(spec, dict) or len(spec) != 1:
            fail(key, f'is {_show(spec)}', 'one distribution: ' + ', '.join(
                f'{{{name}: {what}}}' for name, what in DISTRIBUTIONS.items()))
        kind, params = next(iter(spec.items()))
        if kind not in DISTRIBUTIONS:
            fail(f'{key}.{kind}', 'unknown distribution', 'one of ' + ', '.join(DISTRIBUTIONS))
        where = f'{key}.{kind}'
        if kind in RANDOM_NUMBERS:
            if exists and (isinstance(existing, bool)
                           or not isinstance(existing, (int, float))):
                fail(key, f'draws numbers but the base scenario has {_show(existing)} there',
                     'a key path to a number (choice or grid for other values)')
            length = {'uniform': 2, 'normal': 2, 'truncnormal': 4}[kind]
            params = _number_list(fail, where, params, length)
            if kind == 'uniform' and not params[0] < params[1]:
                fail(where, f'is {_show(params)}', DISTRIBUTIONS[kind])
            if kind == 'normal' and params[1] < 0:
                fail(where, f'is {_show(params)}', DISTRIBUTIONS[kind])
            if kind == 'truncnormal' and not (params[1] > 0 and params[2] < params[3]):
                fail(where, f'is {_show(params)}', DISTRIBUTIONS[kind])
        elif not isinstance(params, list) or not params:
            fail(where, f'is {_show(params)}', DISTRIBUTIONS[kind])
        variables.append(Variable(path=path, tokens=tokens, kind=kind, params=params))
    return variables


def _parse_correlate(fail, correlate, variables) -> list:
    """Check ``correlate``: pairs of random key paths, rho in [-1, 1], a PSD matrix."""
    if not isinstance(correlate, list):
        fail('correlate', f'is {_show(correlate)}', 'a list of ' + CORRELATE_ENTRY)
    kinds = {v.path: v.kind for v in variables}
    drawn = [v.path for v in variables if v.kind in CORRELATABLE]
    pairs = {}
    for i, entry in enumerate(correlate):
        key = f'correlate[{i}]'
        if not isinstance(entry, list) or len(entry) != 3:
            fail(key, f'is {_show(entry)}', CORRELATE_ENTRY)
        for j in (0, 1):
            path = entry[j]
            if not isinstance(path, str) or path not in kinds:
                fail(f'{key}[{j}]', f'{_show(path)} is not a key path under vary',
                     'one of the key paths drawn at random: ' + (', '.join(drawn) or 'none'))
            if kinds[path] not in CORRELATABLE:
                fail(f'{key}[{j}]', f'{_show(path)} is a {kinds[path]}, not a random draw',
                     'a key path drawn from ' + ', '.join(CORRELATABLE) + ' (a grid runs '
                     'every value with every draw)')
        rho = entry[2]
        if isinstance(rho, bool) or not isinstance(rho, (int, float)) \
                or not math.isfinite(rho) or not -1 <= rho <= 1:
            fail(f'{key}[2]', f'is {_show(rho)}', 'a correlation rho with -1 <= rho <= 1')
        a, b = entry[0], entry[1]
        if a == b:
            fail(key, f'correlates {a} with itself', 'two different key paths')
        pair = tuple(sorted((a, b), key=list(kinds).index))
        if pair in pairs and pairs[pair][1] != rho:
            fail(key, f'gives {a} and {b} rho {rho!r}, correlate[{pairs[pair][0]}] gave '
                 f'{pairs[pair][1]!r}', 'each pair once')
        pairs.setdefault(pair, (i, float(rho)))
    correlations = [(a, b, rho) for (a, b), (_, rho) in pairs.items()]
    for paths, matrix in _blocks(variables, correlations):
        smallest = float(np.linalg.eigvalsh(matrix)[0])
        if smallest < -PSD_TOLERANCE:
            fail('correlate', f'the correlations of {", ".join(paths)} make a matrix that is '
                 f'not positive semi-definite (smallest eigenvalue {smallest:.6g})',
                 'correlations that can hold together (a pair not listed has rho 0; if '
                 'a~b and b~c are both 0.9, a~c must be at least 0.62)')
    return correlations


def _blocks(variables, correlations) -> list:
    """
    Split the correlated key paths into groups joined by correlations.

    Returns a list of (key paths in ``vary`` order, correlation matrix);
    pairs not given are uncorrelated.
    """
    order = [v.path for v in variables]
    group = {}
    for a, b, _ in correlations:
        joined = group.get(a, {a}) | group.get(b, {b})
        for path in joined:
            group[path] = joined
    blocks, seen = [], set()
    for path in order:
        if path in group and path not in seen:
            paths = [p for p in order if p in group[path]]
            seen.update(paths)
            matrix = np.eye(len(paths))
            for a, b, rho in correlations:
                if a in group[path]:
                    i, j = paths.index(a), paths.index(b)
                    matrix[i, j] = matrix[j, i] = rho
            blocks.append((paths, matrix))
    return blocks


def _factor(matrix: np.ndarray) -> np.ndarray:
    """
    Return A with A A^T = matrix: its Cholesky factor, or if singular its eigen-factor.

    A singular matrix (rho = 1, or rows that depend on each other) has no
    Cholesky factor; V sqrt(diag(lambda)) from its eigen-decomposition,
    eigenvalues within PSD_TOLERANCE of 0 taken as 0, does the same.
    """
    try:
        return np.linalg.cholesky(matrix)
    except np.linalg.LinAlgError:
        eigenvalues, vectors = np.linalg.eigh(matrix)
        eigenvalues[eigenvalues < PSD_TOLERANCE] = 0.0   # rounding of a zero, not a direction
        return vectors * np.sqrt(eigenvalues)


def _marginal(variable, z: np.ndarray) -> list:
    """Map standard normals z through the variable's inverse CDF: x = F^-1(Phi(z))."""
    from scipy.special import ndtr   # only where drawn, as truncnorm below
    p = variable.params
    if variable.kind == 'normal':
        return list(p[0] + p[1] * z)
    if variable.kind == 'uniform':
        x = p[0] + (p[1] - p[0]) * ndtr(z)
        return list(np.minimum(x, np.nextafter(p[1], p[0])))   # [low, high), as drawn alone
    if variable.kind == 'truncnormal':
        from scipy.stats import truncnorm
        a, b = (p[2] - p[0]) / p[1], (p[3] - p[0]) / p[1]
        lower = truncnorm.ppf(ndtr(z), a, b, loc=p[0], scale=p[1])
        upper = truncnorm.isf(ndtr(-z), a, b, loc=p[0], scale=p[1])   # each tail exact
        return list(np.clip(np.where(z < 0, lower, upper), p[2], p[3]))
    index = np.minimum(np.floor(ndtr(z) * len(p)).astype(int), len(p) - 1)   # choice
    return [p[i] for i in index]


def _points(fail, key, value):
    if value is None:
        return np.zeros((1, 3))
    if not isinstance(value, list) or not value:
        fail(key, f'is {_show(value)}', 'a list of points [x, y, z] in body axes, m')
    points = np.array([_number_list(fail, f'{key}[{i}]', p, 3) for i, p in enumerate(value)])
    far = np.flatnonzero(np.any(np.abs(points) > MAX_MAGNITUDE, axis=1))
    if far.size:   # as every scenario position: beyond it distances lose every digit
        fail(f'{key}[{far[0]}]', f'is {points[far[0]].tolist()}',
             f'a point within {MAX_MAGNITUDE:g} m (body axes)')
    return points


def _parse_metrics(fail, metrics, base, rate, model=None) -> Metrics:
    if not isinstance(metrics, dict):
        fail('metrics', f'is {_show(metrics)}', 'a mapping with clearance and at')
    for name in metrics:
        if name not in METRIC_KEYS:
            fail(f'metrics.{name}', 'unknown key', 'one of ' + ', '.join(METRIC_KEYS))
    bodies = list((base.get('bodies') or {}).keys())
    joints = list((base.get('joints') or {}).keys())

    def body(key, name):
        if name not in bodies:
            fail(key, f'{_show(name)} is not a body of the scenario', 'one of ' +
                 ', '.join(bodies))
        return name

    wrenches = base.get('wrenches') if isinstance(base.get('wrenches'), list) else []
    strokes = [w.get('name', f'wrench{k}') for k, w in enumerate(wrenches)
               if isinstance(w, dict) and w.get('stroke') is not None]
    aero = list(base['aero']) if isinstance(base.get('aero'), dict) else []
    out = Metrics(joints=joints, strokes=list(dict.fromkeys(strokes)), aero=aero)
    clearance = metrics.get('clearance') or []
    if not isinstance(clearance, list):
        fail('metrics.clearance', f'is {_show(clearance)}', 'a list of body pairs')
    seen = set()
    for i, entry in enumerate(clearance):
        key = f'metrics.clearance[{i}]'
        if not isinstance(entry, dict):
            fail(key, f'is {_show(entry)}', 'a mapping with bodies, points_a, points_b')
        for name in entry:
            if name not in CLEARANCE_KEYS:
                fail(f'{key}.{name}', 'unknown key', 'one of ' + ', '.join(CLEARANCE_KEYS))
        pair = entry.get('bodies')
        if not isinstance(pair, list) or len(pair) != 2 or pair[0] == pair[1]:
            fail(f'{key}.bodies', f'is {_show(pair)}', 'two different body names')
        a, b = body(f'{key}.bodies[0]', pair[0]), body(f'{key}.bodies[1]', pair[1])
        if (a, b) in seen:
            fail(f'{key}.bodies', f'{_show(pair)} is given twice', 'each pair once')
        seen.add((a, b))
        out.clearance.append(Clearance(a, b, _points(fail, f'{key}.points_a',
                                                     entry.get('points_a')),
                                       _points(fail, f'{key}.points_b', entry.get('points_b')),
                                       parse_window(fail, entry, key, base)))
    distance = metrics.get('distance') or []
    if not isinstance(distance, list):
        fail('metrics.distance', f'is {_show(distance)}', 'a list of {bodies: [a, b], from, to}')
    pairs = set()
    for i, entry in enumerate(distance):
        found = parse_distance(fail, entry, f'metrics.distance[{i}]', base, model)
        if (found.body_a, found.body_b) in pairs:
            fail(f'metrics.distance[{i}].bodies', 'repeats a pair', 'each pair once')
        pairs.add((found.body_a, found.body_b))
        out.distance.append(found)
    at = metrics.get('at') or []
    if not isinstance(at, list):
        fail('metrics.at', f'is {_show(at)}', 'a list of {time, body, relative_to}')
    for i, entry in enumerate(at):
        key = f'metrics.at[{i}]'
        if not isinstance(entry, dict):
            fail(key, f'is {_show(entry)}', 'a mapping {time, body, relative_to}')
        for name in entry:
            if name not in AT_KEYS:
                fail(f'{key}.{name}', 'unknown key', 'one of ' + ', '.join(AT_KEYS))
        t = entry.get('time')
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t) \
                or t < 0:
            fail(f'{key}.time', f'is {_show(t)}', 'a time >= 0 s')
        _check_at_time(fail, f'{key}.time', t, rate)
        after, groups = None, ()
        if 'after' in entry:   # from a release: between samples, interpolated
            after, groups = windowed.check_after(fail, key, entry['after'], base)
        elif abs(t * rate - round(t * rate)) > ON_GRID * max(1.0, t * rate):
            fail(f'{key}.time', f'is {t!r} s, between two samples at rate_hz {rate:g}',
                 f'a multiple of 1/rate_hz = {1 / rate:g} s (or a time after a release: '
                 '`after: <joint or group>`)')
        relative = entry.get('relative_to')
        out.at.append(At(float(t), body(f'{key}.body', entry.get('body')),
                         None if relative is None else body(f'{key}.relative_to', relative),
                         after, groups))
    out.extremes = windowed.parse_extremes(fail, metrics.get('extremes') or [], base, body)
    return out


def draw(variables, runs: int, seed: int, correlations=()) -> dict:
    """
    Draw every variable's values: ``runs`` random draws times every grid point.

    Run k = g * runs + i is draw i at grid point g (grids in file order, the
    last varying fastest), so every grid point sees the same random draws.
    A key path in ``correlations`` draws ``runs`` standard normals from its
    own generator instead; each group's are mixed by a factor of its
    correlation matrix and mapped through the marginals (``_marginal``).
    The others' draws are those they would have without ``correlations``.
    """
    sequences = np.random.SeedSequence(seed).spawn(len(variables))
    correlated = {path for a, b, _ in correlations for path in (a, b)}
    drawn, normals = {}, {}
    for variable, sequence in zip(variables, sequences):
        rng = np.random.default_rng(sequence)
        p = variable.params
        if variable.path in correlated:
            normals[variable.path] = rng.standard_normal(size=runs)
            continue
        if variable.kind == 'uniform':
            values = rng.uniform(p[0], p[1], size=runs)
        elif variable.kind == 'normal':
            values = rng.normal(p[0], p[1], size=runs)
        elif variable.kind == 'truncnormal':
            from scipy.stats import truncnorm   # only where drawn: a second to import
            a, b = (p[2] - p[0]) / p[1], (p[3] - p[0]) / p[1]
            values = truncnorm.rvs(a, b, loc=p[0], scale=p[1], size=runs, random_state=rng)
        elif variable.kind == 'choice':
            values = [p[i] for i in rng.integers(0, len(p), size=runs)]
        else:
            continue
        drawn[variable.path] = [_plain(v) for v in values]
    by_path = {v.path: v for v in variables}
    for paths, matrix in _blocks(variables, correlations):
        z = _factor(matrix) @ np.array([normals[path] for path in paths])
        for path, row in zip(paths, z):
            drawn[path] = [_plain(v) for v in _marginal(by_path[path], row)]
    grids = [v for v in variables if v.kind == 'grid']
    points = list(itertools.product(*[v.params for v in grids])) or [()]
    values = {}
    for variable in variables:
        if variable.kind == 'grid':
            g = grids.index(variable)
            values[variable.path] = [_plain(point[g]) for point in points for _ in range(runs)]
        else:
            values[variable.path] = drawn[variable.path] * len(points)
    return values
