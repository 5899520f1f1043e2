# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Which dispersions drive a metric: Morris screening and Sobol indices with SALib.

SALib draws the design in the unit cube (Morris trajectories on a
4-level grid; Saltelli's extension of a scrambled Sobol sequence), each
coordinate a probability mapped through the key path's inverse CDF (the
marginal the sweep draws from). Morris' grid levels 0 and 1 are taken as
the probabilities ``MORRIS_TAIL`` and 1 - ``MORRIS_TAIL`` (a normal's
+-3.09 standard deviations), so its elementary effects are per unit of
probability. Both methods assume independent inputs: a sweep with
``correlate`` is refused (the indices of correlated inputs need other
methods, e.g. Shapley effects, which SALib does not have).
"""

from __future__ import annotations

import math

from cfem_ros.core.errors import ArgumentError
from cfem_ros.study.draws import marginal
from cfem_ros.study.errors import SweepError
from cfem_ros.study.evaluate import random_variables
from cfem_ros.study.spec import SweepSpec
import numpy as np

#: Probability the Morris grid's levels 0 and 1 stand for (and 1 minus it).
MORRIS_TAIL = 1e-3
MORRIS_LEVELS = 4
#: Bootstrap resamples of the confidence intervals.
RESAMPLES = 1000


def problem(spec: SweepSpec, design: str) -> dict:
    """
    Return SALib's problem: the varied key paths in the unit cube.

    Raises
    ------
    SweepError
        If a key path is not drawn from numbers, or the sweep correlates them.

    """
    variables = random_variables(spec, f'--design {design}')
    if spec.correlations:
        raise SweepError(spec.path, 'correlate', f'--design {design} needs independent '
                         'inputs (Morris and Sobol indices of correlated inputs mislead)',
                         'no correlate entries for a sensitivity study (run the correlated '
                         'key paths as one, or study them with --method mc)')
    return {'num_vars': len(variables), 'names': [v.path for v in variables],
            'bounds': [[0.0, 1.0]] * len(variables)}


def design_points(spec: SweepSpec, design: str) -> tuple:
    """
    Return (unit-cube design (n, d), the key paths' values there (n, d)).

    ``spec.runs`` is Morris' trajectories (n = runs x (d + 1)) or Sobol's
    base sample, rounded up to a power of 2 (n = base x (d + 2)).
    """
    salib = problem(spec, design)
    if design == 'morris':
        from SALib.sample import morris
        unit = morris.sample(salib, spec.runs, num_levels=MORRIS_LEVELS, seed=spec.seed)
        probability = MORRIS_TAIL + (1 - 2 * MORRIS_TAIL) * unit
    elif design == 'sobol':
        from SALib.sample import sobol
        base = 2 ** max(1, math.ceil(math.log2(spec.runs)))
        unit = sobol.sample(salib, base, calc_second_order=False, scramble=True,
                            seed=spec.seed)
        probability = np.clip(unit, 1e-12, 1 - 1e-12)
    else:
        raise ArgumentError(f'design is {design!r}; expected morris or sobol')
    from scipy.special import ndtri
    values = np.column_stack([np.asarray(marginal(v, ndtri(probability[:, i])), dtype=float)
                              for i, v in enumerate(spec.variables)])
    return unit, values


def metrics_to_rank(table, spec: SweepSpec) -> list:
    """
    Return the metric columns that get indices.

    Those with a number in every run that vary by more than rounding
    (``rounding.rounding_only``).
    """
    from cfem_ros.study.rounding import rounding_only
    out = []
    for name in spec.metrics.columns() + [n for c in spec.criteria for n in c.columns]:
        if name in out or name not in table or name.endswith(('_cause', '_point_a',
                                                              '_point_b')):
            continue
        values = table[name].to_numpy(dtype=float)
        if np.isfinite(values).all() and np.ptp(values) > 0 \
                and not rounding_only(table, name, spec.document):
            out.append(name)
    return out


def within(value: float, half: float, least: float, most: float) -> tuple:
    """
    Return (value, low, high) of an index and its interval, kept within what it can be.

    SALib's intervals are the estimate +- a bootstrap half-width, and
    Saltelli's estimators of S1 and ST can fall outside [0, 1] by their
    sampling error: an index that cannot be negative (mu_star, S1, ST) or
    above 1 (S1, ST) is known to lie in [least, most], so the estimate
    and both ends are moved into that range (the interval then holds the
    index whenever the unclipped one did, and the estimate is nearer).
    """
    def clip(x):
        return min(max(x, least), most)
    return clip(value), clip(value - half), clip(value + half)


def indices(spec: SweepSpec, design: str, unit: np.ndarray, table) -> 'pandas.DataFrame':  # noqa
    """
    Return the indices of every metric to rank, one row per (metric, parameter).

    Morris: ``mu_star`` (mean |elementary effect|, metric unit per unit of
    probability), its bounds ``mu_star_low``/``mu_star_high``, ``sigma``.
    Sobol: ``S1`` and ``ST`` with ``_low``/``_high`` bounds. The bounds
    are at the sweep's confidence (SALib's bootstrap), each index and its
    bounds within what the index can be (``within``: mu_star >= 0, S1 and
    ST in [0, 1]).
    """
    import pandas as pd
    salib = problem(spec, design)
    rows = []
    for metric in metrics_to_rank(table, spec):
        y = table[metric].to_numpy(dtype=float)
        if design == 'morris':
            from SALib.analyze import morris
            result = morris.analyze(salib, unit, y, num_resamples=RESAMPLES,
                                    conf_level=spec.confidence, num_levels=MORRIS_LEVELS,
                                    seed=spec.seed)
            for i, name in enumerate(salib['names']):
                mu_star, low, high = within(float(result['mu_star'][i]),
                                            float(result['mu_star_conf'][i]), 0.0, math.inf)
                rows.append({'metric': metric, 'parameter': name, 'mu_star': mu_star,
                             'mu_star_low': low, 'mu_star_high': high,
                             'sigma': float(result['sigma'][i]), 'mu': float(result['mu'][i])})
        else:
            from SALib.analyze import sobol
            result = sobol.analyze(salib, y, calc_second_order=False, num_resamples=RESAMPLES,
                                   conf_level=spec.confidence, seed=spec.seed)
            for i, name in enumerate(salib['names']):
                row = {'metric': metric, 'parameter': name}
                for index in ('S1', 'ST'):
                    value, low, high = within(float(result[index][i]),
                                              float(result[f'{index}_conf'][i]), 0.0, 1.0)
                    row.update({index: value, f'{index}_low': low, f'{index}_high': high})
                rows.append(row)
    return pd.DataFrame.from_records(rows)


def run_design(spec: SweepSpec, design: str, evaluate):
    """Run the design's points (``evaluate``: an ``Evaluator``); return (indices, runs' table)."""
    unit, values = design_points(spec, design)
    table = evaluate(values)
    return indices(spec, design, unit, table), table
