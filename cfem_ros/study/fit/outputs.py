# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What a fit leaves in its folder (SPEC section 13), and the sentence it ends with.

``fit.json`` (values, standard errors plain and scaled, correlations,
residual RMS overall and per flight, the reduced chi-square, runs,
status), ``fitted.yaml`` (the fit's scenario with the fitted values, the
undetermined at their start; file names in it rewritten relative to the
folder so that it runs from there), ``fitted.mcap`` (the first flight's
run at the fitted values, its inputs replayed) and per flight the figures
``fit_trajectory.png`` and ``fit_residuals.png`` (``_K`` appended,
K = 0, 1, ... of ``measured[K]``, when there are several flights), drawn
in forked processes (``--threads`` of them at most) while ``fitted.mcap``
is recorded.

The folder is checked before the fit starts (``folder_problem``); the
outputs are written into a hidden folder inside it and moved into place by
renames, with SIGINT and SIGTERM held during the renames: an interrupted
write leaves the folder as it was.
"""

from __future__ import annotations

import functools
import json
import math
import os
import shutil
import signal
import stat
import tempfile

from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.study.fit.forked import Forked
from cfem_ros.study.fit.solve import Fit, FitResult
import yaml

#: Free space a fit's folder needs before the fit starts (its outputs are a few MB).
FREE_BYTES = 16 * 1024 * 1024


def output_names(flights: int) -> tuple:
    """Return the files a fit of so many flights writes into its folder."""
    figures = (('fit_trajectory.png', 'fit_residuals.png') if flights == 1 else
               tuple(f'fit_{what}_{k}.png' for k in range(flights)
                     for what in ('trajectory', 'residuals')))
    return ('fit.json', 'fitted.yaml', 'fitted.mcap') + figures


def folder_problem(outdir: str, names, overwrite: bool) -> str:
    """Return why outdir cannot take a fit's outputs ('' if it can), before any run."""
    try:
        mode = os.stat(outdir).st_mode
    except FileNotFoundError:
        mode = None
    except OSError as err:
        return f'-o {outdir}: cannot be examined ({err.strerror})'
    if mode is not None and not stat.S_ISDIR(mode):
        return f'-o {outdir}: is not a folder; expected a folder (new or existing)'
    held = [n for n in names if os.path.lexists(os.path.join(outdir, n))]
    if held and not overwrite:
        return (f'-o {outdir}: already holds {", ".join(held)}; pass --overwrite to replace '
                'them, or choose a new folder')
    folder = os.path.abspath(outdir)
    while not os.path.exists(folder):
        folder = os.path.dirname(folder)
    if not os.path.isdir(folder):
        return f'-o {outdir}: {folder} is not a folder; expected a path in a folder'
    if not os.access(folder, os.W_OK | os.X_OK):
        return f'-o {outdir}: {folder} cannot be written (read-only or not yours)'
    try:
        probe = tempfile.TemporaryFile(dir=folder)
        probe.close()
        room = os.statvfs(folder)
    except OSError as err:
        return f'-o {outdir}: {folder} cannot be written ({err.strerror})'
    free = room.f_bavail * room.f_frsize
    if free < FREE_BYTES:
        return (f'-o {outdir}: {folder} has {free / 1e6:.3g} MB free; the outputs need '
                f'{FREE_BYTES / 1e6:.3g} MB')
    return ''


def _number(value: float):
    """Return a float for JSON (NaN, which JSON lacks, as null)."""
    return None if not math.isfinite(value) else float(value)


def _window(window) -> dict:
    start, end, release = window
    return {'from': start, 'to': end, 'release': _number(release)
            if release is not None else None}


def _flight_json(flight, summary: dict) -> dict:
    return {'file': os.path.abspath(flight.measured_file), 'topic': flight.topic,
            'body': flight.body, 'relative_to': flight.relative_to,
            'scenario': os.path.abspath(flight.scenario), 'set': flight.settings,
            'sigma': {'position': flight.sigma_position,
                      'attitude_deg': flight.sigma_attitude_deg},
            'window': _window(summary['window']), 'samples': summary['samples'],
            'residual_rms': {k: float(v) for k, v in summary['residual_rms'].items()},
            'chi2': _number(summary['chi2']),
            'residual_autocorrelation': summary['structure']['autocorrelation'],
            'residual_structure_p': _number(summary['structure']['p'])}


def fit_json(fit: Fit, result: FitResult) -> dict:
    """Return the content of ``fit.json``."""
    spec, u = fit.spec, result.uncertainty
    parameters = {}
    for j, p in enumerate(spec.parameters):
        parameters[p.path] = {'value': float(result.values[j]),
                              'standard_error': _number(u.standard_errors[j]),
                              'standard_error_scaled': _number(u.standard_errors_scaled[j]),
                              # an end without a bound is null: JSON has no infinity
                              'start': p.start, 'bounds': [_number(p.low), _number(p.high)],
                              'step': p.step,
                              'determined': bool(u.determined[j]), 'name': p.name,
                              'unit': p.unit}
        if result.intervals is not None:
            low, high = result.intervals[j]
            parameters[p.path]['interval'] = [_number(low), _number(high)]
    flights = [_flight_json(f, s) for f, s in zip(spec.flights, result.flights)]
    out = {'parameters': parameters,
           'correlation': [[_number(c) for c in row] for row in u.correlation],
           'covariance_scaled': [[_number(c * _chi2_scale(u.reduced_chi2)) for c in row]
                                 for row in u.covariance],
           'reduced_chi2': _number(u.reduced_chi2), 'chi2': _number(u.chi2),
           'degrees_of_freedom': u.dof,
           'residual_rms': {k: float(v) for k, v in result.residual_rms.items()},
           'runs': result.runs, 'evaluations': result.evaluations, 'status': result.status,
           'problems': result.problems, 'optimizer': result.message,
           'samples': sum(f['samples'] for f in flights),
           'window': flights[0]['window'], 'flights': flights,
           'measured': {k: flights[0][k]
                        for k in ('file', 'topic', 'body', 'relative_to', 'sigma')},
           'scenario': os.path.abspath(spec.scenario)}
    if result.intervals is not None:
        out['confidence'] = spec.confidence
    return out


def _chi2_scale(reduced: float) -> float:
    return max(1.0, reduced) if math.isfinite(reduced) else 1.0


def fitted_document(document: dict, scenario: str, outdir: str) -> dict:
    """
    Return a scenario document with its file names relative to outdir.

    A string value that names an existing file relative to the scenario's
    folder (a motion table, a mesh, an aero table) is rewritten relative to
    outdir, so that ``fitted.yaml`` runs where it is written.
    """
    folder = os.path.dirname(os.path.abspath(scenario))

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


def write_by_renames(outdir: str, names, write) -> dict:
    """
    Have write(local) write the files names into a hidden folder of outdir, then move them.

    local maps each name to its path in the hidden folder. The renames
    are made with SIGINT and SIGTERM held; an error or an interruption
    before them leaves outdir as it was. Return the final paths by name.
    """
    os.makedirs(outdir, exist_ok=True)
    staging = tempfile.mkdtemp(prefix='.cfem-out-', dir=outdir)
    try:
        local = {name: os.path.join(staging, name) for name in names}
        write(local)
        paths = {name: os.path.join(outdir, name) for name in names}
        held = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
        try:
            for name in names:
                os.replace(local[name], paths[name])
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, held)
        return paths
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def write_outputs(fit: Fit, result: FitResult, outdir: str) -> dict:
    """Write every output into outdir (by renames from a hidden folder); return the paths."""
    spec = fit.spec
    names = output_names(len(spec.flights))

    def write(local):
        with open(local['fit.json'], 'w', encoding='utf-8') as stream:
            json.dump(fit_json(fit, result), stream, indent=1, allow_nan=False)
        document = fitted_document(spec.document_with(result.values), spec.scenario, outdir)
        with open(local['fitted.yaml'], 'w', encoding='utf-8') as stream:
            stream.write(f'# {spec.scenario} with the parameters fitted by cfem-sim fit '
                         f'({spec.path}); see fit.json\n')
            yaml.safe_dump(document, stream, sort_keys=False, default_flow_style=None)
        from cfem_ros.study.fit import figures
        jobs = []
        for k, flight in enumerate(fit.flights):
            trajectory, residuals = names[3 + 2 * k:5 + 2 * k]
            jobs += [functools.partial(figures.draw_trajectory, flight, result.values,
                                       local[trajectory]),
                     functools.partial(figures.draw_residuals, flight, result.values,
                                       local[residuals])]
        first = fit.flights[0]
        run = first.flight.document_with(spec.parameters, result.values)
        with Forked(jobs, fit.threads):   # the figures drawn beside the recording
            _record(first.flight.scenario, run, local['fitted.mcap'],
                    first.trajectories.inputs, first.trajectories.interpolate)
    return write_by_renames(outdir, names, write)


def _record(scenario: str, document: dict, output: str, inputs, interpolate_odometry: bool):
    """Run a fitted scenario for its duration and record it, as ``cfem-sim run`` does."""
    from cfem_ros.core.engine.simulator import Simulator
    from cfem_ros.recording import offline
    from cfem_ros.recording.container import Recorder
    from cfem_ros.recording.recorder import run_metadata, StateRecorder
    model = parse_scenario(document, source=scenario)
    rate = min(1.0 / model.dt, 1000.0)
    sim = Simulator(model)
    with Recorder(output, overwrite=True, atomic=True,
                  metadata=run_metadata(model, scenario, rate, model.start_ns)) as recorder:
        offline.run(sim, StateRecorder(recorder, sim, start_ns=model.start_ns), rate_hz=rate,
                    duration=model.duration,
                    inputs=[i for i in inputs if i.time <= model.duration],
                    interpolate_odometry=interpolate_odometry)
