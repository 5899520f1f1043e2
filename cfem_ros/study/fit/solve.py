# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The fit itself: weighted least squares of simulated against measured poses.

The residuals are, per measured sample in the window, the position error
over the position sigma (3, m/m) and the attitude error (the rotation
vector of measured^T simulated, deg) over the attitude sigma (3).
``scipy.optimize.least_squares`` (trust-region reflective, bounded) finds
the parameters; the Jacobian is by central differences with each
parameter's stated step (one-sided at a bound), its 2n runs in parallel
threads (the compiled step releases the GIL). The standard errors and
correlations come from the weighted Jacobian at the solution: with the
sigmas right, the covariance of the estimates is (J^T J)^-1. A parameter
whose column is below ``DETERMINED`` of the largest singular value's
direction is not determined by the data: it gets no standard error and
the fit's status says so.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
import math
import os
import sys
from typing import Callable, Optional

from cfem_ros.study.fit.measured import Measured
from cfem_ros.study.fit.simulate import Trajectories, Trajectory
from cfem_ros.study.fit.spec import FitError, FitSpec
import numpy as np

#: A direction of the parameters whose singular value is below this fraction of the
#: largest one is not determined by the data (the residuals move 1e7 times less along it).
DETERMINED = 1e-7
#: A parameter this much of whose weight lies in the undetermined directions is not
#: determined (half: it is more in them than out of them).
UNDETERMINED_SHARE = 0.5
#: Runs of the simulation past the window's end, in steps (room for the splines).
MARGIN_STEPS = 3


@dataclass
class FitResult:
    """What a fit found (SPEC section 13's ``fit.json``)."""

    values: np.ndarray
    standard_errors: np.ndarray
    correlation: np.ndarray
    residual_rms: dict
    runs: int
    status: str
    problems: list
    window: tuple
    reduced_chi_square: float
    evaluations: int
    message: str
    determined: np.ndarray = field(default_factory=lambda: np.empty(0, bool))


class Fit:
    """
    Fit a scenario's parameters to measured poses.

    Parameters
    ----------
    spec : FitSpec
    measured : Measured
    inputs : list of Input
        Replayed in every run.
    interpolate_odometry : bool
    threads : int
        Runs of one Jacobian at once.
    log : callable, optional
        Called with a line of progress.

    """

    def __init__(self, spec: FitSpec, measured: Measured, inputs=(),
                 interpolate_odometry: bool = True, threads: Optional[int] = None,
                 log: Optional[Callable[[str], None]] = None):
        self.spec = spec
        self.measured = measured
        self.threads = max(1, threads or os.cpu_count() or 1)
        self.log = log or (lambda line: print(line, file=sys.stderr, flush=True))
        dt = _dt(spec)
        self.trajectories = Trajectories(spec, inputs, interpolate_odometry,
                                         duration=float(measured.time[-1]) + MARGIN_STEPS * dt)
        self.start_run = self.trajectories.run(spec.x0)
        self.window = self._window(self.start_run)
        self.data = measured.window(*self.window[:2])
        self._check_samples()
        self.trajectories.duration = self.window[1] + MARGIN_STEPS * dt
        self._last = (None, None)
        self.evaluations = 0

    def _window(self, run: Trajectory) -> tuple:
        """Return (start, end, release time or None) of the window, in s."""
        spec = self.spec
        times = []
        for end in (spec.start, spec.end):
            if end is None:
                times.append(float(self.measured.time[-1]))
                continue
            if end.release is None:
                times.append(end.time)
                continue
            release = self.measured.releases.get(end.release, run.releases.get(end.release))
            if release is None:
                raise FitError(spec.path, 'measured.window', f'{end.release} is not released '
                               'in the measured file nor in the run at the start values',
                               'a joint that is released, or times in s')
            times.append(release + end.time)
        if times[1] <= times[0]:
            raise FitError(spec.path, 'measured.window', f'runs from {times[0]:.6g} s to '
                           f'{times[1]:.6g} s', 'an end after its start')
        joint = next((e.release for e in (spec.start, spec.end) if e and e.release), None)
        if joint is None and run.releases:
            joint = min(run.releases, key=run.releases.get)
        release = (self.measured.releases.get(joint, run.releases.get(joint))
                   if joint else None)
        return times[0], times[1], release

    def _check_samples(self):
        needed = max(3, len(self.spec.parameters) + 1)
        if len(self.data.time) < needed:
            raise FitError(self.spec.path, 'measured.window', f'holds {len(self.data.time)} '
                           f'measured pose(s) of {self.spec.body} from {self.window[0]:.6g} to '
                           f'{self.window[1]:.6g} s', f'at least {needed} (a wider window, or '
                           'a file with more samples)')

    def residuals(self, values) -> np.ndarray:
        """Return the weighted residuals at parameter values (6 per measured sample)."""
        key = np.asarray(values, dtype=float).tobytes()
        if self._last[0] == key:
            return self._last[1]
        out = self._residuals(self.trajectories.run(values))
        self._last = (key, out)
        return out

    def _residuals(self, run: Trajectory) -> np.ndarray:
        spec, data = self.spec, self.data
        if run.end < self.window[1] - 1e-9:
            raise FitError(spec.path, 'parameters', f'a run stopped at t = {run.end:.9g} s '
                           f'({run.status}), before the window ends at {self.window[1]:.9g} s',
                           'bounds within which the run reaches the window end')
        position, attitude = run.poses(data.time)
        error_position = (position - data.position) / spec.sigma_position
        error_attitude = ((data.attitude.inv() * attitude).as_rotvec(degrees=True)
                          / spec.sigma_attitude_deg)
        return np.hstack([error_position, error_attitude]).ravel()

    def jacobian(self, values) -> np.ndarray:
        """Return the residuals' Jacobian by central differences, its runs in parallel."""
        values = np.asarray(values, dtype=float)
        base = self.residuals(values)
        cases = []
        for j, parameter in enumerate(self.spec.parameters):
            h = parameter.step
            up, down = values[j] + h <= parameter.high, values[j] - h >= parameter.low
            cases.append((j, h if up else 0.0, -h if down else 0.0))
        points = []
        for j, plus, minus in cases:
            for delta in (plus, minus):
                if delta != 0.0:
                    point = values.copy()
                    point[j] += delta
                    points.append(point)
        with ThreadPoolExecutor(max_workers=self.threads) as pool:
            results = iter(list(pool.map(
                lambda p: self._residuals(self.trajectories.run(p)), points)))
        columns = []
        for j, plus, minus in cases:
            high = next(results) if plus != 0.0 else base
            low = next(results) if minus != 0.0 else base
            columns.append((high - low) / (plus - minus))
        return np.column_stack(columns)

    def solve(self) -> FitResult:
        """Run the fit and return what it found."""
        from scipy.optimize import least_squares
        spec = self.spec
        names = ', '.join(p.path for p in spec.parameters)
        self.log(f'fit: {len(spec.parameters)} parameter(s) ({names}) to '
                 f'{len(self.data.time)} poses of {spec.body} relative to {spec.relative_to} '
                 f'from {self.window[0]:.6g} to {self.window[1]:.6g} s; steps '
                 + ', '.join(f'{p.step:.3g}' for p in spec.parameters))

        def fun(values):
            r = self.residuals(values)
            self.evaluations += 1
            self.log(f'  evaluation {self.evaluations}: weighted rms {_rms(r):.6g} at '
                     + ', '.join(f'{v:.9g}' for v in values))
            return r

        solution = least_squares(fun, spec.x0, jac=self.jacobian, bounds=spec.bounds,
                                 method='trf', x_scale='jac', max_nfev=spec.max_evaluations)
        values = solution.x
        r = self.residuals(values)
        jacobian = self.jacobian(values)
        return self._result(values, r, jacobian, solution)

    def _result(self, values, r, jacobian, solution) -> FitResult:
        spec = self.spec
        n = len(values)
        _, singular, vt = np.linalg.svd(jacobian, full_matrices=False)
        largest = singular[0] if singular.size and singular[0] > 0 else 1.0
        kept = singular > DETERMINED * largest
        weak = vt[~kept]
        share = (weak ** 2).sum(axis=0) if weak.size else np.zeros(n)
        determined = share < UNDETERMINED_SHARE
        covariance = (vt[kept].T / singular[kept] ** 2) @ vt[kept]
        errors = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
        errors[~determined] = math.nan
        scale = np.where(determined, errors, math.nan)
        with np.errstate(invalid='ignore', divide='ignore'):
            correlation = covariance / np.outer(scale, scale)
        np.fill_diagonal(correlation, np.where(determined, 1.0, math.nan))
        residual = r.reshape(-1, 6)
        rms = {'position': _rms(residual[:, :3]) * spec.sigma_position,
               'attitude_deg': _rms(residual[:, 3:]) * spec.sigma_attitude_deg}
        dof = r.size - int(kept.sum())
        problems = []
        for j, parameter in enumerate(spec.parameters):
            if not determined[j]:
                problems.append(('not_determined', f'{parameter.name} is not determined by the '
                                 'measured poses in the window (they do not change with it): '
                                 'fix it in the scenario, or widen the window to where it acts'))
        for j, parameter in enumerate(spec.parameters):
            if solution.active_mask[j] != 0:
                bound = parameter.low if solution.active_mask[j] < 0 else parameter.high
                problems.append(('at_bound', f'{parameter.name} ended at its bound {bound:g}: '
                                 'widen its bounds if they are not physical limits, or look '
                                 'for what else the model lacks'))
        if solution.status == 0:
            problems.append(('not_converged', f'stopped after {spec.max_evaluations} '
                             'evaluations (max_evaluations) before converging'))
        status = problems[0][0] if problems else 'converged'
        return FitResult(values=values, standard_errors=errors, correlation=correlation,
                         residual_rms=rms, runs=self.trajectories.runs, status=status,
                         problems=[p[1] for p in problems], window=self.window,
                         reduced_chi_square=float(r @ r / dof) if dof > 0 else math.nan,
                         evaluations=self.evaluations, message=solution.message,
                         determined=determined)


def _rms(values) -> float:
    values = np.asarray(values, dtype=float)
    return float(np.sqrt(np.mean(values ** 2))) if values.size else 0.0


def _dt(spec: FitSpec) -> float:
    from cfem_ros.core.scenario.parse import parse_scenario
    return parse_scenario(spec.document_with(spec.x0), source=spec.scenario).dt
