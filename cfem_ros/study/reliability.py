# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
P(any criterion fails) by plain Monte Carlo or OpenTURNS' rare-event methods.

The sweep's distributions map one to one onto OpenTURNS marginals (normal
-> ``Normal``, uniform -> ``Uniform``, truncnormal -> ``TruncatedNormal``)
joined by a ``NormalCopula`` of the ``correlate`` matrix: the Gaussian
copula the sweep draws from. The limit state is the least criterion
margin (``criteria.margins``, < 0 where a criterion fails); every batch
of points a method asks for is run as sweep runs (``Evaluator``).

- ``subset``: subset sampling (conditional probability 0.1), ``runs`` points per
  level, in batches of ``runs`` x 0.1 (one step of every Markov chain).
- ``nais``: non-parametric adaptive importance sampling, ``runs`` per step.
- ``form``: FORM (Abdo-Rackwitz, finite-difference gradients in batches),
  then importance sampling around its design point, ``runs`` per batch,
  until the coefficient of variation reaches the target.
- ``mc``: the sweep's own draws, the failure fraction with its exact interval.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
import math
import signal
import threading
from typing import Optional

from cfem_ros.study.confidence import clopper_pearson
from cfem_ros.study.criteria import margins
from cfem_ros.study.draws import blocks
from cfem_ros.study.errors import SweepError
from cfem_ros.study.evaluate import random_variables
from cfem_ros.study.resources import MethodFailed
from cfem_ros.study.spec import SweepSpec
import numpy as np

#: Runs FORM's search for the design point may take, per parameter (+ 1).
FORM_CALLS = 150
#: Batches importance sampling may run after FORM, at most.
MAX_BATCHES = 100
#: Conditional probability of each subset level; quantile level of NAIS.
LEVEL_PROBABILITY = 0.1


@dataclass
class Estimate:
    """What ``estimate.json`` holds (SPEC section 9), with the level of the interval."""

    probability: float
    cov: float
    ci_low: float
    ci_high: float
    runs: int
    method: str
    level: float = 0.95
    failed_runs: Optional[int] = None   # runs that failed a criterion (None: not counted)

    def as_dict(self) -> dict:
        """Return the fields as plain JSON values."""
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in asdict(self).items()}

    def sentence(self) -> str:
        """Return the line ``cfem-sim sweep`` prints."""
        line = (f'P(any criterion fails) = {self.probability:.4g} by {self.method}, '
                f'coefficient of variation {self.cov:.3g}, {100 * self.level:g} % interval '
                f'[{self.ci_low:.4g}, {self.ci_high:.4g}], {self.runs} runs')
        if self.failed_runs == 0 and self.method == 'mc':
            line += f'; no run failed: P is at most {self.ci_high:.4g} at this confidence'
        elif self.failed_runs == 0:
            line += ('; no run failed: the estimate rests on no failure (extrapolated from '
                     'the runs nearest to failing), not a measured probability')
        return line


def distribution(spec: SweepSpec):
    """
    Return the sweep's joint input distribution as an OpenTURNS distribution.

    Raises
    ------
    SweepError
        If a key path is not drawn from numbers, or the correlations are
        singular (rho = +-1: no density for these methods to sample).

    """
    import openturns as ot
    variables = random_variables(spec, 'a rare-event method')
    marginals = []
    for v in variables:
        p = v.params
        if v.kind == 'normal':
            marginals.append(ot.Normal(p[0], p[1]))
        elif v.kind == 'uniform':
            marginals.append(ot.Uniform(p[0], p[1]))
        else:
            marginals.append(ot.TruncatedNormal(p[0], p[1], p[2], p[3]))
    order = [v.path for v in variables]
    matrix = np.eye(len(order))
    for paths, block in blocks(variables, spec.correlations):
        index = [order.index(path) for path in paths]
        matrix[np.ix_(index, index)] = block
    if np.linalg.eigvalsh(matrix)[0] < 1e-9:
        raise SweepError(spec.path, 'correlate', 'makes a singular correlation matrix (rho '
                         '+-1, or rows that depend on each other)', 'correlations strictly '
                         'between -1 and 1 for a rare-event method (or one key path instead '
                         'of two that move together)')
    copula = ot.NormalCopula(ot.CorrelationMatrix(matrix.tolist())) if spec.correlations \
        else ot.IndependentCopula(len(order))
    return ot.JointDistribution(marginals, copula)


def estimate(spec: SweepSpec, method: str, evaluate, criteria, target_cov: float = 0.1,
             runs: int = 1000) -> Estimate:
    """
    Estimate P(any criterion fails) by a rare-event method.

    Parameters
    ----------
    spec : SweepSpec
        The sweep: its distributions, correlations, seed and confidence.
    method : str
        'subset', 'nais', 'form', or 'mc' (the sweep's own draws).
    evaluate : callable
        points (n, d) -> table rows (an ``Evaluator``).
    criteria : list of Criterion
        The rules; the event is "the least margin is below 0".
    target_cov : float
        FORM's importance sampling stops at this coefficient of variation.
    runs : int
        Points per level (subset), per step (nais), per batch (form).

    """
    import openturns as ot
    if method == 'mc':
        from cfem_ros.study.criteria import judge
        from cfem_ros.study.evaluate import table_values
        return mc_estimate(spec, judge(evaluate(table_values(spec)), criteria))
    if not criteria:
        raise SweepError(spec.path, 'criteria', f'is empty: --method {method} estimates the '
                         'probability that a criterion fails', 'at least one rule')
    joint = distribution(spec)
    ot.Log.Show(ot.Log.ERROR)   # its warnings are not the user's to act on
    ot.RandomGenerator.SetSeed(spec.seed)
    raised = []
    handlers = _handlers()

    def limit_state(points):
        try:
            for signum, handler in handlers.items():
                # OpenTURNS puts its own SIGINT handler around each call of a Python
                # function, and that one crashes the process when it fires: the caller's rule
                signal.signal(signum, handler)
            if raised:   # an optimizer may go on after a failed call: every call fails now
                raise raised[0]
            table = evaluate(np.array(points))
        except BaseException as err:   # OpenTURNS wraps it: kept to raise it as it is
            if not raised:
                raised.append(err)
            raise
        return margins(table, criteria).reshape(-1, 1)

    try:
        found = _run(ot, spec, method, joint, limit_state, evaluate, target_cov, runs)
    except Exception as err:   # noqa: B902 (what the limit state raised, not its wrapping)
        if raised:
            raise raised[0] from None
        if isinstance(err, SweepError):
            raise
        for signum in (signal.SIGINT, signal.SIGTERM):
            if signal.Signals(signum).name in str(err):
                # OpenTURNS' own handler took the signal (between two calls) and raised it as
                # an error: give it to the program's handler, which stops the study there
                signal.raise_signal(signum)
        # OpenTURNS' own failures (a degenerate sample: no spread left to adapt to)
        why = ' '.join(str(err).split())[:200]
        raise MethodFailed(spec.path, f'--method {method}', f'stopped after {evaluate.count} '
                           f'runs: OpenTURNS could not go on ({type(err).__name__}: {why})',
                           'more --runs, or another method (form, subset, or mc)') from None
    if raised:   # swallowed by the method: not an estimate
        raise raised[0]
    return found


def _handlers() -> dict:
    """Return the Python handlers of SIGINT and SIGTERM (none off the main thread)."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    found = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    return {s: h for s, h in found.items() if h is not None}


def _run(ot, spec, method, joint, limit_state, evaluate, target_cov, runs) -> Estimate:
    """Run one OpenTURNS method on the limit state and return its estimate."""
    dimension = joint.getDimension()
    function = ot.MemoizeFunction(ot.PythonFunction(dimension, 1, func_sample=limit_state))
    output = ot.CompositeRandomVector(function, ot.RandomVector(joint))
    event = ot.ThresholdEvent(output, ot.Less(), 0.0)
    if method == 'subset':
        # the chains (runs x p0 of them) advance one step per batch: asking for a whole
        # level at once (block size = runs) gives estimates biased low in OpenTURNS 1.27
        chains = max(1, round(runs * LEVEL_PROBABILITY))
        algorithm = ot.SubsetSampling(ot.StandardEvent(event), 2.0, LEVEL_PROBABILITY)
        algorithm.setBlockSize(chains)
        algorithm.setMaximumOuterSampling(max(1, round(runs / chains)))
    elif method == 'nais':
        algorithm = ot.NAIS(ot.StandardEvent(event), LEVEL_PROBABILITY)
        algorithm.setBlockSize(runs)
        algorithm.setMaximumOuterSampling(1)
    elif method == 'form':
        optimizer = ot.AbdoRackwitz()
        optimizer.setMaximumCallsNumber(FORM_CALLS * (dimension + 1))
        optimizer.setStartingPoint(joint.getMean())   # physical space
        form = ot.FORM(optimizer, event)
        try:
            form.run()
        except RuntimeError as err:   # no design point within the budget
            if 'maximum calls' not in str(err):
                raise
            raise MethodFailed(spec.path, '--method form', f'found no design point in '
                               f'{FORM_CALLS * (dimension + 1)} runs (the search did not '
                               'converge)', 'a failure region FORM can reach, or --method '
                               'nais or subset') from None
        found = form.getResult()
        point = ', '.join(f'{v.path} = {x:.6g}' for v, x in zip(
            spec.variables, found.getPhysicalSpaceDesignPoint()))
        evaluate.log(f'design point {point}; reliability index '
                     f'{found.getHasoferReliabilityIndex():.4g}, P(fail) by FORM '
                     f'{found.getEventProbability():.4g}; importance sampling around it')
        algorithm = ot.PostAnalyticalImportanceSampling(found)
        algorithm.setBlockSize(runs)
        algorithm.setMaximumOuterSampling(MAX_BATCHES)
        algorithm.setMaximumCoefficientOfVariation(target_cov)
    else:
        raise ValueError(f'method is {method!r}; expected one of mc, subset, nais, form')
    algorithm.run()
    result = algorithm.getResult()
    p = float(result.getProbabilityEstimate())
    cov = float(result.getCoefficientOfVariation()) if p > 0 else math.inf
    low = high = p
    if p > 0:   # the normal law of the estimate that OpenTURNS gives
        interval = result.getProbabilityDistribution().computeBilateralConfidenceInterval(
            spec.confidence)
        low, high = interval.getLowerBound()[0], interval.getUpperBound()[0]
    return Estimate(p, cov, max(0.0, low), min(1.0, high), evaluate.count, method,
                    spec.confidence)


def mc_estimate(spec: SweepSpec, table):
    """Return the estimate of a judged Monte Carlo table: fraction, exact interval (valid runs)."""
    from cfem_ros.study.criteria import judge, valid_runs
    if 'pass' not in table:
        table = judge(table, spec.criteria)
    table = valid_runs(table)   # invalid draws: not run, neither pass nor failure
    failed = int((~table['pass'].to_numpy(dtype=bool)).sum())
    n = len(table)
    if not n:
        raise SweepError(spec.path, 'vary', "gives no valid draw: the scenario's checks "
                         'refuse every run', 'distributions whose draws make valid scenarios')
    p = failed / n
    low, high = clopper_pearson(failed, n, spec.confidence)
    cov = math.sqrt((1 - p) / (n * p)) if failed else math.inf
    return Estimate(p, cov, low, high, n, 'mc', spec.confidence, failed_runs=failed)
