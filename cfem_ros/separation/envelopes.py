# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A sweep's separation envelope in a carrier's axes (SPEC section 12).

From the recorded runs of a sweep folder (``runs/run_<k>.mcap``, written
by ``cfem-sim sweep --record all``): the separating body's x, y, z, roll,
pitch, yaw relative to the reference body, against time from each run's
own first release, on a common grid (the recording's samples, linear
between them); per grid time the median and the 5 and 95 % percentiles
over the runs; the worst run by the first criterion (least margin) drawn
on top. ``cfem-sim plot OUTDIR --relative-to BODY`` and the report draw it.
"""

from __future__ import annotations

import glob
import json
import os
import re

from cfem_ros.core.engine.events import Status
from cfem_ros.core.errors import CfemError
from cfem_ros.plots import save
from cfem_ros.recording.analysis import euler_continuous, shared_run
from cfem_ros.recording.poses import shared_poses
from cfem_ros.recording.relative import relative_track, release_time
from cfem_ros.separation.figures import LEAST_SPAN, QUANTITIES
import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402, I100 - after choosing the backend
import numpy as np  # noqa: E402, I100

#: The band drawn around the median, percent.
BAND = (5.0, 95.0)
_RUN = re.compile(r'run_(\d+)\.mcap$')


def recorded_runs(outdir: str) -> dict:
    """Return the sweep folder's recordings by run number."""
    found = {}
    for path in glob.glob(os.path.join(outdir, 'runs', 'run_*.mcap')):
        match = _RUN.search(path)
        if match:
            found[int(match.group(1))] = path
    return dict(sorted(found.items()))


def _manifest(outdir: str) -> dict:
    with open(os.path.join(outdir, 'sweep.json'), encoding='utf-8') as stream:
        return json.load(stream)


def default_reference(manifest: dict):
    """Return the body a report draws the separation in: the first kinematic body, or parent."""
    from cfem_ros.study_plots import released_pair
    document = manifest.get('resolved', {}).get('document', {})
    for name, body in (document.get('bodies') or {}).items():
        if isinstance(body, dict) and body.get('motion'):
            return name
    pair = released_pair(manifest)
    return pair[1] if pair else None


def separating_body(path: str, reference: str):
    """Return the body that moves farthest relative to reference in a recording (or None)."""
    from cfem_ros.separation.figures import free_bodies
    tracks = free_bodies(shared_poses(path), reference)
    if not tracks:
        return None
    return max(tracks, key=lambda track: np.ptp(track.position, axis=0).max()).name


def histories(recordings: dict, body: str, reference: str) -> dict:
    """
    Return ``history`` of each recording, by the same keys: read once, the angles turned at once.

    Each run's relative track comes from its poses (``recording.poses``);
    the attitudes of the runs with as many samples are made continuous in
    one call (``euler_continuous`` of a stack, each run as if alone).
    """
    tracks = {}
    for key, path in recordings.items():
        poses = shared_poses(path)
        track = relative_track(poses, body, reference)
        released = release_time(poses)
        origin = 0.0 if np.isnan(released) else released
        tracks[key] = (track.time - origin, track.position, track.euler_deg)
    alike = {}
    for key, (_, _, euler) in tracks.items():
        alike.setdefault(len(euler), []).append(key)
    out = {}
    for count, keys in alike.items():
        turned = euler_continuous(np.reshape([tracks[k][2] for k in keys], (len(keys), count, 3)))
        for key, angles in zip(keys, turned):
            out[key] = (tracks[key][0], np.column_stack([tracks[key][1], angles]))
    return {key: out[key] for key in recordings}


def history(path: str, body: str, reference: str):
    """Return (time from release (n,), values (n, 6): x, y, z m, roll, pitch, yaw deg) of a run."""
    return histories({0: path}, body, reference)[0]


def envelope(runs: list, step: float) -> tuple:
    """
    Return (grid (m,), median (m, 6), low (m, 6), high (m, 6)) of runs' histories.

    The grid runs from 0 (the release) by ``step`` to the end of the
    shortest history; each history is interpolated linearly onto it.
    """
    end = min(t[-1] for t, _ in runs)
    grid = np.arange(0.0, end + 0.5 * step, step)
    stack = np.array([[np.interp(grid, t, values[:, k]) for k in range(6)]
                      for t, values in runs])   # (runs, 6, m)
    median = np.median(stack, axis=0).T
    low, high = (np.percentile(stack, q, axis=0).T for q in BAND)
    return grid, median, low, high


def worst_run(outdir: str, runs) -> tuple:
    """
    Return (run, criterion name) of the least margin to the first criterion among runs.

    (None, None) when the folder has no criteria.
    """
    import pandas as pd
    from cfem_ros.study_plots import load_criteria
    criteria, _ = load_criteria(outdir)
    if not criteria:
        return None, None
    table = pd.read_parquet(os.path.join(outdir, 'results.parquet'))
    table = table[table['run'].isin(list(runs)) & (table['status'] != Status.INVALID)]
    if table.empty:
        return None, criteria[0].name
    margin = criteria[0].margin_of(table)
    return int(table['run'].to_numpy()[int(np.argmin(margin))]), criteria[0].name


def envelope_figure(outdir: str, reference: str):
    """Draw a sweep's envelope of the six quantities in reference's axes (a Figure)."""
    manifest = _manifest(outdir)
    recordings = recorded_runs(outdir)
    if not recordings:
        raise CfemError(f'{outdir}: no recorded runs (runs/run_<k>.mcap); expected a sweep run '
                        'with --record all for its envelope')
    body = separating_body(next(iter(recordings.values())), reference)
    if body is None:
        raise CfemError(f'{outdir}: --relative-to {reference}: no other free body to draw')
    drawn = histories(recordings, body, reference)
    rate = float(manifest.get('resolved', {}).get('rate_hz', '100') or 100)
    grid, median, low, high = envelope(list(drawn.values()), 1.0 / rate)
    worst, criterion = worst_run(outdir, drawn)
    fig, axes = plt.subplots(3, 2, figsize=(11, 9), sharex=True, layout='constrained')
    fig.suptitle(f'{body} relative to {reference}, {reference} axes: envelope of '
                 f'{len(drawn)} runs')
    for ax, column, (name, unit) in zip(axes.ravel(), (0, 3, 1, 4, 2, 5), QUANTITIES):
        ax.fill_between(grid, low[:, column], high[:, column], color='tab:blue', alpha=0.25,
                        label=f'{BAND[0]:g}-{BAND[1]:g} % of the runs')
        ax.plot(grid, median[:, column], color='tab:blue', label='median')
        if worst is not None:
            t, values = drawn[worst]
            ax.plot(t, values[:, column], color='tab:red', linewidth=1.2,
                    label=f'worst run by {criterion}: run {worst}')
        ax.axvline(0.0, color='tab:red', linestyle='--', linewidth=1.0)
        ax.set_ylabel(f'{name} [{unit}]')
        ax.grid(True, alpha=0.3)
        low_y, high_y = ax.get_ylim()
        if high_y - low_y < LEAST_SPAN[unit]:
            middle = (low_y + high_y) / 2
            ax.set_ylim(middle - LEAST_SPAN[unit] / 2, middle + LEAST_SPAN[unit] / 2)
    gravity = manifest.get('resolved', {}).get('document', {}).get('gravity', [0, 0, -1])
    if isinstance(gravity, list) and len(gravity) == 3 and gravity[2] > 0:
        axes[2, 0].invert_yaxis()
        axes[2, 0].set_ylabel('z [m] (down)')
    for ax in axes[-1]:
        ax.set_xlabel('time from release [s]')
    axes[0, 0].legend(fontsize=8, loc='best')
    return fig, worst


def write_envelope(outdir: str, reference: str, directory: str) -> list:
    """Write the envelope figure under directory; return its path in a list."""
    os.makedirs(directory, exist_ok=True)
    fig, _ = envelope_figure(outdir, reference)
    return [save(fig, os.path.join(directory, f'envelope_relative_{reference}.png'))]


def _rerun(outdir: str, manifest: dict, run: int, output: str):
    """Record run ``run`` of a Monte Carlo sweep folder again (None if it cannot be)."""
    from cfem_ros.study.runs import run_one
    from cfem_ros.study.spec import load_sweep
    if manifest.get('method', 'mc') != 'mc':
        return None
    spec = load_sweep(manifest['sweep'], runs=manifest['resolved']['runs'])
    if json.loads(spec.describe()) != manifest['resolved']:
        return None   # the sweep file changed since: not the run of the table
    run_one(spec, run, record=output)
    return output


def report_figures(outdir: str, directory: str, warn=None) -> list:
    """
    Write the report's separation figures under directory; return their paths.

    The envelope over the recorded runs (if any) and the outline snapshots
    of the worst run by the first criterion, in the axes of the first
    kinematic body (else the released joint's parent): its recording, or
    the run recorded again (Monte Carlo sweeps whose file is unchanged).
    """
    from cfem_ros.separation.figures import snapshots_figure
    manifest = _manifest(outdir)
    reference = default_reference(manifest)
    if reference is None:
        return []
    paths, recordings = [], recorded_runs(outdir)
    worst = None
    try:
        if recordings:
            fig, worst = envelope_figure(outdir, reference)
            name = f'envelope_relative_{reference}.png'
            paths.append(save(fig, os.path.join(directory, name)))
        else:
            worst, _ = worst_run(outdir, _valid_runs(outdir))
        if worst is None:
            return paths
        path = recordings.get(worst) or _rerun(outdir, manifest, worst,
                                               os.path.join(directory, f'run_{worst}.mcap'))
        if path is not None:
            fig = snapshots_figure(shared_run(path), reference,
                                   title=f'worst run ({worst}) by the first criterion')
            paths.append(save(fig, os.path.join(directory, f'snapshots_run_{worst}.png')))
    except (CfemError, OSError, KeyError, ValueError) as err:
        if warn is not None:
            warn(f'{outdir}: no separation figures in the report ({err})')
    return paths


def _valid_runs(outdir: str) -> list:
    import pandas as pd
    table = pd.read_parquet(os.path.join(outdir, 'results.parquet'), columns=['run', 'status'])
    return table.loc[table['status'] == Status.OK, 'run'].tolist()
