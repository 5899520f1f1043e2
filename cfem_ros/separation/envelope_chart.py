# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The release envelope's chart (SPEC section 14): safe, unsafe, undecided per condition.

From ``envelope.parquet`` (``study/envelope.py``): one panel per value of
the third axis (one panel with two axes), the first axis across and the
second up, each grid point marked by its decision against the target
(safe: meets, unsafe: does not meet, undecided) and labelled with its
estimate of P(any criterion fails) and the one-sided bound. Without a
target the points are coloured by their pass fraction. Where a panel's grid
has two values or more on both axes (numbers), the line where the
estimate equals the target is drawn, interpolated linearly between the
grid points (a guide between conditions that were run, not a result), with
the line where the bound equals it.
"""

from __future__ import annotations

import enum
import math
import os

from cfem_ros.plots import save
from cfem_ros.study.decision import DOES_NOT_MEET, MEETS, UNDECIDED
from cfem_ros.study.labels import label
import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402, I100 - after choosing the backend
import numpy as np  # noqa: E402, I100

CHART = 'envelope.png'
#: The table's decision without a target (``study/envelope.py``).
NO_TARGET = 'no_target'


class Verdict(enum.Enum):
    """How a condition is drawn: its words in the legend, colour and marker."""

    SAFE = ('safe (meets the target)', '#1a9641', 'o')
    UNSAFE = ('unsafe (does not meet it)', '#d7191c', 'X')
    UNDECIDED = ('undecided (more runs)', '#f59e0b', 's')

    @property
    def words(self) -> str:
        """Return the legend's words."""
        return self.value[0]


#: The table's decisions (section 9) as drawn.
VERDICTS = {MEETS: Verdict.SAFE, DOES_NOT_MEET: Verdict.UNSAFE, UNDECIDED: Verdict.UNDECIDED}


def _numbers(values) -> bool:
    return all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)
               and math.isfinite(float(v)) for v in values)


def _places(values) -> tuple:
    """Return (the distinct values in order, where each is drawn, whether they are numbers)."""
    distinct = list(dict.fromkeys(values))
    if _numbers(distinct):
        distinct = sorted(distinct, key=float)
        return distinct, [float(v) for v in distinct], True
    return distinct, list(range(len(distinct))), False   # names: evenly, in grid order


def _short(value: float) -> str:
    from cfem_ros.study.decision import up
    return 'none' if value is None or not math.isfinite(value) else up(float(value))


def _equals(words: str, value) -> str:
    """Return 'load factor n = 3 g' from the label 'load factor n [g]' and 3."""
    shown = f'{value:g}' if _numbers([value]) else str(value)
    if words.endswith(']') and ' [' in words:
        words, unit = words[:-1].rsplit(' [', 1)
        return f'{words} = {shown} {unit}'
    return f'{words} = {shown}'


def _contour(ax, panel, axes, xs, ys, target: float) -> str:
    """Draw P = target and p_upper = target over a full numeric grid; return a note if not."""
    if len(xs[0]) < 2 or len(ys[0]) < 2:
        return 'no line P = target: one value on an axis'
    shape = (len(ys[0]), len(xs[0]))
    grid = {name: np.full(shape, np.nan) for name in ('probability', 'p_upper')}
    for _, row in panel.iterrows():
        i, j = ys[0].index(row[axes[1]]), xs[0].index(row[axes[0]])
        for name in grid:
            grid[name][i, j] = row[name]
    x, y = np.meshgrid(xs[1], ys[1])
    drawn = False
    for name, style in (('probability', '-'), ('p_upper', '--')):
        field = np.ma.masked_invalid(grid[name])
        if field.count() < 4 or not (field.min() < target < field.max()):
            continue   # the level is not crossed inside the grid
        ax.contour(x, y, field, levels=[target], colors='#333333', linestyles=style,
                   linewidths=1.2)
        drawn = True
    return '' if drawn else 'the target is not crossed inside the grid'


def _panel(ax, panel, axes, target, document):
    """Draw one panel: the points, their numbers and the target's lines."""
    xs, ys = _places(panel[axes[0]].tolist()), _places(panel[axes[1]].tolist())
    for _, row in panel.iterrows():
        at = (xs[1][xs[0].index(row[axes[0]])], ys[1][ys[0].index(row[axes[1]])])
        verdict = None if target is None else VERDICTS.get(row['decision'])
        if verdict is None:   # no target: the pass fraction
            ax.scatter(*at, c=[row['pass_fraction']], cmap='RdYlGn', vmin=0.0, vmax=1.0,
                       s=140, edgecolors='black', zorder=3)
            text = f'pass {row["pass_fraction"]:.2f}\n{row["runs"]} runs'
        else:
            ax.scatter(*at, color=verdict.value[1], marker=verdict.value[2], s=140,
                       edgecolors='black', zorder=3)
            text = (f'P {row["probability"]:.2g}\n<= {_short(row["p_upper"])}'
                    if math.isfinite(row['probability']) else 'no estimate')
        ax.annotate(text, at, textcoords='offset points', xytext=(9, 5), fontsize=7)
    note = ''
    if target is not None and xs[2] and ys[2]:
        note = _contour(ax, panel, axes, xs, ys, target)
    ax.set_xticks(xs[1])
    ax.set_yticks(ys[1])
    if not xs[2]:
        ax.set_xticklabels([str(v) for v in xs[0]])
    if not ys[2]:
        ax.set_yticklabels([str(v) for v in ys[0]])
    for places, limits in ((xs[1], ax.set_xlim), (ys[1], ax.set_ylim)):
        span = (max(places) - min(places)) or 1.0
        limits(min(places) - 0.12 * span, max(places) + 0.3 * span)
    ax.set_xlabel(label(axes[0], document))
    ax.set_ylabel(label(axes[1], document))
    ax.grid(True, alpha=0.3)
    if note:
        ax.text(0.01, 0.01, note, transform=ax.transAxes, fontsize=7, color='#555555')


def envelope_figure(table, axes, *, target=None, confidence: float = 0.95,
                    document=None, title: str = ''):
    """
    Return the chart of an envelope's table: one panel per value of the third axis.

    Parameters
    ----------
    table : pandas.DataFrame
        ``envelope.parquet``: a column per axis (its key path), ``decision``,
        ``probability``, ``p_upper``, ``pass_fraction`` and ``runs``.
    axes : list of str
        The key paths across, up and (optional) one panel per value.
    target : float, optional
        The target probability (None: no decisions, pass fractions drawn).
    confidence : float
        The one-sided confidence of the bounds, for the legend.
    document : dict, optional
        The base scenario (names for the axes' labels).
    title : str
        The figure's title.

    """
    from matplotlib.lines import Line2D
    panels = [(None, table)]
    if len(axes) > 2:
        values = _places(table[axes[2]].tolist())[0]
        panels = [(v, table[table[axes[2]] == v]) for v in values]
    fig, grid = plt.subplots(1, len(panels), figsize=(5.2 * len(panels) + 0.6, 4.8),
                             squeeze=False, sharey=True)
    for ax, (value, panel) in zip(grid[0], panels):
        _panel(ax, panel, axes, target, document)
        if value is not None:
            ax.set_title(_equals(label(axes[2], document), value), fontsize=10)
    for ax in grid[0][1:]:
        ax.set_ylabel('')
    handles = []
    if target is not None:
        handles = [Line2D([], [], color=v.value[1], marker=v.value[2], linestyle='',
                          markeredgecolor='black', markersize=9, label=v.words)
                   for v in Verdict]
        handles += [Line2D([], [], color='#333333', linestyle='-',
                           label=f'P(fail) = target {target:g} (between points: linear)'),
                    Line2D([], [], color='#333333', linestyle='--',
                           label=f'{100 * confidence:g} % bound = target')]
    if handles:
        fig.legend(handles=handles, loc='lower center', ncol=min(len(handles), 3),
                   fontsize=8, frameon=False)
    fig.suptitle(title or 'Release envelope', fontsize=11)
    fig.tight_layout(rect=(0, 0.12 if handles else 0, 1, 0.95))
    if target is None:   # the colours are pass fractions: their scale
        from matplotlib.cm import ScalarMappable
        from matplotlib.colors import Normalize
        fig.colorbar(ScalarMappable(Normalize(0.0, 1.0), 'RdYlGn'), ax=list(grid[0]),
                     label='pass fraction (no target: no decision)', shrink=0.9)
    return fig


def write_chart(outdir: str, directory=None) -> str:
    """Draw an envelope folder's chart into directory (default: the folder); return its path."""
    from cfem_ros.study.envelope import read_envelope
    table, manifest = read_envelope(outdir)
    targets = table['target'].dropna().unique()
    target = float(targets[0]) if len(targets) else None
    runs = sorted({int(r) for r in table['runs']})
    each = f'{runs[0]}' if len(runs) == 1 else f'{runs[0]} to {runs[-1]}'
    title = (f'Release envelope {manifest.get("name") or ""}: {manifest.get("method", "mc")}, '
             f'{each} runs per condition')
    if target is not None:
        title += f', target P(fail) < {target:g} at {100 * float(table["confidence"][0]):g} %'
    fig = envelope_figure(table, manifest['axes'], target=target,
                          confidence=float(table['confidence'][0]), title=title)
    return save(fig, os.path.join(directory or outdir, CHART))
