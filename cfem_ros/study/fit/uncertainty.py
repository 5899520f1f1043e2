# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What the data say about the fitted parameters: determined or not, errors, correlations.

From the weighted Jacobian J at the solution and the weighted residuals r:

- a parameter whose column is zero (the poses in the window do not change
  with it) is not determined, for that reason;
- the columns scaled to unit length, their singular vectors whose singular
  value is below ``INTERCHANGEABLE`` are directions along which the poses
  do not change: the parameters that make them up can be traded one for
  another (an area and an altitude: both scale the dynamic pressure times
  the area). They are named together, with the correlation of their
  columns, and are not determined;
- the determined parameters' covariance is (J^T J)^-1 over their columns
  (the others held at their start values), the standard error its
  diagonal's square root, and ``standard_error_scaled`` that times
  sqrt(max(1, reduced chi-square)): a reduced chi-square above 1 says the
  residuals are larger than the stated sigmas, and the errors grow with it;
- two determined parameters correlated beyond ``NEARLY`` are named as well.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math

import numpy as np

#: A direction of the unit-scaled columns with a singular value below this cannot be told
#: apart by the data (two columns whose correlation is above 1 - 5e-7).
INTERCHANGEABLE = 1e-3
#: A parameter with at least this weight in such a direction (a share of 1 %: its variance
#: grows by 1e4 times the poses' sensitivity along it) is named in it and not determined.
NAMED_WEIGHT = 0.1
#: Determined parameters correlated beyond this are named as nearly interchangeable.
NEARLY = 0.999
#: A reduced chi-square above this is said in a WARNING line.
CHI2_WARNING = 2.0
#: Residuals whose lag-1 autocorrelation has a p-value below this (white noise: about 1
#: flight in 1,000) are said not to be noise, in a WARNING line ...
STRUCTURE_P = 1e-3
#: ... when their size is at least this share of the stated variance (below it they are
#: the interpolation's and the solver's rounding, not the data's).
STRUCTURE_SIZE = 0.25
#: Fewer samples than this in a flight's window: no test of its residuals.
STRUCTURE_SAMPLES = 10
QUANTITY_NAMES = ('x', 'y', 'z', 'roll', 'pitch', 'yaw')


@dataclass
class Uncertainty:
    """The fitted parameters' errors and what the data cannot tell."""

    determined: np.ndarray            # bool per parameter
    covariance: np.ndarray            # unscaled, NaN rows/columns for the undetermined
    standard_errors: np.ndarray
    standard_errors_scaled: np.ndarray
    correlation: np.ndarray
    reduced_chi2: float
    chi2: float
    dof: int
    problems: list = field(default_factory=list)   # (status, sentence)


def columns_flat(jacobian: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """Return which columns do not change the residuals (by 1e-10 sigma over a step)."""
    return np.linalg.norm(jacobian, axis=0) * np.abs(steps) <= 1e-10


def interchangeable_groups(jacobian: np.ndarray, usable: np.ndarray) -> tuple:
    """
    Return (groups, undetermined) of the usable columns.

    groups: lists of column indices, each a direction along which the poses
    do not change, with the largest correlation of their columns.
    """
    n = jacobian.shape[1]
    index = np.flatnonzero(usable)
    undetermined = np.zeros(n, dtype=bool)
    if index.size < 2:
        return [], undetermined
    columns = jacobian[:, index]
    unit = columns / np.linalg.norm(columns, axis=0)
    _, singular, vt = np.linalg.svd(unit, full_matrices=False)
    weak = vt[singular < INTERCHANGEABLE]
    share = (weak ** 2).sum(axis=0) if weak.size else np.zeros(index.size)
    undetermined[index[share >= NAMED_WEIGHT ** 2]] = True
    cosine = unit.T @ unit
    groups = []
    for direction in weak:
        members = [int(k) for k in np.flatnonzero(np.abs(direction) >= NAMED_WEIGHT)]
        if len(members) < 2:
            continue
        pairs = [(cosine[a, b], a, b) for i, a in enumerate(members) for b in members[i + 1:]]
        strongest = max(pairs, key=lambda p: abs(p[0]))
        groups.append(([int(index[k]) for k in members], -float(strongest[0])))
    return groups, undetermined


def analyse(jacobian: np.ndarray, r: np.ndarray, parameters, steps,
            held=None) -> Uncertainty:
    """
    Return the parameters' uncertainty from the weighted Jacobian and residuals.

    held: parameters already found undetermined and held at their start
    values (left out, said before).
    """
    n = jacobian.shape[1]
    names = [p.name for p in parameters]
    problems = []
    held = np.zeros(n, dtype=bool) if held is None else np.asarray(held, dtype=bool)
    flat = columns_flat(jacobian, np.asarray(steps, dtype=float)) & ~held
    for j in np.flatnonzero(flat):
        problems.append(('not_determined', f'{names[j]} is not determined by the measured '
                         'poses in the window (they do not change with it): fix it in the '
                         'scenario, or widen the window to where it acts; it keeps its '
                         'start value'))
    flat |= held
    groups, interchangeable = interchangeable_groups(jacobian, ~flat)
    for members, correlation in groups:
        problems.append(('not_determined', f'{_names(names, members)} are interchangeable '
                         f'here: correlation {correlation:+.5f} (the poses change along one '
                         f'combination of them only); fix {_fix(members)}; they keep their '
                         'start values'))
    determined = ~flat & ~interchangeable
    covariance = np.full((n, n), math.nan)
    if determined.any():
        columns = jacobian[:, determined]
        _, singular, vt = np.linalg.svd(columns, full_matrices=False)
        inner = (vt.T / singular ** 2) @ vt if singular.min() > 0 else \
            np.full((vt.shape[1],) * 2, math.nan)
        covariance[np.ix_(determined, determined)] = inner
    chi2 = float(r @ r)
    dof = r.size - int(determined.sum())
    reduced = chi2 / dof if dof > 0 else math.nan
    errors = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    errors[~determined] = math.nan
    scaled = errors * math.sqrt(max(1.0, reduced)) if math.isfinite(reduced) else errors
    with np.errstate(invalid='ignore', divide='ignore'):
        correlation = covariance / np.outer(errors, errors)
    np.fill_diagonal(correlation, np.where(determined, 1.0, math.nan))
    for i in range(n):
        for k in range(i + 1, n):
            c = correlation[i, k]
            if math.isfinite(c) and abs(c) > NEARLY:
                problems.append(('interchangeable', f'{names[i]} and {names[k]} are nearly '
                                 f'interchangeable here: correlation {c:+.5f}; their errors '
                                 'are large together: fix one if another source knows it'))
    return Uncertainty(determined=determined, covariance=covariance, standard_errors=errors,
                       standard_errors_scaled=scaled, correlation=correlation,
                       reduced_chi2=reduced, chi2=chi2, dof=dof, problems=problems)


def _names(names, members) -> str:
    shown = [names[k] for k in members]
    return shown[0] + ' and ' + shown[1] if len(shown) == 2 else \
        ', '.join(shown[:-1]) + ' and ' + shown[-1]


def _fix(members) -> str:
    return 'one' if len(members) == 2 else f'{len(members) - 1} of them'


def residual_structure(r: np.ndarray) -> dict:
    """
    Return whether one flight's weighted residuals look like white noise.

    r: the flight's weighted residuals, 6 per sample in time order. Per
    quantity, the lag-1 autocorrelation rho of the residuals (mean removed);
    for white noise rho sqrt(n) is about N(0, 1), so the Box-Pierce statistic
    n sum(rho^2) over the quantities that vary is chi-square with as many
    degrees of freedom. A model that misses something (a parameter held at a
    wrong value, a load left out) leaves residuals that follow the
    trajectory: autocorrelated, whatever the reduced chi-square; noise that
    is correlated between samples does too, and then the standard errors are
    too small as well.

    Returns
    -------
    dict
        ``autocorrelation`` (per quantity, None where it does not vary),
        ``p`` (NaN below ``STRUCTURE_SAMPLES`` samples), ``size`` (the
        residuals' mean square, in stated variances).

    """
    from scipy.special import chdtrc   # chi2.sf's own function (scipy.stats costs 0.3 s)
    samples = r.reshape(-1, 6)
    n = len(samples)
    out = {'autocorrelation': {}, 'p': math.nan,
           'size': float(np.mean(samples ** 2)) if n else math.nan}
    statistic, count = 0.0, 0
    for q, name in enumerate(QUANTITY_NAMES):
        x = samples[:, q] - samples[:, q].mean() if n else samples[:, q]
        energy = float(x @ x)
        if n < 2 or energy <= 0.0:
            out['autocorrelation'][name] = None
            continue
        rho = float(x[1:] @ x[:-1]) / energy
        out['autocorrelation'][name] = rho
        statistic += n * rho ** 2
        count += 1
    if n >= STRUCTURE_SAMPLES and count:
        out['p'] = float(chdtrc(count, statistic))
    return out


def structure_warning(key: str, structure: dict) -> str:
    """Return the WARNING sentence of a flight whose residuals are not noise ('' if none)."""
    p = structure['p']
    if not math.isfinite(p) or p >= STRUCTURE_P or not structure['size'] >= STRUCTURE_SIZE:
        return ''
    rho = {k: v for k, v in structure['autocorrelation'].items() if v is not None}
    worst = max(rho, key=lambda k: abs(rho[k]))
    return (f'the residuals of {key} are not noise: their lag-1 autocorrelation is '
            f'{rho[worst]:+.2f} in {worst} (p = {p:.2g} for white noise): the model misses '
            'something the data show (a parameter held at a wrong value, a load left out) '
            'or the noise is correlated between samples; the standard errors do not '
            'include that')


def chi2_warning(reduced: float) -> str:
    """Return the WARNING sentence of a reduced chi-square above 2 ('' if none)."""
    if not math.isfinite(reduced) or reduced <= CHI2_WARNING:
        return ''
    return (f'reduced chi-square {reduced:.3g} > {CHI2_WARNING:g}: the residuals are '
            f'{math.sqrt(reduced):.3g} times the stated sigmas (the sigmas are too small, or '
            'the model cannot follow the data); the standard errors printed are scaled by '
            f'{math.sqrt(reduced):.3g}')
