# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A sweep's ``vary`` and ``correlate`` (SPEC section 6): the distributions, and the draws.

Each varied key path has its own generator
(``numpy.random.SeedSequence(seed).spawn``), so the table never depends on
how the runs are shared out. Key paths listed in ``correlate`` are joined by
a Gaussian copula: each still draws its own standard normals from its own
generator; these are mixed by a factor of the correlation matrix and mapped
through each declared marginal's inverse CDF.
"""

from __future__ import annotations

from dataclasses import dataclass
import itertools
import math

from cfem_ros.core.fileio.messages import show
from cfem_ros.study.errors import number_list
from cfem_ros.study.keypaths import parse_key_path, resolve
import numpy as np

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
#: Most runs in a sweep (draws times grid points): each is a task and a row.
MAX_RUNS = 1_000_000


@dataclass
class Variable:
    """One varied key path: its distribution and its parameters."""

    path: str
    tokens: tuple
    kind: str
    params: list


def parse_vary(fail, vary, base) -> list:
    if not isinstance(vary, dict):
        fail('vary', f'is {show(vary)}', 'a mapping of key path -> distribution')
    variables = []
    for path, spec in vary.items():
        key = f'vary.{path}'
        try:
            tokens = parse_key_path(path)
        except ValueError:
            fail(key, f'{show(path)} is not a key path',
                 'keys joined by dots, list indices in brackets: wrenches[1].force[2]')
        try:
            _, _, existing, exists = resolve(base, tokens)
        except KeyError as err:
            there = ('one of ' + ', '.join(err.args[1]) + ' (' if len(err.args) > 1
                     and err.args[1] else '(')
            fail(key, f'{err.args[0]}', there + 'a key path to a value of the base '
                 'scenario, or a new key under one of its mappings)')
        if not isinstance(spec, dict) or len(spec) != 1:
            fail(key, f'is {show(spec)}', 'one distribution: ' + ', '.join(
                f'{{{name}: {what}}}' for name, what in DISTRIBUTIONS.items()))
        kind, params = next(iter(spec.items()))
        if kind not in DISTRIBUTIONS:
            fail(f'{key}.{kind}', 'unknown distribution', 'one of ' + ', '.join(DISTRIBUTIONS))
        where = f'{key}.{kind}'
        if kind in RANDOM_NUMBERS:
            if exists and (isinstance(existing, bool)
                           or not isinstance(existing, (int, float))):
                fail(key, f'draws numbers but the base scenario has {show(existing)} there',
                     'a key path to a number (choice or grid for other values)')
            length = {'uniform': 2, 'normal': 2, 'truncnormal': 4}[kind]
            params = number_list(fail, where, params, length)
            if kind == 'uniform' and not params[0] < params[1]:
                fail(where, f'is {show(params)}', DISTRIBUTIONS[kind])
            if kind == 'normal' and params[1] < 0:
                fail(where, f'is {show(params)}', DISTRIBUTIONS[kind])
            if kind == 'truncnormal' and not (params[1] > 0 and params[2] < params[3]):
                fail(where, f'is {show(params)}', DISTRIBUTIONS[kind])
        elif not isinstance(params, list) or not params:
            fail(where, f'is {show(params)}', DISTRIBUTIONS[kind])
        variables.append(Variable(path=path, tokens=tokens, kind=kind, params=params))
    return variables


def parse_correlate(fail, correlate, variables) -> list:
    """Check ``correlate``: pairs of random key paths, rho in [-1, 1], a PSD matrix."""
    if not isinstance(correlate, list):
        fail('correlate', f'is {show(correlate)}', 'a list of ' + CORRELATE_ENTRY)
    kinds = {v.path: v.kind for v in variables}
    drawn = [v.path for v in variables if v.kind in CORRELATABLE]
    pairs = {}
    for i, entry in enumerate(correlate):
        key = f'correlate[{i}]'
        if not isinstance(entry, list) or len(entry) != 3:
            fail(key, f'is {show(entry)}', CORRELATE_ENTRY)
        for j in (0, 1):
            path = entry[j]
            if not isinstance(path, str) or path not in kinds:
                fail(f'{key}[{j}]', f'{show(path)} is not a key path under vary',
                     'one of the key paths drawn at random: ' + (', '.join(drawn) or 'none'))
            if kinds[path] not in CORRELATABLE:
                fail(f'{key}[{j}]', f'{show(path)} is a {kinds[path]}, not a random draw',
                     'a key path drawn from ' + ', '.join(CORRELATABLE) + ' (a grid runs '
                     'every value with every draw)')
        rho = entry[2]
        if isinstance(rho, bool) or not isinstance(rho, (int, float)) \
                or not math.isfinite(rho) or not -1 <= rho <= 1:
            fail(f'{key}[2]', f'is {show(rho)}', 'a correlation rho with -1 <= rho <= 1')
        a, b = entry[0], entry[1]
        if a == b:
            fail(key, f'correlates {a} with itself', 'two different key paths')
        pair = tuple(sorted((a, b), key=list(kinds).index))
        if pair in pairs and pairs[pair][1] != rho:
            fail(key, f'gives {a} and {b} rho {rho!r}, correlate[{pairs[pair][0]}] gave '
                 f'{pairs[pair][1]!r}', 'each pair once')
        pairs.setdefault(pair, (i, float(rho)))
    correlations = [(a, b, rho) for (a, b), (_, rho) in pairs.items()]
    for paths, matrix in blocks(variables, correlations):
        smallest = float(np.linalg.eigvalsh(matrix)[0])
        if smallest < -PSD_TOLERANCE:
            fail('correlate', f'the correlations of {", ".join(paths)} make a matrix that is '
                 f'not positive semi-definite (smallest eigenvalue {smallest:.6g})',
                 'correlations that can hold together (a pair not listed has rho 0; if '
                 'a~b and b~c are both 0.9, a~c must be at least 0.62)')
    return correlations


def check_draws(fail, variables, runs: int):
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
            fail(where, f'is {show(p)}: its draws overflow (beyond double precision)',
                 'bounds and spreads whose differences are finite numbers')
        if variable.kind == 'grid':
            total *= len(p)
    if total > MAX_RUNS:
        fail('runs', f'{runs:,} draws times the grids give {total:,} runs',
             f'at most {MAX_RUNS:,} runs in a sweep')


def blocks(variables, correlations) -> list:
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


def marginal(variable, z: np.ndarray) -> list:
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


def draw(variables, runs: int, seed: int, correlations=()) -> dict:
    """
    Draw every variable's values: ``runs`` random draws times every grid point.

    Run k = g * runs + i is draw i at grid point g (grids in file order, the
    last varying fastest), so every grid point sees the same random draws.
    A key path in ``correlations`` draws ``runs`` standard normals from its
    own generator instead; each group's are mixed by a factor of its
    correlation matrix and mapped through the marginals (``marginal``).
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
    for paths, matrix in blocks(variables, correlations):
        z = _factor(matrix) @ np.array([normals[path] for path in paths])
        for path, row in zip(paths, z):
            drawn[path] = [_plain(v) for v in marginal(by_path[path], row)]
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


def _plain(value):
    """Return a value as plain Python (floats, ints, str, lists), as YAML would give it."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value
