# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""One fit from its file to its result: what ``cfem-sim fit`` does before it writes."""

from __future__ import annotations

from typing import Callable, Optional

from cfem_ros.study.fit.measured import read_measured
from cfem_ros.study.fit.solve import Fit, FitResult, Observed
from cfem_ros.study.fit.spec import FitSpec, load_fit


def observed_flights(spec: FitSpec) -> list:
    """Return each flight's measured poses and the inputs its runs replay."""
    out = []
    for flight in spec.flights:
        inputs, interpolate, start_ns = [], flight.odometry != 'extrapolate', None
        if flight.inputs:
            from cfem_ros.recording.replay import read_inputs_and_start, recorded_interpolation
            inputs, start_ns = read_inputs_and_start(flight.inputs)
            if flight.odometry is None:
                interpolate = recorded_interpolation(flight.inputs) is not False
        out.append(Observed(read_measured(spec.path, flight, start_ns), inputs, interpolate))
    return out


def fit_file(path: str, threads: Optional[int] = None, profile: bool = False,
             log: Optional[Callable[[str], None]] = None) -> tuple:
    """
    Fit the parameters of a fit file (with ``--profile``'s intervals if asked).

    Returns
    -------
    (Fit, FitResult)

    Raises
    ------
    FitError
        For a fit file, measured file or window that cannot be used, or a
        run that fails within the bounds.

    """
    spec = load_fit(path)
    fit = Fit(spec, observed_flights(spec), threads=threads, log=log)
    result: FitResult = fit.solve()
    if profile:
        from cfem_ros.study.fit.likelihood import profile_intervals
        result.intervals = profile_intervals(fit, result)
        result.runs = fit.runs   # the profile's refits counted with the fit's runs
    return fit, result
