# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""One fit from its file to its folder: what ``cfem-sim fit`` does."""

from __future__ import annotations

from typing import Callable, Optional

from cfem_ros.study.fit.measured import read_measured
from cfem_ros.study.fit.outputs import sentence, write_outputs
from cfem_ros.study.fit.solve import Fit, FitResult
from cfem_ros.study.fit.spec import load_fit


def fit_file(path: str, outdir: str, threads: Optional[int] = None,
             log: Optional[Callable[[str], None]] = None) -> tuple:
    """
    Fit the parameters of a fit file and write its outputs into outdir.

    Returns
    -------
    (Fit, FitResult, str)
        The fit, what it found, and the sentence that says it.

    Raises
    ------
    FitError
        For a fit file, measured file or window that cannot be used, or a
        run that fails within the bounds.

    """
    spec = load_fit(path)
    inputs, interpolate, start_ns = [], spec.odometry != 'extrapolate', None
    if spec.inputs:
        from cfem_ros.recording.replay import read_inputs_and_start, recorded_interpolation
        inputs, start_ns = read_inputs_and_start(spec.inputs)
        if spec.odometry is None:
            interpolate = recorded_interpolation(spec.inputs) is not False
    measured = read_measured(spec, start_ns)
    fit = Fit(spec, measured, inputs, interpolate, threads=threads, log=log)
    result: FitResult = fit.solve()
    write_outputs(fit, result, outdir, inputs, interpolate)
    return fit, result, sentence(fit, result)
