# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The rare-event methods as independent replicates of P(fail) (SPEC section 9).

Each method returns a ``Sampled``: independent, identically distributed
estimates whose mean is the estimate and whose spread gives the bound
(``bounds.student_bounds``). The tail check runs the same method on the
heavier-tailed inputs (``tails``):

- ``subset``: K repetitions of OpenTURNS' subset sampling, each with its
  own seed.
- ``nais``: OpenTURNS' NAIS adapts a kernel mixture q; a further
  sample of q with unit-covariance kernels, weighted f / q_wide, in
  ``BATCHES`` batches.
- ``form``: FORM's design point u* (``design_point``: improved HL-RF,
  each iteration one batch of runs), then importance sampling from
  N(u*, I) in the standard space, batches of ``runs`` points, each from
  its own seed, at least K of them, until the coefficient of variation is
  reached. FORM's own first-order P is kept to be checked against them.

``limit_state(points (n, d) physical) -> margins (n,)``, failure below 0;
``joint`` the inputs' OpenTURNS distribution.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Optional

from cfem_ros.core.errors import CfemError
from cfem_ros.study.bounds import batch_means
import numpy as np

#: Batches the last NAIS sample is cut into.
BATCHES = 10
#: Importance-sampling batches FORM may run, at most.
MAX_BATCHES = 100
#: Conditional probability of each subset level; quantile level of NAIS.
LEVEL_PROBABILITY = 0.1
#: Seeds subset sampling may take in place of repetitions OpenTURNS could not finish.
SPARES = 3
#: FORM's centred differences: the step in the standard space (standard deviations).
STEP = 1e-4
#: FORM's design point: within this many standard deviations (times |u| beyond 1) of
#: the limit state's surface, and u off the gradient by no more.
TOLERANCE = 1e-3
#: FORM's iterations, at most; halved steps tried in one batch; Armijo's fraction.
MAX_ITERATIONS = 100
HALVINGS = 4
ARMIJO = 1e-4
#: FORM's design point, at most this many standard deviations from the origin: beyond
#: it P by FORM is below 1e-300 (a double's smallest normal number is 2.2e-308), and no
#: draw there is a value of the inputs anyone meant.
MAX_BETA = 37.0


class FlatLimitState(CfemError, RuntimeError):
    """A limit state FORM cannot search: no gradient, or its surface beyond MAX_BETA."""


@dataclass
class Sampled:
    """Independent replicates of P(fail), and what they rest on."""

    replicates: np.ndarray
    failed: int                      # failed runs under the replicates
    how: str                         # 'batches' or 'repetitions'
    form_probability: Optional[float] = None
    design_point: Optional[list] = None


def seeds(seed: int, count: int) -> list:
    """Return ``count`` independent seeds drawn from one (the first is ``seed`` itself)."""
    spawned = np.random.SeedSequence(seed).generate_state(count, dtype=np.uint32)
    return [int(seed)] + [int(s) for s in spawned[1:]]


def _event(ot, joint, function):
    output = ot.CompositeRandomVector(function, ot.RandomVector(joint))
    return ot.ThresholdEvent(output, ot.Less(), 0.0)


class _Counting:
    """An OpenTURNS function of the limit state that counts the failed runs it saw."""

    def __init__(self, ot, dimension: int, limit_state):
        self.failed = 0

        def counted(points):
            margins = np.asarray(limit_state(np.array(points)), dtype=float).reshape(-1, 1)
            self.failed += int(np.sum(margins < 0))
            return margins

        self.function = ot.MemoizeFunction(ot.PythonFunction(dimension, 1,
                                                             func_sample=counted))


def subset(ot, joint, limit_state, runs: int, seed: int, repeat: int,
           log=None) -> Sampled:
    """
    Return ``repeat`` independent subset-sampling estimates, each with its own seed.

    OpenTURNS 1.27 stops a repetition now and then (2 of 100 seeds of a
    plane 3.5 SDs out, 500 points a level) on a negative estimate of its own
    variance, which is not used here: that repetition is run again with the
    next spare seed (at most ``SPARES``), said through ``log``.
    """
    found, failed = [], 0
    stream = seeds(seed, repeat + SPARES)
    spare = repeat
    for s in stream[:repeat]:
        while True:
            try:
                estimate, seen = _subset_once(ot, joint, limit_state, runs, s)
                break
            except TypeError as err:
                if 'variance estimate must be' not in str(err) or spare >= len(stream):
                    raise
                if log is not None:
                    log(f'subset sampling seed {s}: OpenTURNS stopped on a negative variance '
                        f'estimate of its own; the repetition is run with seed {stream[spare]}')
                s, spare = stream[spare], spare + 1
        found.append(estimate)
        failed += seen
    return Sampled(np.array(found), failed, 'repetitions')


def _subset_once(ot, joint, limit_state, runs: int, seed: int) -> tuple:
    """Return (estimate, failed runs) of one subset sampling with its seed."""
    counting = _Counting(ot, joint.getDimension(), limit_state)
    ot.RandomGenerator.SetSeed(seed)
    # the chains (runs x p0 of them) advance one step per batch: asking for a whole
    # level at once (block size = runs) gives estimates biased low in OpenTURNS 1.27
    chains = max(1, round(runs * LEVEL_PROBABILITY))
    algorithm = ot.SubsetSampling(ot.StandardEvent(_event(
        ot, joint, counting.function)), 2.0, LEVEL_PROBABILITY)
    algorithm.setBlockSize(chains)
    algorithm.setMaximumOuterSampling(max(1, round(runs / chains)))
    algorithm.run()
    return float(algorithm.getResult().getProbabilityEstimate()), counting.failed


def nais(ot, joint, limit_state, runs: int, seed: int) -> Sampled:
    """
    Return ``BATCHES`` batch estimates of P from a sample of NAIS's widened density.

    NAIS adapts a kernel mixture q to the failure region, in the standard
    space; its kernels are narrower than the inputs' unit normal (the
    bandwidth shrinks as runs grow), so the weights f / q of its own last
    sample have no finite variance far from the kernels and the batches'
    spread is too small (a 95 % bound held the exact P in 86 of 100 seeds
    of a plane 4 SDs out). The batches come from a further ``runs``
    points of the same mixture with unit-covariance kernels at the same
    centres and weights: f / q_wide then has a finite variance, as FORM's
    shifted normal has (the same plane: 141 of 150 seeds, the spread of
    the estimates 0.08 where the narrow kernels' was 0.13).
    """
    counting = _Counting(ot, joint.getDimension(), limit_state)
    ot.RandomGenerator.SetSeed(seed)
    algorithm = ot.NAIS(ot.StandardEvent(_event(ot, joint, counting.function)),
                        LEVEL_PROBABILITY)
    algorithm.setBlockSize(runs)
    algorithm.setMaximumOuterSampling(1)
    algorithm.run()
    d = joint.getDimension()
    adapted = ot.Mixture(algorithm.getResult().getAuxiliaryDistribution().getImplementation())
    wide = ot.Mixture([ot.Normal(kernel.getMean(), ot.Point(d, 1.0), ot.CorrelationMatrix(d))
                       for kernel in adapted.getDistributionCollection()],
                      adapted.getWeights())
    ot.RandomGenerator.SetSeed(seeds(seed, 2)[1])
    u = np.array(wide.getSample(runs), dtype=float)
    to_physical = joint.getInverseIsoProbabilisticTransformation()
    below = np.asarray(limit_state(np.array(to_physical(u), dtype=float)),
                       dtype=float).ravel() < 0
    log_ratio = (np.array(ot.Normal(d).computeLogPDF(u), dtype=float).ravel()
                 - np.array(wide.computeLogPDF(u), dtype=float).ravel())
    values = np.where(below, np.exp(log_ratio), 0.0)
    return Sampled(batch_means(values, BATCHES), int(below.sum()), 'batches')


def form(ot, joint, limit_state, runs: int, seed: int, repeat: int, target_cov: float,
         calls: int, log, start=None) -> Sampled:
    """
    Return the importance-sampling batches around FORM's design point.

    ``start``: a physical point the design point search starts from (the
    inputs' mean when None). ``log(beta, p_form, physical)`` is told the
    design point. Raises ``RuntimeError`` 'maximum calls' when the search
    finds no design point within ``calls`` runs.
    """
    to_physical = joint.getInverseIsoProbabilisticTransformation()

    def margins(u):
        return np.asarray(limit_state(np.array(to_physical(u), dtype=float)),
                          dtype=float).ravel()

    origin = np.zeros(joint.getDimension()) if start is None else \
        np.array(joint.getIsoProbabilisticTransformation()(start), dtype=float)
    star, beta, p_form = design_point(margins, origin, calls)
    physical = [float(v) for v in to_physical(star)]
    log(beta, p_form, physical)
    values, failed = [], 0
    for k, s in enumerate(seeds(seed, MAX_BATCHES)):
        u = star + np.random.default_rng(s).standard_normal((runs, star.size))
        below = margins(u) < 0
        weights = np.exp(-u @ star + 0.5 * star @ star)   # phi(u) / phi(u - u*)
        values.append(float(np.mean(np.where(below, weights, 0.0))))
        failed += int(below.sum())
        if k + 1 >= max(2, repeat):
            mean = float(np.mean(values))
            se = float(np.std(values, ddof=1)) / math.sqrt(len(values))
            if mean > 0 and se / mean <= target_cov:
                break
    return Sampled(np.array(values), failed, 'batches', p_form, physical)


def design_point(margins, start: np.ndarray, calls: int) -> tuple:
    """
    Return FORM's design point u* (standard space), its reliability index and P_FORM.

    The improved HL-RF iteration (Zhang and Der Kiureghian, 1995): from u, the
    HL-RF point of the limit state's linearization, (grad.u - G) grad / |grad|^2,
    taken in full when the merit 0.5 |u|^2 + c |G| falls enough (Armijo), c =
    2 max(|u|, |HL-RF point|) / |grad| (a descent of the merit, and a full first
    step from the origin accepted), else the largest of halved steps that does.
    Each iteration is one batch of runs: the full step with its centred-difference
    stencil (the gradient the next iteration needs, if the step is taken),
    then, only when it is not, halved steps in one batch and the stencil of the one
    taken. OpenTURNS' Abdo-Rackwitz asked for one run at a time, and from the
    origin its merit took steps of 1/64 of the way, some 16 iterations of 11 runs
    on config/sweeps/store_separation_decision.yaml where this takes a few.

    Parameters
    ----------
    margins : callable
        u (n, d), standard space -> limit-state values (n,), failure below 0.
    start : ndarray (d,)
        The search's first point (standard space).
    calls : int
        Runs the search may take; past them, RuntimeError 'maximum calls'.

    """
    d = start.size
    taken = [0]

    def run(points):
        taken[0] += len(points)
        if taken[0] > calls:
            raise RuntimeError(f'FORM: maximum calls number {calls} reached without a '
                               'design point')
        return margins(np.asarray(points, dtype=float))

    def stencil(u):
        return np.concatenate([u + STEP * np.eye(d), u - STEP * np.eye(d)])

    def gradient(values):
        return (values[:d] - values[d:]) / (2 * STEP)

    found = run(np.vstack([start[None, :], stencil(start)]))
    u, g, grad = start, float(found[0]), gradient(found[1:])
    previous = None   # the last step's part along the surface: taken, and as proposed
    for _ in range(MAX_ITERATIONS):
        norm = float(np.linalg.norm(grad))
        if not norm > 0:
            raise FlatLimitState(f'FORM: the limit state does not change with the inputs at '
                                 f'u = {np.array2string(u, precision=4)} (no gradient)')
        target = (grad @ u - g) / norm ** 2 * grad
        if not np.linalg.norm(target) <= MAX_BETA:   # asked before any run is made there
            raise FlatLimitState(
                f'FORM: the limit state hardly changes with the inputs: its linearization at '
                f'u = {np.array2string(u, precision=4)} puts the failure surface '
                f'{float(np.linalg.norm(target)):.3g} standard deviations away (beyond '
                f'{MAX_BETA:g}: P by FORM below 1e-300, at inputs nobody meant)')
        along = u - (u @ grad) / norm ** 2 * grad   # the part of u off the gradient
        # on the surface (its linearization within TOLERANCE standard deviations) and
        # u along the gradient there: the closest point of the surface
        within = TOLERANCE * max(1.0, float(np.linalg.norm(u)))
        if abs(g) / norm <= within and np.linalg.norm(along) <= within:
            break
        c = 2 * max(float(np.linalg.norm(u)), float(np.linalg.norm(target))) / norm
        step = _damped(target - u, grad / norm, previous)
        merit = 0.5 * u @ u + c * abs(g)
        slope = (u + c * np.sign(g) * grad) @ step   # the merit's derivative along the step
        if not slope < 0:   # the damped step no descent of the merit: HL-RF's own
            step = target - u
            slope = u @ target - u @ u - c * abs(g)
        tangent = (target - u) - ((target - u) @ grad) / norm ** 2 * grad

        def accepted(lam, value):
            trial = u + lam * step
            return 0.5 * trial @ trial + c * abs(value) <= merit + ARMIJO * lam * slope

        found = run(np.vstack([(u + step)[None, :], stencil(u + step)]))
        if accepted(1.0, found[0]):
            previous = (step - (step @ grad) / norm ** 2 * grad, tangent)
            u, g, grad = u + step, float(found[0]), gradient(found[1:])
            continue
        lam = 1.0
        while True:
            lams = lam * 0.5 ** np.arange(1, HALVINGS + 1)
            values = run(u + lams[:, None] * step)
            ok = [k for k, (a, v) in enumerate(zip(lams, values)) if accepted(a, v)]
            if ok:
                break
            lam = float(lams[-1])
        lam, g = float(lams[ok[0]]), float(values[ok[0]])
        previous = (lam * (step - (step @ grad) / norm ** 2 * grad), tangent)
        u = u + lam * step
        grad = gradient(run(stencil(u)))
    else:
        raise RuntimeError(f'FORM: maximum calls number: {MAX_ITERATIONS} iterations '
                           'without a design point')
    from scipy.stats import norm as normal
    beta = float(np.linalg.norm(u))
    # the origin on the failing side of the tangent plane (G rises from u* away from the
    # origin): P(fail) by FORM above one half, as OpenTURNS gives it
    return u, beta, float(normal.cdf(beta) if grad @ u > 0 else normal.sf(beta))


def _damped(step: np.ndarray, normal: np.ndarray, previous) -> np.ndarray:
    """
    Return an HL-RF step with its part along the surface damped where HL-RF zigzags.

    On a curved surface HL-RF's steps along it overshoot the design point by a
    ratio rho of the error each time (rho near -0.7 on the test's surface: some
    twenty iterations to 1e-3). The error e and the step's part along the surface t
    are linked by t = (rho - 1) e; the secant of the last two steps gives rho - 1
    = (t - t_before) . moved / |moved|^2, moved the part along the surface taken
    then, and the step that ends the error is t / (1 - rho), damped to no less
    than a tenth and never lengthened. The step's part across the surface (to it)
    stays whole.
    """
    tangent = step - (step @ normal) * normal
    if previous is None:
        return step
    moved, before = previous
    change = float((tangent - before) @ moved)
    if not change < 0 or not moved @ moved > 0:   # not zigzagging: HL-RF's step
        return step
    factor = min(1.0, max(0.1, -float(moved @ moved) / change))
    return step - (1.0 - factor) * tangent
