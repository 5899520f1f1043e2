# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Figures of a sweep folder (``cfem-sim plot OUTDIR``): spreads, sensitivities, envelopes.

Histograms of each metric with its 5th, 50th and 95th percentiles; a
chosen metric against each varied parameter, failed runs marked; and,
from the recorded runs, the envelope of the released body's path
relative to its parent.
"""

from __future__ import annotations

import glob
import json
import os
import sys

from cfem_ros import plots
from cfem_ros.core import rotations
from cfem_ros.recording.analysis import open_run
import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402, I100 - after choosing the backend
import numpy as np  # noqa: E402, I100

DPI = 110
PERCENTILES = (5, 50, 95)
FIXED_COLUMNS = ('run', 'status', 'message')


def metric_columns(table, manifest: dict) -> list:
    """Return the metric columns that vary over a sweep table (not indices, not causes)."""
    varied = set(varied_columns(table, manifest))
    out = []
    for name in table.columns:
        if name in FIXED_COLUMNS or name in varied or name.endswith(('_point_a', '_point_b')):
            continue
        values = table[name].to_numpy()
        if table[name].dtype.kind == 'f' and np.isfinite(values).any() \
                and np.nanmax(values) > np.nanmin(values):   # constants have no spread
            out.append(name)
    return out


def varied_columns(table, manifest: dict) -> list:
    """Return the columns of the varied key paths, in file order."""
    vary = manifest.get('resolved', {}).get('vary', [])
    return [v[0] for v in vary if v[0] in table.columns]


def drawn_values(table, column: str) -> np.ndarray:
    """
    Return a metric's finite values over the runs that finished, as the figures draw them.

    A joint's peak moment below ``plots.ROUNDING`` times that joint's largest
    load in the run (its peak moment, or its peak force on a 1 m lever arm)
    is rounding and drawn as zero, as in the figures of a run.
    """
    ok = (table['status'] == 'ok').to_numpy()
    values = table.loc[ok, column].to_numpy(dtype=float)
    force = 'peak_force_' + column[len('peak_moment_'):]
    if column.startswith('peak_moment_') and force in table.columns:
        scale = np.fmax(np.abs(values), np.abs(table.loc[ok, force].to_numpy(dtype=float)))
        values = np.where(np.abs(values) <= plots.ROUNDING * scale, 0.0, values)
    return values[np.isfinite(values)]


def at_rounding_level(values: np.ndarray) -> bool:
    """Return whether values spread by no more than ROUNDING x their largest magnitude."""
    if not len(values):
        return False
    return float(values.max() - values.min()) <= plots.ROUNDING * float(np.abs(values).max())


def histogram_figure(table, column: str):
    """
    Histogram of a metric over the runs that finished, with its 5/50/95 percentiles.

    A metric whose spread is rounding (see ``at_rounding_level``) is drawn
    as one value with a note instead.
    """
    ok = table['status'] == 'ok'
    values = drawn_values(table, column)
    fig, ax = plt.subplots(figsize=(7, 4))
    if at_rounding_level(values):
        raw = table.loc[ok, column].to_numpy(dtype=float)
        raw = raw[np.isfinite(raw)]
        value = float(np.median(values))
        ax.axvline(value, color='tab:blue', linewidth=2.0)
        ax.text(0.02, 0.95, f'{column} = {value:.6g} in every run: its values '
                f'({raw.min():.6g} to {raw.max():.6g}) differ by rounding only\n'
                f'(within {plots.ROUNDING:g} of the largest, or of the largest load of '
                'the joint), so no histogram', transform=ax.transAxes, fontsize=8,
                va='top')
        ax.set_yticks([])
    else:
        ax.hist(values, bins=max(10, min(60, int(np.sqrt(len(values))) * 2)),
                color='tab:blue', alpha=0.8)
        if len(values):
            for p, value in zip(PERCENTILES, np.percentile(values, PERCENTILES)):
                ax.axvline(value, color='tab:red', linestyle='--', linewidth=1.0)
                ax.annotate(f'P{p} = {value:.6g}', xy=(value, 1.0),
                            xycoords=('data', 'axes fraction'), xytext=(3, -12 - p // 10),
                            textcoords='offset points', color='tab:red', fontsize=8,
                            rotation=90, va='top')
        ax.set_ylabel('runs')
    failed = int((~ok).sum())
    note = f', {failed} failed (not shown)' if failed else ''
    ax.set_title(f'{column}: {len(values)} runs{note}', fontsize=10, loc='left')
    ax.set_xlabel(column)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig


def scatter_figure(table, metric: str, parameters):
    """Plot a metric against each varied parameter; failed runs as red crosses at the bottom."""
    parameters = list(parameters)
    count = max(1, len(parameters))
    fig, axes = plt.subplots(1, count, figsize=(4.5 * count, 4), squeeze=False)
    ok = (table['status'] == 'ok').to_numpy()
    y = table[metric].to_numpy(dtype=float)
    finite = np.isfinite(y)
    floor = np.nanmin(y[ok & finite]) if np.any(ok & finite) else 0.0
    for ax, name in zip(axes[0], parameters):
        x = table[name]
        if x.dtype.kind not in 'fi':
            x = x.astype('category').cat.codes
        x = x.to_numpy(dtype=float)
        ax.plot(x[ok], y[ok], '.', color='tab:blue', markersize=3, label='ok')
        if np.any(~ok):
            ax.plot(x[~ok], np.where(finite[~ok], y[~ok], floor), 'x', color='tab:red',
                    label=f'failed ({int((~ok).sum())})')
            ax.legend(fontsize=8)
        ax.set_xlabel(name)
        ax.grid(True, alpha=0.3)
    axes[0][0].set_ylabel(metric)
    fig.suptitle(f'{metric} against the varied parameters', fontsize=10)
    fig.tight_layout()
    return fig


def released_pair(manifest: dict):
    """Return (joint, parent, child) of the base scenario's first releasable joint, or None."""
    joints = manifest.get('resolved', {}).get('document', {}).get('joints') or {}
    for name, spec in joints.items():
        if isinstance(spec, dict) and spec.get('release'):
            return name, spec.get('parent'), spec.get('child')
    return None


def envelope_figure(recordings, parent: str, child: str):
    """
    Draw the child's CG relative to the parent's frame over the recorded runs.

    Each run is a thin line in the parent's x-z plane and against time;
    the shaded band is the least and largest value over the runs at each
    sample time the runs share, its edges drawn over the runs. With gravity
    along +z (z down) the z axes point down, as in ``cfem-sim plot`` of a run.
    """
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    tracks = []
    z_down = False
    for path in recordings:
        run = open_run(path)
        if parent not in run.bodies or child not in run.bodies:
            continue
        z_down = z_down or plots._z_down(run)
        p, c = run.bodies[parent], run.bodies[child]
        rot = rotations.matrices(p.quaternion)
        rel = np.einsum('nji,nj->ni', rot, c.position - p.position)
        tracks.append((c.time, rel))
        axes[0].plot(rel[:, 0], rel[:, 2], color='tab:blue', alpha=0.3, linewidth=0.8)
        axes[1].plot(c.time, rel[:, 2], color='tab:blue', alpha=0.3, linewidth=0.8)
    if tracks:
        n = min(len(t) for t, _ in tracks)
        z = np.array([rel[:n, 2] for _, rel in tracks])
        t = tracks[0][0][:n]
        axes[1].fill_between(t, z.min(axis=0), z.max(axis=0), color='tab:orange',
                             alpha=0.25, zorder=3, label='envelope')
        for edge in (z.min(axis=0), z.max(axis=0)):
            axes[1].plot(t, edge, color='tab:orange', linewidth=1.5, zorder=4)
        axes[1].legend(fontsize=8)
    axes[0].set_xlabel(f'x in {parent} axes [m]')
    axes[0].set_ylabel(f'z in {parent} axes [m]')
    axes[0].set_title(f'{child} CG relative to {parent}, {len(tracks)} runs', fontsize=10,
                      loc='left')
    axes[1].set_xlabel('time [s]')
    axes[1].set_ylabel(f'z in {parent} axes [m]')
    for ax in axes:
        ax.grid(True, alpha=0.3)
        if z_down:
            ax.invert_yaxis()
    fig.tight_layout()
    return fig


def default_metric(table, metrics: list):
    """
    Return (the metric the scatter figure draws by default, a note or None).

    The first clearance minimum, or when it is the same in every run the
    first metric that varies; the note says so.
    """
    is_min = [c for c in table.columns if c.startswith('clearance_') and c.endswith('_min')]
    chosen = next((m for m in metrics if m in is_min), metrics[0] if metrics else None)
    first = is_min[0] if is_min else None
    if first is None or first == chosen:
        return chosen, None
    values = table[first].to_numpy(dtype=float)
    values = values[np.isfinite(values)]
    same = (f'the same in every run ({values[0]:.6g})' if len(values)
            else 'not a number in any run')
    instead = (f'the scatter figure draws {chosen} instead' if chosen
               else 'no metric varies: no scatter figure')
    return chosen, f'cfem-sim plot: {first} is {same}; {instead} (choose with --metric)'


def _save(fig, path: str) -> str:
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def write_sweep_figures(outdir: str, directory: str, metric=None) -> list:
    """
    Write the figures of a sweep folder as PNG files; return their paths.

    Raises
    ------
    ValueError
        If metric is not a metric column of the table.

    """
    import pandas as pd
    table = pd.read_parquet(os.path.join(outdir, 'results.parquet'))
    with open(os.path.join(outdir, 'sweep.json'), encoding='utf-8') as stream:
        manifest = json.load(stream)
    metrics = metric_columns(table, manifest)
    if metric is None:
        metric, note = default_metric(table, metrics)
        if note:
            print(note, file=sys.stderr)
    elif metric not in table.columns:
        raise ValueError(f'--metric: {metric!r} is not a column of the table; expected one of '
                         + ', '.join(metrics))
    os.makedirs(directory, exist_ok=True)
    paths = [_save(histogram_figure(table, m), os.path.join(directory, f'hist_{m}.png'))
             for m in metrics]
    varied = varied_columns(table, manifest)
    if metric is not None and varied:
        paths.append(_save(scatter_figure(table, metric, varied),
                           os.path.join(directory, f'scatter_{metric}.png')))
    recordings = sorted(glob.glob(os.path.join(outdir, 'runs', 'run_*.mcap')))
    pair = released_pair(manifest)
    if recordings and pair:
        _, parent, child = pair
        paths.append(_save(envelope_figure(recordings, parent, child),
                           os.path.join(directory, f'envelope_{child}_{parent}.png')))
    return paths
