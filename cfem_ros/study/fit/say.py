# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What a fit says when it ends: one sentence, its notes, and its warnings.

The errors printed are the scaled standard errors (the standard error
times sqrt(max(1, reduced chi-square))); a reduced chi-square above 2 is a
WARNING line, and so are a flight's residuals that are not noise
(``uncertainty.residual_structure``). The residual's RMS is printed in m and
deg, as every other length and angle the tool prints (SPEC section 15).
"""

from __future__ import annotations

import math

from cfem_ros.study.fit.solve import Fit, FitResult
from cfem_ros.study.fit.uncertainty import chi2_warning, structure_warning


def estimate_text(value: float, error: float, unit: str = '') -> str:
    """
    Return 'value ± error unit', the value rounded where its standard error says.

    Two significant digits of the error; the value to the same decimal; an
    undetermined error (NaN) prints 'not determined'.
    """
    suffix = f' {unit}' if unit else ''
    if not math.isfinite(error):
        return f'{value:.6g}{suffix} (not determined)'
    if error == 0:
        return f'{value:.9g} ± 0{suffix}'
    decimals = 1 - int(math.floor(math.log10(abs(error))))
    if decimals > 0:
        return f'{value:.{decimals}f} ± {error:.{decimals}f}{suffix}'
    step = 10.0 ** (-decimals)
    return f'{round(value / step) * step:.0f} ± {round(error / step) * step:.0f}{suffix}'


def sentence(fit: Fit, result: FitResult) -> str:
    """Return what the fit found and how well, in one line (its notes on the lines after)."""
    u, parameters = result.uncertainty, fit.spec.parameters
    parts = [f'{p.name} {estimate_text(result.values[j], u.standard_errors_scaled[j], p.unit)}'
             for j, p in enumerate(parameters)]
    n = len(parts)
    for i in range(n):
        for k in range(i + 1, n):
            c = u.correlation[i, k]
            if math.isfinite(c) and abs(c) >= 0.3:
                parts.append(f'correlation {parameters[i].name} / {parameters[k].name} '
                             f'{c:+.2f}')
    rms = result.residual_rms
    parts.append(f'residual {rms["position"]:.3g} m, {rms["attitude_deg"]:.3g} deg')
    parts.append(f'reduced chi-square {u.reduced_chi2:.3g}')
    text = ', '.join(parts) + f' ({result.status}, {result.runs} runs)'
    if result.intervals is not None:
        shown = []
        for j, p in enumerate(parameters):
            low, high = result.intervals[j]
            if math.isfinite(low) and math.isfinite(high):
                unit = f' {p.unit}' if p.unit else ''
                shown.append(f'{p.name} [{low:.6g}, {high:.6g}]{unit}')
        if shown:
            text += (f'\nprofile-likelihood intervals ({fit.spec.confidence:.3g}): '
                     + ', '.join(shown))
    if len(result.flights) > 1:
        for flight, summary in zip(fit.spec.flights, result.flights):
            rms = summary['residual_rms']
            text += (f'\n{flight.key}: residual {rms["position"]:.3g} m, '
                     f'{rms["attitude_deg"]:.3g} deg over {summary["samples"]} poses')
    if result.problems:
        text += '\n' + '\n'.join(f'note: {p}' for p in result.problems)
    return text


def warnings(fit: Fit, result: FitResult) -> list:
    """Return the fit's WARNING sentences (a reduced chi-square above 2, residuals not noise)."""
    said = [chi2_warning(result.uncertainty.reduced_chi2)]
    for flight, summary in zip(fit.spec.flights, result.flights):
        said.append(structure_warning(flight.key, summary['structure']))
    return [line for line in said if line]
