# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The fit itself: weighted least squares of simulated against measured poses.

The residuals are, per measured sample in a flight's window, the position
error over the position sigma (3, m/m) and the attitude error (the
rotation vector of measured^T simulated, deg) over the attitude sigma (3),
the flights' residuals one after the other (the parameters are shared).
``scipy.optimize.least_squares`` (trust-region reflective, bounded) finds
the parameters; the Jacobian is by central differences with each
parameter's stated step (one-sided at a bound), its runs (2 per parameter
and flight) in parallel threads (the compiled step releases the GIL), as
are the flights' runs at one point (the start, each of the solver's steps).
What the data determine, and how well, is ``uncertainty.analyse``'s: a
parameter the data do not determine keeps its start value, and the others
are fitted again with it held there.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
import os
import sys
from typing import Callable, Optional

from cfem_ros.study.fit.flightfit import FlightFit, rms
from cfem_ros.study.fit.measured import Measured
from cfem_ros.study.fit.spec import FitSpec
from cfem_ros.study.fit.uncertainty import analyse, residual_structure, Uncertainty
import numpy as np


@dataclass
class Observed:
    """A flight's measured poses and the inputs its runs replay."""

    measured: Measured
    inputs: list = field(default_factory=list)
    interpolate_odometry: bool = True


@dataclass
class FitResult:
    """What a fit found (SPEC section 13's ``fit.json``)."""

    values: np.ndarray
    uncertainty: Uncertainty
    residual_rms: dict
    flights: list          # per flight: {'residual_rms', 'samples', 'window', 'chi2',
    #                        'structure' (uncertainty.residual_structure)}
    runs: int
    status: str
    problems: list
    evaluations: int
    message: str
    intervals: Optional[list] = None   # per parameter: (low, high) of --profile

    @property
    def window(self) -> tuple:
        """Return the first flight's window: start, end, and release or None (s)."""
        return self.flights[0]['window']

    @property
    def standard_errors(self) -> np.ndarray:
        """Return the standard errors (NaN for a parameter not determined)."""
        return self.uncertainty.standard_errors

    @property
    def determined(self) -> np.ndarray:
        """Return whether the data determine each parameter."""
        return self.uncertainty.determined

    @property
    def correlation(self) -> np.ndarray:
        """Return the estimates' correlation matrix."""
        return self.uncertainty.correlation


class Fit:
    """
    Fit a scenario's parameters to measured poses of one flight or several.

    Parameters
    ----------
    spec : FitSpec
    observed : list of Observed (or one Measured, for a fit of one flight)
    threads : int
        Runs at once: a Jacobian's, and the flights' at one point.
    log : callable, optional
        Called with a line of progress.

    """

    def __init__(self, spec: FitSpec, observed, threads: Optional[int] = None,
                 log: Optional[Callable[[str], None]] = None):
        if isinstance(observed, Measured):
            observed = [Observed(observed)]
        self.spec = spec
        self.threads = max(1, threads or os.cpu_count() or 1)
        self.log = log or (lambda line: print(line, file=sys.stderr, flush=True))
        self.flights = _each(lambda case: FlightFit(spec, case[0], case[1].measured,
                                                    case[1].inputs,
                                                    case[1].interpolate_odometry),
                             list(zip(spec.flights, observed)), self.threads)
        self._last = (None, None)
        self._last_jacobian = (None, None)
        self.evaluations = 0

    @property
    def runs(self) -> int:
        """Return the runs made so far, over every flight."""
        return sum(f.trajectories.runs for f in self.flights)

    def evaluate(self, values, threads: int = 1) -> np.ndarray:
        """Return the weighted residuals at values, the flights' runs threads at once."""
        return np.concatenate(_each(lambda flight: flight.evaluate(values), self.flights,
                                    threads))

    def residuals(self, values) -> np.ndarray:
        """Return the weighted residuals at parameter values (the last one kept)."""
        key = np.asarray(values, dtype=float).tobytes()
        if self._last[0] == key:
            return self._last[1]
        out = self.evaluate(values, self.threads)
        self._last = (key, out)
        return out

    def jacobian(self, values, columns=None, threads: Optional[int] = None,
                 base: Optional[np.ndarray] = None) -> np.ndarray:
        """
        Return the residuals' Jacobian (in columns) by central differences, in parallel.

        The last one is kept: the solver's last Jacobian is at its solution, where
        ``solve`` asks for it again (the same runs: the same numbers, not run twice).
        """
        values = np.asarray(values, dtype=float)
        columns = range(len(values)) if columns is None else columns
        key = (values.tobytes(), tuple(int(j) for j in columns))
        if base is None and self._last_jacobian[0] == key:
            return self._last_jacobian[1].copy()
        kept, base = base is None, self.residuals(values) if base is None else base
        cases, points = [], []
        for j in columns:
            parameter = self.spec.parameters[j]
            h = parameter.step
            plus = h if values[j] + h <= parameter.high else 0.0
            minus = -h if values[j] - h >= parameter.low else 0.0
            cases.append((plus, minus))
            for delta in (plus, minus):
                if delta != 0.0:
                    point = values.copy()
                    point[j] += delta
                    points.extend((point, flight) for flight in self.flights)
        with ThreadPoolExecutor(max_workers=threads or self.threads) as pool:
            results = iter(list(pool.map(lambda case: case[1].evaluate(case[0]), points)))

        def side(delta):
            if delta == 0.0:
                return base
            return np.concatenate([next(results) for _ in self.flights])
        out = []
        for plus, minus in cases:
            high, low = side(plus), side(minus)
            out.append((high - low) / (plus - minus))
        jacobian = np.column_stack(out) if out else np.zeros((base.size, 0))
        if kept:
            self._last_jacobian = (key, jacobian.copy())
        return jacobian

    def _least_squares(self, x0, free, nfev):
        """Fit the free parameters from x0 (the others held); return (values, solution)."""
        from scipy.optimize import least_squares
        spec = self.spec
        low, high = spec.bounds
        free = np.asarray(free)

        def full(x):
            values = np.array(x0, dtype=float)
            values[free] = x
            return values

        def fun(x):
            r = self.residuals(full(x))
            self.evaluations += 1
            self.log(f'  evaluation {self.evaluations}: weighted rms {rms(r):.6g} at '
                     + ', '.join(f'{v:.9g}' for v in full(x)))
            return r

        solution = least_squares(fun, np.asarray(x0, dtype=float)[free],
                                 jac=lambda x: self.jacobian(full(x), free),
                                 bounds=(low[free], high[free]), method='trf', x_scale='jac',
                                 max_nfev=nfev)
        return full(solution.x), solution

    def solve(self) -> FitResult:
        """Run the fit and return what it found."""
        spec = self.spec
        names = ', '.join(p.path for p in spec.parameters)
        samples = sum(len(f.data.time) for f in self.flights)
        where = (f'from {self.flights[0].window[0]:.6g} to {self.flights[0].window[1]:.6g} s'
                 if len(self.flights) == 1 else f'in {len(self.flights)} flights')
        self.log(f'fit: {len(spec.parameters)} parameter(s) ({names}) to {samples} poses of '
                 f'{spec.flights[0].body} relative to {spec.flights[0].relative_to} {where}; '
                 'steps ' + ', '.join(f'{p.step:.3g}' for p in spec.parameters))
        every = np.arange(len(spec.parameters))
        values, solution = self._least_squares(spec.x0, every, spec.max_evaluations)
        r = self.residuals(values)
        steps = [p.step for p in spec.parameters]
        uncertainty = analyse(self.jacobian(values), r, spec.parameters, steps)
        held = ~uncertainty.determined
        if held.any():   # the undetermined back to their start; the others fitted again
            values = values.copy()
            values[held] = spec.x0[held]
            free = np.flatnonzero(~held)
            if free.size:
                self.log('  the parameters the data do not determine held at their start '
                         'values; the others fitted again')
                values, solution = self._least_squares(values, free, spec.max_evaluations)
            r = self.residuals(values)
            again = analyse(self.jacobian(values), r, spec.parameters, steps, held=held)
            again.problems = _merged(uncertainty.problems, again.problems)
            uncertainty = again
        return self._result(values, r, uncertainty, solution, held)

    def _result(self, values, r, uncertainty, solution, held) -> FitResult:
        spec = self.spec
        problems = list(uncertainty.problems)
        free = np.flatnonzero(~held)
        for k, j in enumerate(free):
            mask = solution.active_mask[k] if k < len(solution.active_mask) else 0
            if mask != 0:
                parameter = spec.parameters[j]
                bound = parameter.low if mask < 0 else parameter.high
                problems.append(('at_bound', f'{parameter.name} ended at its bound {bound:g}: '
                                 'widen its bounds if they are not physical limits, or look '
                                 'for what else the model lacks'))
        if solution.status == 0:
            problems.append(('not_converged', f'stopped after {spec.max_evaluations} '
                             'evaluations (max_evaluations) before converging'))
        status = problems[0][0] if problems else 'converged'
        flights, at = [], 0
        for flight in self.flights:
            part = r[at:at + flight.data.time.size * 6]
            at += part.size
            flights.append({'residual_rms': flight.residual_rms(part),
                            'samples': int(flight.data.time.size), 'window': flight.window,
                            'chi2': float(part @ part),
                            'structure': residual_structure(part)})
        total = {'position': _pooled([f['residual_rms']['position'] for f in flights],
                                     [f['samples'] for f in flights]),
                 'attitude_deg': _pooled([f['residual_rms']['attitude_deg'] for f in flights],
                                         [f['samples'] for f in flights])}
        return FitResult(values=values, uncertainty=uncertainty, residual_rms=total,
                         flights=flights, runs=self.runs, status=status,
                         problems=[p[1] for p in problems], evaluations=self.evaluations,
                         message=solution.message)


def _each(function, items: list, threads: int) -> list:
    """Return function of each item, in order, threads at once (an error: the first item's)."""
    if threads <= 1 or len(items) <= 1:
        return [function(item) for item in items]
    with ThreadPoolExecutor(max_workers=min(threads, len(items))) as pool:
        return list(pool.map(function, items))


def _merged(first: list, second: list) -> list:
    out = []
    for problem in first + second:
        if problem not in out:
            out.append(problem)
    return out


def _pooled(values, counts) -> float:
    """Return the RMS over flights of their RMS values, each weighted by its samples."""
    counts = np.asarray(counts, dtype=float)
    return float(np.sqrt(np.sum(np.asarray(values) ** 2 * counts) / counts.sum()))
