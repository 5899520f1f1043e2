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
- ``form``: OpenTURNS' FORM for the design point u*, then importance
  sampling from N(u*, I) in the standard space, batches of ``runs``
  points, each from its own seed, at least K of them, until the
  coefficient of variation is reached. FORM's own first-order P is kept
  to be checked against them.

``limit_state(points (n, d) physical) -> margins (n,)``, failure below 0;
``joint`` the inputs' OpenTURNS distribution.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Optional

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
         calls: int, log) -> Sampled:
    """
    Return the importance-sampling batches around FORM's design point.

    Raises ``RuntimeError`` 'maximum calls' when FORM finds no design point
    within ``calls`` runs.
    """
    counting = _Counting(ot, joint.getDimension(), limit_state)
    optimizer = ot.AbdoRackwitz()
    optimizer.setMaximumCallsNumber(calls)
    optimizer.setStartingPoint(joint.getMean())   # physical space
    analysis = ot.FORM(optimizer, _event(ot, joint, counting.function))
    analysis.run()
    found = analysis.getResult()
    star = np.array(found.getStandardSpaceDesignPoint(), dtype=float)
    physical = [float(v) for v in found.getPhysicalSpaceDesignPoint()]
    log(found, physical)
    to_physical = joint.getInverseIsoProbabilisticTransformation()
    values, failed = [], 0
    for k, s in enumerate(seeds(seed, MAX_BATCHES)):
        u = star + np.random.default_rng(s).standard_normal((runs, star.size))
        below = np.asarray(limit_state(np.array(to_physical(u), dtype=float)),
                           dtype=float).ravel() < 0
        weights = np.exp(-u @ star + 0.5 * star @ star)   # phi(u) / phi(u - u*)
        values.append(float(np.mean(np.where(below, weights, 0.0))))
        failed += int(below.sum())
        if k + 1 >= max(2, repeat):
            mean = float(np.mean(values))
            se = float(np.std(values, ddof=1)) / math.sqrt(len(values))
            if mean > 0 and se / mean <= target_cov:
                break
    return Sampled(np.array(values), failed, 'batches', float(found.getEventProbability()),
                   physical)
