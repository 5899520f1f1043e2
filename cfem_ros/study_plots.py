# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Figures of a sweep folder (``cfem-sim plot OUTDIR``): spreads, sensitivities, envelopes.

Histograms of each metric with its 5th, 50th and 95th percentiles and the
criteria on it as limit lines; a chosen metric against each varied
parameter (a grid of panels), runs that fail a criterion and runs that did
not finish marked; each criterion's failure fraction with its exact
interval; sensitivity indices; and, from the recorded runs, the envelope
of the released body's path relative to its parent (or, for a body with
no joint, to the carrier, or to its release point). Axes are named with
units (``study.labels``).
"""

from __future__ import annotations

import glob
import json
import os
import sys

from cfem_ros import plots
from cfem_ros.core import rotations
from cfem_ros.core.engine.events import Status
from cfem_ros.core.errors import ArgumentError
from cfem_ros.recording.poses import shared_poses
from cfem_ros.study.labels import label, unit
from cfem_ros.study.rounding import at_rounding_level, family_scale
import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402, I100 - after choosing the backend
from matplotlib.ticker import MaxNLocator  # noqa: E402, I100
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
    ok = (table['status'] == Status.OK).to_numpy()
    values = table.loc[ok, column].to_numpy(dtype=float)
    force = 'peak_force_' + column[len('peak_moment_'):]
    if column.startswith('peak_moment_') and force in table.columns:
        scale = np.fmax(np.abs(values), np.abs(table.loc[ok, force].to_numpy(dtype=float)))
        values = np.where(np.abs(values) <= plots.ROUNDING * scale, 0.0, values)
    return values[np.isfinite(values)]


def histogram_figure(table, column: str, criteria=(), document=None):
    """
    Histogram of a metric over the runs that finished, with its 5/50/95 percentiles.

    A metric whose spread is rounding (see ``at_rounding_level``) is drawn
    as one value with a note instead. Each criterion on the metric is a
    limit line, the side that fails shaded.
    """
    ok = table['status'] == Status.OK
    values = drawn_values(table, column)
    fig, ax = plt.subplots(figsize=(7, 4))
    if at_rounding_level(values, family_scale(table, column, document)):
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
    for criterion in criteria:
        if criterion.column == column:
            _limit(ax, criterion, table)
    failed = int((~ok).sum())
    note = f', {failed} did not finish (not shown)' if failed else ''
    ax.set_title(f'{label(column, document)}: {len(values)} runs{note}', fontsize=10,
                 loc='left')
    ax.set_xlabel(label(column, document))
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig


def _limit(ax, criterion, table):
    """Draw a criterion as limit line(s) on a histogram, the failing side shaded."""
    from cfem_ros.study.criteria import failures
    bad = int(failures(table, [criterion])[criterion.name].sum())
    edges = [criterion.threshold, -criterion.threshold] if criterion.absolute \
        else [criterion.threshold]
    text = f'{criterion.name}: {criterion.text} ({bad} of {len(table)} runs fail)'
    for i, edge in enumerate(edges):
        ax.axvline(edge, color='black', linewidth=1.5, label=text if i == 0 else None)
        fails_above = (criterion.op in ('<', '<=')) == (edge >= 0 or not criterion.absolute)
        ax.axvspan(edge, ax.get_xlim()[1] if fails_above else ax.get_xlim()[0],
                   color='tab:red', alpha=0.08)
    ax.legend(fontsize=8, loc='upper right')


#: Panels per row of the scatter figure.
COLUMNS = 3


def scatter_figure(table, metric: str, parameters, criteria=(), document=None):
    """
    Plot a metric against each varied parameter, a grid of COLUMNS panels a row.

    Runs that pass are blue dots, runs that fail a criterion orange
    triangles, runs that did not finish red crosses at the bottom; a
    criterion on the metric is a horizontal limit line.
    """
    parameters = list(parameters)
    count = max(1, len(parameters))
    columns = min(COLUMNS, count)
    rows = -(-count // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(4.3 * columns, 3.4 * rows + 0.6),
                             squeeze=False, sharey=True)
    ok = (table['status'] == Status.OK).to_numpy()
    passed = table['pass'].to_numpy(dtype=bool) if 'pass' in table else ok
    y = table[metric].to_numpy(dtype=float)
    finite = np.isfinite(y)
    floor = np.nanmin(y[ok & finite]) if np.any(ok & finite) else 0.0
    for i, ax in enumerate(axes.flat):
        if i >= len(parameters):
            ax.set_visible(False)
            continue
        name = parameters[i]
        x = table[name]
        if x.dtype.kind not in 'fi':
            x = x.astype('category').cat.codes
        x = x.to_numpy(dtype=float)
        good = ok & passed
        ax.plot(x[good], y[good], '.', color='tab:blue', markersize=3,
                label=f'pass ({int(good.sum())})' if 'pass' in table else 'ok')
        bad = ok & ~passed
        if np.any(bad):
            ax.plot(x[bad], y[bad], '^', color='tab:orange', markersize=4,
                    label=f'fail a criterion ({int(bad.sum())})')
        if np.any(~ok):
            ax.plot(x[~ok], np.where(finite[~ok], y[~ok], floor), 'x', color='tab:red',
                    label=f'did not finish ({int((~ok).sum())})')
        for criterion in criteria:
            if criterion.column == metric:
                for edge in ([criterion.threshold, -criterion.threshold] if criterion.absolute
                             else [criterion.threshold]):
                    ax.axhline(edge, color='black', linewidth=1.0)
        if i == 0 and (np.any(bad) or np.any(~ok)):
            ax.legend(fontsize=7)
        ax.set_xlabel(label(name, document), fontsize=9)
        ax.xaxis.set_major_locator(MaxNLocator(5))   # long tick labels do not overlap
        ax.grid(True, alpha=0.3)
        if i % columns == 0:
            ax.set_ylabel(label(metric, document), fontsize=9)
    fig.suptitle(f'{label(metric, document)} against the varied parameters', fontsize=10)
    fig.tight_layout()
    return fig


def _print_estimate(outdir: str, method: str):
    path = os.path.join(outdir, 'estimate.json')
    print(f'the runs of --{"method" if method in ("subset", "nais", "form") else "design"} '
          f'{method} are not drawn from the inputs: their failure fractions are not P(fail)')
    if os.path.exists(path):
        from cfem_ros.study.reliability import Estimate
        with open(path, encoding='utf-8') as stream:
            held = json.load(stream)
        found = Estimate.from_dict(held)
        print(found.sentence())
        if found.decision_sentence:
            print(found.decision_sentence)


def fractions_figure(table, criteria, level: float, sampled: bool = True):
    """
    Draw each criterion's failure fraction (and any's) with its exact interval.

    sampled: the runs are drawn from the inputs (a Monte Carlo sweep); if
    not (a rare-event method or a design chose them), the title says that
    the fractions are not P(fail).
    """
    from cfem_ros.study.confidence import fractions
    from cfem_ros.study.decision import up
    found = fractions(table, criteria, level)
    fig, ax = plt.subplots(figsize=(7, 1.0 + 0.5 * len(found)))
    for i, f in enumerate(found):
        low, high = f.interval
        ax.plot([low, high], [i, i], color='tab:red', linewidth=3, solid_capstyle='butt')
        ax.plot([f.fraction], [i], 'o', color='black')
        ax.annotate(f'{f.failures}/{f.runs}, P(fail) <= {up(f.bound)}', xy=(high, i),
                    xytext=(6, -3), textcoords='offset points', fontsize=8)
    ax.set_yticks(range(len(found)), [f.name for f in found])
    ax.set_ylim(-0.6, len(found) - 0.4)
    ax.invert_yaxis()
    ax.set_xlim(0, min(1.0, 1.6 * max(f.interval[1] for f in found)) or 1.0)
    ax.set_xlabel(f'P(fail) [-]: failure fraction (dot), exact {100 * level:g} % interval '
                  '(bar)')
    title = f'failures per criterion over {found[0].runs} runs'
    if not sampled:
        title += ' chosen by the method (not P(fail): see estimate.json)'
    ax.set_title(title, fontsize=10, loc='left')
    ax.grid(True, axis='x', alpha=0.3)
    fig.tight_layout()
    return fig


def sensitivity_figure(indices, metric: str, document=None):
    """Draw one metric's indices per parameter with their confidence bounds."""
    rows = indices[indices['metric'] == metric]
    morris = 'mu_star' in rows
    key = 'mu_star' if morris else 'ST'
    rows = rows.sort_values(key)
    names = [label(p, document) for p in rows['parameter']]
    fig, ax = plt.subplots(figsize=(8, 1.2 + 0.45 * len(rows)))
    at = np.arange(len(rows))
    if morris:
        ax.barh(at, rows['mu_star'], color='tab:blue', label='mu*')
        ax.errorbar(rows['mu_star'], at, xerr=[rows['mu_star'] - rows['mu_star_low'],
                                               rows['mu_star_high'] - rows['mu_star']],
                    fmt='none', color='black', capsize=3)
        ax.plot(rows['sigma'], at, 'D', color='tab:orange', label='sigma')
        ax.set_xlabel(f'Morris mu* and sigma [{unit(metric, document) or "-"} per unit of '
                      'probability]')
    else:
        for offset, index, color in ((-0.2, 'S1', 'tab:blue'), (0.2, 'ST', 'tab:orange')):
            ax.barh(at + offset, rows[index], height=0.4, color=color, label=index)
            ax.errorbar(rows[index], at + offset, xerr=[rows[index] - rows[f'{index}_low'],
                                                        rows[f'{index}_high'] - rows[index]],
                        fmt='none', color='black', capsize=3)
        ax.set_xlabel('Sobol index [-]: first order S1, total ST')
    ax.set_yticks(at, names, fontsize=8)
    ax.set_title(f'sensitivity of {label(metric, document)}', fontsize=10, loc='left')
    ax.legend(fontsize=8, loc='lower right')
    ax.grid(True, axis='x', alpha=0.3)
    fig.tight_layout()
    return fig


def released_pair(manifest: dict):
    """
    Return (joint, reference, body) of the body whose separation the envelope draws.

    The base scenario's first releasable joint: (joint, parent, child), or
    the first joint of its first release group.
    With none, the first free body (neither fixed nor moved by a table) is
    drawn relative to the carrier, the first fixed or kinematic body:
    ('', carrier, body); with no carrier, relative to its own release point
    (its position at t = 0): ('', None, body). None if no body is free.
    """
    document = manifest.get('resolved', {}).get('document', {})
    joints = document.get('joints') or {}
    for name, spec in joints.items():
        if isinstance(spec, dict) and spec.get('release'):
            return name, spec.get('parent'), spec.get('child')
    for group in (document.get('release_groups') or {}).values():   # a group's first joint
        members = group.get('joints') if isinstance(group, dict) else None
        spec = joints.get(members[0]) if isinstance(members, list) and members else None
        if isinstance(spec, dict):
            return members[0], spec.get('parent'), spec.get('child')
    bodies = {n: b for n, b in (document.get('bodies') or {}).items() if isinstance(b, dict)}
    carried = [n for n, b in bodies.items() if b.get('fixed') or b.get('motion')]
    free = [n for n in bodies if n not in carried]
    if not free:
        return None
    return '', carried[0] if carried else None, free[0]


def envelope_figure(recordings, parent, child: str):
    """
    Draw the child's CG relative to the parent's frame over the recorded runs.

    With parent None, relative to the child's own position at the first
    sample (its release point), in world axes.

    Each run is a thin line in the parent's x-z plane and against time
    (each panel's lines one ``LineCollection``, in the order of recordings);
    the shaded band is the least and largest value over the runs at each
    sample time the runs share, its edges drawn over the runs. With gravity
    along +z (z down) the z axes point down, as in ``cfem-sim plot`` of a run.
    """
    from matplotlib.collections import LineCollection
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    tracks = []
    z_down = False
    for path in recordings:
        run = shared_poses(path)
        if (parent is not None and parent not in run.bodies) or child not in run.bodies:
            continue
        z_down = z_down or plots._z_down(run)
        c = run.bodies[child]
        if parent is None:
            rel = c.position - c.position[:1]
        else:
            p = run.bodies[parent]
            rot = rotations.matrices(p.quaternion)
            rel = np.einsum('nji,nj->ni', rot, c.position - p.position)
        tracks.append((c.time, rel))
    # every run a thin line, a panel's lines one collection drawn as plot() draws lines
    for ax, lines in ((axes[0], [rel[:, [0, 2]] for _, rel in tracks]),
                      (axes[1], [np.column_stack([t, rel[:, 2]]) for t, rel in tracks])):
        ax.add_collection(LineCollection(
            lines, colors='tab:blue', alpha=0.3, linewidths=0.8, zorder=2,
            capstyle=plt.rcParams['lines.solid_capstyle'],
            joinstyle=plt.rcParams['lines.solid_joinstyle']))
    if tracks:
        n = min(len(t) for t, _ in tracks)
        z = np.array([rel[:n, 2] for _, rel in tracks])
        t = tracks[0][0][:n]
        axes[1].fill_between(t, z.min(axis=0), z.max(axis=0), color='tab:orange',
                             alpha=0.25, zorder=3, label='envelope')
        for edge in (z.min(axis=0), z.max(axis=0)):
            axes[1].plot(t, edge, color='tab:orange', linewidth=1.5, zorder=4)
        axes[1].legend(fontsize=8)
    frame = f'in {parent} axes' if parent else 'from the release point, world axes'
    axes[0].set_xlabel(f'{child} CG x {frame} [m]')
    axes[0].set_ylabel(f'{child} CG z {frame} [m]')
    axes[0].set_title(f'{child} CG relative to {parent or "its release point"}, '
                      f'{len(tracks)} runs', fontsize=10, loc='left')
    axes[1].set_xlabel('time [s]')
    axes[1].set_ylabel(f'{child} CG z {frame} [m]')
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


def load_criteria(outdir: str) -> tuple:
    """Return (criteria, confidence) a sweep folder's table was judged by (none: [], 0.95)."""
    from cfem_ros.study.expressions import from_json
    path = os.path.join(outdir, 'criteria.json')
    if not os.path.exists(path):
        return [], 0.95
    with open(path, encoding='utf-8') as stream:
        held = json.load(stream)
    return [from_json(c) for c in held['criteria']], held['confidence']


def write_sweep_figures(outdir: str, directory: str, metric=None) -> list:
    """
    Write the figures of a sweep folder as PNG files; return their paths.

    Also prints each criterion's failure fraction with its interval.

    Raises
    ------
    ArgumentError
        If metric is not a metric column of the table.
    FolderError
        If every draw of the sweep is invalid (nothing was run).

    """
    import pandas as pd
    table = pd.read_parquet(os.path.join(outdir, 'results.parquet'))
    with open(os.path.join(outdir, 'sweep.json'), encoding='utf-8') as stream:
        manifest = json.load(stream)
    document = manifest.get('resolved', {}).get('document')
    from cfem_ros.study.criteria import no_valid_draw, valid_runs
    nothing = no_valid_draw(table)
    if nothing is not None:
        from cfem_ros.study.folder import FolderError
        raise FolderError(f'{outdir}: {nothing}; nothing to draw or report')
    table = valid_runs(table)   # invalid draws were not run: nothing to draw
    criteria, level = load_criteria(outdir)
    metrics = metric_columns(table, manifest)
    if metric is None:
        metric, note = default_metric(table, metrics)
        if note:
            print(note, file=sys.stderr)
    elif metric not in table.columns:
        raise ArgumentError(f'--metric: {metric!r} is not a column of the table; expected '
                            'one of ' + ', '.join(metrics))
    os.makedirs(directory, exist_ok=True)
    paths = [_save(histogram_figure(table, m, criteria, document),
                   os.path.join(directory, f'hist_{m}.png')) for m in metrics]
    varied = varied_columns(table, manifest)
    if metric is not None and varied:
        paths.append(_save(scatter_figure(table, metric, varied, criteria, document),
                           os.path.join(directory, f'scatter_{metric}.png')))
    sampled = manifest.get('method', 'mc') == 'mc'
    if criteria and 'pass' in table:
        from cfem_ros.study.confidence import fractions
        if sampled:
            for fraction in fractions(table, criteria, level):
                print(fraction.sentence())
        else:   # the method chose the points: their fractions are not P(fail)
            _print_estimate(outdir, manifest.get('method'))
        paths.append(_save(fractions_figure(table, criteria, level, sampled),
                           os.path.join(directory, 'criteria.png')))
    sensitivity = os.path.join(outdir, 'sensitivity.parquet')
    if os.path.exists(sensitivity):
        indices = pd.read_parquet(sensitivity)
        for name in indices['metric'].unique():
            paths.append(_save(sensitivity_figure(indices, name, document),
                               os.path.join(directory, f'sensitivity_{name}.png')))
    recordings = sorted(glob.glob(os.path.join(outdir, 'runs', 'run_*.mcap')))
    pair = released_pair(manifest)
    if recordings and pair:
        _, parent, child = pair
        paths.append(_save(envelope_figure(recordings, parent, child),
                           os.path.join(directory, f'envelope_{child}_{parent or "release"}'
                                        '.png')))
    return paths
