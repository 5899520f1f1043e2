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
  level, in batches of ``runs`` x 0.1 (one step of every Markov chain),
  repeated K times (``--repeat``), each with its own seed.
- ``nais``: non-parametric adaptive importance sampling, ``runs`` per step.
- ``form``: FORM (improved HL-RF, each iteration's runs and centred-difference
  gradient in one batch), then importance sampling around its design point, ``runs`` per batch,
  at least K batches, until the coefficient of variation reaches the target.
- ``mc``: the sweep's own draws, the failure fraction with its exact bounds.

Every method gives a one-sided bound ``p_upper`` (``samplers``, ``bounds``)
and the tail check (``tails``); ``decision`` turns them into a decision.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
import math
import signal
import threading
from typing import Optional

from cfem_ros.core.errors import ArgumentError
from cfem_ros.study.confidence import clopper_pearson
from cfem_ros.study.criteria import margins
from cfem_ros.study.decision import down, up
from cfem_ros.study.draws import blocks
from cfem_ros.study.errors import SweepError
from cfem_ros.study.evaluate import random_variables
from cfem_ros.study.resources import MethodFailed
from cfem_ros.study.spec import SweepSpec
from cfem_ros.study.tails import DOF, mc_tail, normals, SCALE, Tail
import numpy as np

#: Runs FORM's search for the design point may take, per parameter (+ 1).
FORM_CALLS = 150
#: Independent repetitions of subset sampling (--repeat); least batches after FORM.
REPEAT = 5


@dataclass
class Estimate:
    """
    What ``estimate.json`` holds (SPEC section 9), with the level of its bounds.

    ``ci_low``/``ci_high`` are two-sided and ``p_upper`` one-sided at
    ``level``: exact (Clopper-Pearson) for Monte Carlo, Student-t over
    independent batches or repetitions for the others (``bound`` says
    which); NaN when the runs cannot bound P. ``tail_*`` is the tail check,
    ``target``/``decision``/``decision_sentence`` the decision
    (``decision``), when the sweep file has a ``target``.
    """

    probability: float
    cov: float
    ci_low: float
    ci_high: float
    runs: int
    method: str
    level: float = 0.95
    failed_runs: Optional[int] = None   # runs that failed a criterion (None: not counted)
    p_upper: float = math.nan
    p_lower: float = math.nan
    bound: str = ''
    tail_probability: Optional[float] = None
    tail_p_upper: Optional[float] = None
    tail_note: str = ''
    form_probability: Optional[float] = None
    disagreement: str = ''
    target: Optional[float] = None
    decision: Optional[str] = None
    decision_sentence: str = ''

    def as_dict(self) -> dict:
        """Return the fields as plain JSON values (NaN and inf as None)."""
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, held: dict) -> 'Estimate':
        """Return the estimate an ``estimate.json`` holds (None read back as NaN or inf)."""
        names = {f.name for f in fields(cls)}
        values = {k: v for k, v in held.items() if k in names}
        for key in ('cov', 'ci_low', 'ci_high', 'p_upper', 'p_lower', 'probability'):
            if values.get(key, 0) is None:
                values[key] = math.inf if key == 'cov' else math.nan
        return cls(**values)

    def sentence(self) -> str:
        """Return the line ``cfem-sim sweep`` prints."""
        pct = f'{100 * self.level:g} %'
        line = (f'P(any criterion fails) = {self.probability:.4g} by {self.method}, '
                f'coefficient of variation {self.cov:.3g}, {pct} interval '
                f'[{down(self.ci_low, 4)}, {up(self.ci_high, 4)}]')
        if math.isfinite(self.p_upper):
            line += f', P <= {up(self.p_upper)} at {pct} one-sided'
        elif self.method != 'mc':
            line += ', no bound (too few failed runs)'
        if self.bound:
            line += f' ({self.bound})'
        line += f', {self.runs} runs'
        if self.failed_runs == 0 and self.method == 'mc':
            line += f'; no run failed: P is at most {up(self.p_upper)} at this confidence'
        elif self.failed_runs == 0:
            line += ('; no run failed: the estimate rests on no failure (extrapolated from '
                     'the runs nearest to failing), not a measured probability')
        if self.disagreement:
            line += f'; {self.disagreement}'
        if self.tail_probability is not None and math.isfinite(self.tail_probability):
            bound = (f'P <= {up(self.tail_p_upper)}' if self.tail_p_upper is not None
                     and math.isfinite(self.tail_p_upper) else 'no bound')
            line += (f'; with heavier tails (each normal input a Student-t, {DOF} dof): '
                     f'P = {self.tail_probability:.4g}, {bound}')
        if self.tail_note:
            line += f'; tail check: {self.tail_note}'
        return line


def distribution(spec: SweepSpec, heavier: bool = False):
    """
    Return the sweep's joint input distribution as an OpenTURNS distribution.

    heavier: each normal input a Student-t of the same median and standard
    deviation (the tail check, ``tails``), the rest as they are.

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
        if v.kind == 'normal' and heavier:
            marginals.append(ot.Student(float(DOF), p[0], p[1] * SCALE))
        elif v.kind == 'normal':
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
             runs: int = 1000, repeat: int = REPEAT) -> Estimate:
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
    repeat : int
        Independent repetitions of subset sampling; least importance
        sampling batches after FORM.

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
        found = _run(ot, spec, method, joint, limit_state, evaluate, target_cov, runs, repeat)
    except Exception as err:   # noqa: B902 (what the limit state raised, not its wrapping)
        if raised:
            raise raised[0] from None
        if isinstance(err, (SweepError, MethodFailed)):   # said already, with the fix
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


def _run(ot, spec, method, joint, limit_state, evaluate, target_cov, runs,
         repeat) -> Estimate:
    """Run one method on the limit state; return its estimate, bounds and tail check."""
    from cfem_ros.study import samplers
    from cfem_ros.study.bounds import lognormal_bounds, student_bounds
    level = spec.confidence

    def margins_of(points):
        return np.asarray(limit_state(points), dtype=float).ravel()

    def said(beta, p_form, physical):
        point = ', '.join(f'{v.path} = {x:.6g}' for v, x in zip(spec.variables, physical))
        evaluate.log(f'design point {point}; reliability index {beta:.4g}, P(fail) by FORM '
                     f'{p_form:.4g}; importance sampling around it')

    def sample(inputs, seed, start=None):
        if method == 'subset':
            return samplers.subset(ot, inputs, margins_of, runs, seed, repeat, evaluate.log)
        if method == 'nais':
            return samplers.nais(ot, inputs, margins_of, runs, seed)
        calls = FORM_CALLS * (inputs.getDimension() + 1)
        try:
            return samplers.form(ot, inputs, margins_of, runs, seed, repeat, target_cov,
                                 calls, said, start)
        except samplers.FlatLimitState as err:
            raise MethodFailed(spec.path, '--method form', str(err).replace('FORM: ', ''),
                               'criteria whose margins change with the varied key '
                               'paths, or --method mc') from None
        except RuntimeError as err:   # no design point within the budget
            if 'maximum calls' not in str(err):
                raise
            raise MethodFailed(spec.path, '--method form', f'found no design point in '
                               f'{calls} runs (the search did not converge)', 'a failure '
                               'region FORM can reach, or --method nais or subset') from None

    if method not in ('subset', 'nais', 'form'):
        raise ArgumentError(f'method is {method!r}; expected one of mc, subset, nais, form')
    bounds = lognormal_bounds if method == 'subset' else student_bounds
    found = sample(joint, spec.seed)
    b = bounds(found.replicates, level, found.failed)
    lognormal = method == 'subset' and bool((found.replicates > 0).all())
    how = {'subset': f'{len(found.replicates)} independent repetitions'
                     + (' (bounds of a lognormal mean)' if lognormal else ''),
           'nais': f'{len(found.replicates)} batches of the weighted estimator',
           'form': f'{len(found.replicates)} independent importance-sampling batches'}
    result = Estimate(b.probability, b.cov, b.ci_low, b.ci_high, 0, method, level,
                      p_upper=b.p_upper, p_lower=b.p_lower,
                      bound=f'Student-t over {how[method]}',
                      form_probability=found.form_probability)
    if found.form_probability is not None and math.isfinite(b.ci_high) \
            and not b.ci_low <= found.form_probability <= b.ci_high:
        result.disagreement = (
            f"FORM's first-order P(fail) {found.form_probability:.3g} is outside the "
            f"importance sampling's {100 * level:g} % interval [{b.ci_low:.3g}, "
            f'{b.ci_high:.3g}]: the methods disagree beyond their bounds (the limit state '
            'is not linear near the design point); the sampled estimate is the one used')
    tail = None
    if normals(spec):   # importance weights of heavier tails than q's have no variance:
        # the method is run again on the heavier-tailed inputs, its own seeds
        evaluate.log('tail check: the same method on the heavier-tailed inputs')
        # FORM's search on them starts from the first design point: the same surface,
        # the closest point in the heavier inputs' standard space most often near it
        heavy = sample(distribution(spec, heavier=True), samplers.seeds(spec.seed, 2)[1],
                       found.design_point)
        h = bounds(heavy.replicates, level, heavy.failed)
        tail = Tail(h.probability, h.p_upper, '' if math.isfinite(h.p_upper) else
                    f'{heavy.failed} failed runs: too few for a bound')
    _tail(result, tail, spec)
    result.runs = evaluate.count
    return result


def _tail(result: Estimate, tail, spec: SweepSpec):
    """Put the tail check in the estimate (or why there is none)."""
    if tail is None:
        result.tail_note = 'no normal input: no tail check'
        return
    result.tail_probability = tail.probability
    result.tail_p_upper = tail.p_upper
    result.tail_note = tail.note


def mc_estimate(spec: SweepSpec, table):
    """Return the estimate of a judged Monte Carlo table: fraction, exact bounds (valid runs)."""
    from cfem_ros.study.confidence import lower_bound, upper_bound
    from cfem_ros.study.criteria import judge, valid_runs
    if 'pass' not in table:
        table = judge(table, spec.criteria)
    table = valid_runs(table)   # invalid draws: not run, neither pass nor failure
    bad = ~table['pass'].to_numpy(dtype=bool)
    failed = int(bad.sum())
    n = len(table)
    if not n:
        raise SweepError(spec.path, 'vary', "gives no valid draw: the scenario's checks "
                         'refuse every run', 'distributions whose draws make valid scenarios')
    p = failed / n
    low, high = clopper_pearson(failed, n, spec.confidence)
    cov = math.sqrt((1 - p) / (n * p)) if failed else math.inf
    result = Estimate(p, cov, low, high, n, 'mc', spec.confidence, failed_runs=failed,
                      p_upper=upper_bound(failed, n, spec.confidence),
                      p_lower=lower_bound(failed, n, spec.confidence),
                      bound='exact Clopper-Pearson')
    tail = None
    if normals(spec):
        points = np.column_stack([pd_column(table, v.path) for v in spec.variables])
        tail = mc_tail(spec, points, bad, spec.confidence)
    _tail(result, tail, spec)
    return result


def pd_column(table, path: str) -> np.ndarray:
    """Return a varied key path's column as floats (NaN where it is not a number)."""
    import pandas as pd
    return pd.to_numeric(table[path], errors='coerce').to_numpy(dtype=float)
