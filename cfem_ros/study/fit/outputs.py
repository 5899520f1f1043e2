# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What a fit leaves in its folder (SPEC section 13), and the sentence it ends with.

``fit.json`` (values, standard errors, correlations, residual RMS, runs,
status), ``fitted.yaml`` (the scenario with the fitted values; file names
in it rewritten relative to the folder so that it runs from there),
``fitted.mcap`` (its run, with the measured inputs replayed) and the
figures ``fit_trajectory.png`` and ``fit_residuals.png``. Each file is
written to a temporary name and moved into place.
"""

from __future__ import annotations

import json
import math
import os

from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.study.fit.solve import Fit, FitResult
import yaml

#: The files a fit writes into its folder.
OUTPUTS = ('fit.json', 'fitted.yaml', 'fitted.mcap', 'fit_trajectory.png', 'fit_residuals.png')


def _replace(tmp: str, path: str):
    os.replace(tmp, path)


def _number(value: float):
    """Return a float for JSON (NaN, which JSON lacks, as null)."""
    return None if not math.isfinite(value) else float(value)


def fit_json(fit: Fit, result: FitResult) -> dict:
    """Return the content of ``fit.json``."""
    spec = fit.spec
    parameters = {}
    for j, p in enumerate(spec.parameters):
        parameters[p.path] = {'value': float(result.values[j]),
                              'standard_error': _number(result.standard_errors[j]),
                              'start': p.start, 'bounds': [p.low, p.high], 'step': p.step,
                              'determined': bool(result.determined[j]), 'name': p.name,
                              'unit': p.unit}
    start, end, release = result.window
    return {'parameters': parameters,
            'correlation': [[_number(c) for c in row] for row in result.correlation],
            'residual_rms': {k: float(v) for k, v in result.residual_rms.items()},
            'runs': result.runs, 'evaluations': result.evaluations, 'status': result.status,
            'problems': result.problems, 'optimizer': result.message,
            'reduced_chi_square': _number(result.reduced_chi_square),
            'samples': int(len(fit.data.time)),
            'window': {'from': start, 'to': end, 'release': _number(release)
                       if release is not None else None},
            'measured': {'file': os.path.abspath(spec.measured_file), 'topic': spec.topic,
                         'body': spec.body, 'relative_to': spec.relative_to,
                         'sigma': {'position': spec.sigma_position,
                                   'attitude_deg': spec.sigma_attitude_deg}},
            'scenario': os.path.abspath(spec.scenario)}


def fitted_document(fit: Fit, values, outdir: str) -> dict:
    """
    Return the scenario with the fitted values, its file names relative to outdir.

    A string value that names an existing file relative to the scenario's
    folder (a motion table, a mesh, an aero table) is rewritten relative to
    outdir, so that ``fitted.yaml`` runs where it is written.
    """
    document = fit.spec.document_with(values)
    folder = os.path.dirname(os.path.abspath(fit.spec.scenario))

    def moved(node):
        if isinstance(node, dict):
            return {k: moved(v) for k, v in node.items()}
        if isinstance(node, list):
            return [moved(v) for v in node]
        if isinstance(node, str) and not os.path.isabs(node) \
                and os.path.isfile(os.path.join(folder, node)):
            return os.path.relpath(os.path.join(folder, node), os.path.abspath(outdir))
        return node

    return moved(document)


def write_outputs(fit: Fit, result: FitResult, outdir: str, inputs=(),
                  interpolate_odometry: bool = True) -> dict:
    """Write every output into outdir; return {what: path}."""
    os.makedirs(outdir, exist_ok=True)
    paths = {name: os.path.join(outdir, name) for name in OUTPUTS}
    tmp = f'.tmp-{os.getpid()}'
    with open(paths['fit.json'] + tmp, 'w', encoding='utf-8') as stream:
        json.dump(fit_json(fit, result), stream, indent=1)
    _replace(paths['fit.json'] + tmp, paths['fit.json'])
    document = fitted_document(fit, result.values, outdir)
    with open(paths['fitted.yaml'] + tmp, 'w', encoding='utf-8') as stream:
        stream.write(f'# {fit.spec.scenario} with the parameters fitted by cfem-sim fit '
                     f'({fit.spec.path}); see fit.json\n')
        yaml.safe_dump(document, stream, sort_keys=False, default_flow_style=None)
    _replace(paths['fitted.yaml'] + tmp, paths['fitted.yaml'])
    _record(paths['fitted.yaml'], document, paths['fitted.mcap'], inputs, interpolate_odometry)
    from cfem_ros.study.fit.figures import draw
    draw(fit, result, paths['fit_trajectory.png'], paths['fit_residuals.png'])
    return paths


def _record(scenario: str, document: dict, output: str, inputs, interpolate_odometry: bool):
    """Run the fitted scenario for its duration and record it, as ``cfem-sim run`` does."""
    from cfem_ros.core.engine.simulator import Simulator
    from cfem_ros.recording import offline
    from cfem_ros.recording.container import Recorder
    from cfem_ros.recording.recorder import run_metadata, StateRecorder
    model = parse_scenario(document, source=scenario)
    rate = min(1.0 / model.dt, 1000.0)
    sim = Simulator(model)
    with Recorder(output, overwrite=True, atomic=True,
                  metadata=run_metadata(model, scenario, rate, 0)) as recorder:
        offline.run(sim, StateRecorder(recorder, sim), rate_hz=rate, duration=model.duration,
                    inputs=[i for i in inputs if i.time <= model.duration],
                    interpolate_odometry=interpolate_odometry)


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
    """Return what the fit found, and how well, in one sentence."""
    parts = [f'{p.name} {estimate_text(result.values[j], result.standard_errors[j], p.unit)}'
             for j, p in enumerate(fit.spec.parameters)]
    n = len(parts)
    for i in range(n):
        for k in range(i + 1, n):
            c = result.correlation[i, k]
            if math.isfinite(c) and abs(c) >= 0.3:
                parts.append(f'correlation {fit.spec.parameters[i].name} / '
                             f'{fit.spec.parameters[k].name} {c:+.2f}')
    rms = result.residual_rms
    parts.append(f'residual {rms["position"] * 1000:.3g} mm, {rms["attitude_deg"]:.3g} deg')
    text = ', '.join(parts) + f' ({result.status}, {result.runs} runs)'
    if result.problems:
        text += '\n' + '\n'.join(f'note: {p}' for p in result.problems)
    return text
