# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
One flight within a fit: its window, its measured samples in it, its runs and residuals.

The window is fixed before the fit starts, from the measured file's
releases or the run at the start values (a release group's time is its
first joint's release), so every run is compared over the same samples.
Only the window's samples are compared and only up to the last of them is
simulated: a measured sample far past the window, or a window's end far
past the last sample, costs nothing. A window without ``to`` ends
at the last measured sample within the scenario's duration.
"""

from __future__ import annotations

from typing import Optional

from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.study.fit.flights import FitError, Flight
from cfem_ros.study.fit.measured import Measured
from cfem_ros.study.fit.simulate import Trajectories, Trajectory
from cfem_ros.study.fit.spec import FitSpec
import numpy as np

#: Runs of the simulation past the window's end, in steps (room for the splines).
MARGIN_STEPS = 3


class FlightFit:
    """
    A flight's share of a fit: runs its scenario and weighs its residuals.

    Parameters
    ----------
    spec : FitSpec
    flight : Flight
    measured : Measured
        Its measured poses (all of them: the window is taken here).
    inputs : list of Input
        Replayed in every run.
    interpolate_odometry : bool

    """

    def __init__(self, spec: FitSpec, flight: Flight, measured: Measured, inputs=(),
                 interpolate_odometry: bool = True):
        self.spec, self.flight, self.measured = spec, flight, measured
        model = parse_scenario(flight.document_with(spec.parameters, spec.x0),
                               source=flight.scenario)
        self.dt = model.dt
        last = float(measured.time[-1])
        # a time past the last measured sample compares nothing more: no run goes past it
        absolute = [min(e.time, last) for e in (flight.start, flight.end)
                    if e is not None and e.release is None]
        self.scenario_duration = max([model.duration] + absolute)
        self.trajectories = Trajectories(spec, flight, inputs, interpolate_odometry,
                                         duration=self.scenario_duration
                                         + MARGIN_STEPS * self.dt)
        self.start_run = self.trajectories.run(spec.x0)
        self.window = self._window(self.start_run)
        self.data = measured.window(*self.window[:2])
        self._check_samples()
        #: s, the last measured sample compared: the runs stop a few steps after it, however
        #: far the window's end (a delay of 1e6 s after a release simulates nothing more)
        self.last = float(self.data.time[-1])
        self.trajectories.duration = self.last + MARGIN_STEPS * self.dt

    def _release(self, name: str, run: Trajectory) -> Optional[float]:
        joints = self.flight.groups.get(name, (name,))
        for releases in (self.measured.releases, run.releases):
            times = [releases[j] for j in joints if j in releases]
            if times:
                return min(times)
        return None

    def _window(self, run: Trajectory) -> tuple:
        """Return (start, end, release time or None) of the window, in s."""
        flight, path = self.flight, self.spec.path
        times = []
        for end in (flight.start, flight.end):
            if end is None:
                times.append(self.measured.last_before(self.scenario_duration))
                continue
            if end.release is None:
                times.append(end.time)
                continue
            release = self._release(end.release, run)
            if release is None:
                raise FitError(path, f'{flight.key}.window', f'{end.release} is not released '
                               'in the measured file nor in the run at the start values',
                               'a joint or release group that is released, or times in s')
            times.append(release + end.time)
        if times[1] <= times[0]:
            raise FitError(path, f'{flight.key}.window', f'runs from {times[0]:.6g} s to '
                           f'{times[1]:.6g} s', 'an end after its start')
        name = next((e.release for e in (flight.start, flight.end) if e and e.release), None)
        if name is None and run.releases:
            name = min(run.releases, key=run.releases.get)
        return times[0], times[1], self._release(name, run) if name else None

    def _check_samples(self):
        needed = max(3, len(self.spec.parameters) + 1) if len(self.spec.flights) == 1 else 1
        if len(self.data.time) < needed:
            raise FitError(self.spec.path, f'{self.flight.key}.window',
                           f'holds {len(self.data.time)} measured pose(s) of '
                           f'{self.flight.body} from {self.window[0]:.6g} to '
                           f'{self.window[1]:.6g} s', f'at least {needed} (a wider window, '
                           'or a file with more samples)')

    def residuals(self, run: Trajectory) -> np.ndarray:
        """Return the weighted residuals of a run (6 per measured sample in the window)."""
        flight, data = self.flight, self.data
        if run.end < self.last - 1e-9:
            raise FitError(self.spec.path, 'parameters', f'a run stopped at t = '
                           f'{run.end:.9g} s ({run.status}), before the last measured '
                           f'sample of {flight.key} in its window at {self.last:.9g} s',
                           'bounds within which the run reaches the window end')
        position, attitude = run.poses(data.time)
        error_position = (position - data.position) / flight.sigma_position
        error_attitude = ((data.attitude.inv() * attitude).as_rotvec(degrees=True)
                          / flight.sigma_attitude_deg)
        out = np.hstack([error_position, error_attitude]).ravel()
        if not np.all(np.isfinite(out)):   # a run whose poses overflowed: no residual
            raise FitError(self.spec.path, 'parameters', f'a run ({run.status}) gives poses '
                           f'of {flight.body} that are not finite in the window of '
                           f'{flight.key}', 'bounds within which the run stays finite')
        return out

    def evaluate(self, values) -> np.ndarray:
        """Run at values and return the weighted residuals."""
        return self.residuals(self.trajectories.run(values))

    def residual_rms(self, r: np.ndarray) -> dict:
        """Return the RMS position (m) and attitude (deg) errors of this flight's residuals."""
        residual = r.reshape(-1, 6)
        return {'position': rms(residual[:, :3]) * self.flight.sigma_position,
                'attitude_deg': rms(residual[:, 3:]) * self.flight.sigma_attitude_deg}


def rms(values) -> float:
    """Return the root mean square of values (0 for none)."""
    values = np.asarray(values, dtype=float)
    return float(np.sqrt(np.mean(values ** 2))) if values.size else 0.0


__all__ = ['FlightFit', 'MARGIN_STEPS', 'rms']
