# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What ``cfem-sim predict`` leaves in its folder (SPEC section 13), and what it says.

``prediction.json`` (the draws, the parameters drawn and held, the band at
the last sample, the criteria's pass fraction with its exact interval),
``band.parquet`` (per sample time: the draws counted and, per quantity of
the body relative to the carrier, the 5 %, median and 95 % values over the
draws and the run at the fitted values), ``draws.parquet`` (one row per
draw: its values, status, metrics, pass), each numeric column's unit in
the Parquet field metadata (``table_units``, SPEC section 15), the six-panel sheet
``prediction.png`` and the page ``prediction.html`` (self-contained). The
files are written by renames from a hidden folder, as a fit's are.
"""

from __future__ import annotations

import base64
import html
import json
import math
import os

from cfem_ros.core.engine.events import Status
from cfem_ros.recording.units import with_units
from cfem_ros.study.fit.outputs import write_by_renames
from cfem_ros.study.fit.predict import Fitted, PredictionResult, QUANTILES, QUANTITIES
from cfem_ros.study.labels import unit_rule
import numpy as np

NAMES = ('prediction.json', 'band.parquet', 'draws.parquet', 'prediction.png',
         'prediction.html')
#: Rows of the page's band table (sample times, evenly spread).
PAGE_ROWS = 11


def _number(value):
    return None if value is None or not math.isfinite(value) else float(value)


def _clean(node):
    """Return node with every float that is not finite as None (JSON has no NaN)."""
    if isinstance(node, dict):
        return {k: _clean(v) for k, v in node.items()}
    if isinstance(node, (list, tuple)):
        return [_clean(v) for v in node]
    if isinstance(node, (float, np.floating)):
        return _number(float(node))
    if isinstance(node, np.integer):
        return int(node)
    return node


def band_columns(body: str) -> list:
    """Return the band table's columns after time and draws, in order."""
    return [f'{body}_{q}_{what}' for q, _ in QUANTITIES
            for what in ('p05', 'median', 'p95', 'fitted')]


def band_table(fitted: Fitted, result: PredictionResult):
    """Return the band as a table: time (s), draws, then band_columns (m, deg)."""
    import pandas as pd
    columns = {'time': result.time, 'draws': result.counted.astype(int)}
    names = iter(band_columns(fitted.body))
    for q in range(len(QUANTITIES)):
        for values in (result.band[0][:, q], result.band[1][:, q], result.band[2][:, q],
                       result.fitted[:, q]):
            columns[next(names)] = values
    return pd.DataFrame(columns)


def table_units(table, document: dict, body: str) -> dict:
    """
    Return {column: unit} of band.parquet's or draws.parquet's numeric columns.

    The band's ``time`` (s), ``draws`` (a count) and each quantity's unit
    (``QUANTITIES``); a draw's ``run``, ``pass`` and its values and metrics
    as a sweep's table gives them (``labels.unit_rule`` with the next
    point's scenario).
    """
    known = {'time': 's', 'draws': '', 'run': '', 'pass': ''}
    for q, unit in QUANTITIES:
        known.update((f'{body}_{q}_{what}', unit) for what in ('p05', 'median', 'p95', 'fitted'))
    units = {}
    for column in table.columns:
        if column in known:
            units[column] = known[column]
        elif table[column].dtype.kind in 'fiub':
            rule = unit_rule(column, document)
            if rule is not None:
                units[column] = rule
    return units


def _write_parquet(table, path: str, document: dict, body: str):
    import pyarrow.parquet as pq
    pq.write_table(with_units(table, table_units(table, document, body)), path)


def prediction_json(fitted: Fitted, nxt, result: PredictionResult, seed: int) -> dict:
    """Return the content of ``prediction.json``."""
    table = result.table
    last, end = {}, result.end
    for q, (name, unit) in enumerate(QUANTITIES):
        last[name] = {'p05': _number(result.band[0][end, q]),
                      'median': _number(result.band[1][end, q]),
                      'p95': _number(result.band[2][end, q]),
                      'fitted': _number(result.fitted[end, q]), 'unit': unit}
    parameters = {}
    for j, key in enumerate(fitted.paths):
        error = math.sqrt(fitted.covariance[j, j]) if fitted.determined[j] else math.nan
        parameters[key] = {'value': float(fitted.values[j]),
                           'standard_error_scaled': _number(error),
                           'drawn': bool(fitted.determined[j]), 'name': fitted.names[j],
                           'unit': fitted.units[j],
                           'outside_bounds': int(np.sum(
                               (table[key] < fitted.bounds[j, 0])
                               | (table[key] > fitted.bounds[j, 1])))}
    return {'fit': os.path.abspath(fitted.path), 'next': os.path.abspath(nxt.path),
            'scenario': os.path.abspath(nxt.scenario), 'body': fitted.body,
            'relative_to': fitted.relative_to, 'draws': int(len(table)), 'seed': seed,
            'quantiles_percent': list(QUANTILES), 'band': 'pointwise over the draws',
            'quantile_uncertainty': quantile_uncertainty(int(len(table))),
            'parameters': parameters,
            'status': {str(k): int(v) for k, v in table['status'].value_counts().items()},
            'release': result.release, 'time': float(result.time[end]),
            'draws_at_end': int(result.counted[end]), 'at_end': last,
            'criteria': result.passes}


def quantile_uncertainty(draws: int) -> float:
    """
    Return the 1-sigma error of a 5 % (or 95 %) line of draws, in band half-widths.

    For a normal spread the sample 5 % quantile of N draws has a standard
    deviation sqrt(p (1 - p) / N) / phi(z_p) in standard deviations (p =
    0.05, z_p = 1.645), and the half-width of the band is 1.645 of those.
    """
    from scipy.stats import norm
    p = QUANTILES[0] / 100.0
    z = norm.ppf(1.0 - p)
    return math.sqrt(p * (1.0 - p) / draws) / norm.pdf(z) / z


def notes(fitted: Fitted, result: PredictionResult, summary: dict) -> list:
    """Return what the reader must know besides the numbers (one sentence each)."""
    out = [f'the 5 % and 95 % lines are estimated from {summary["draws"]} draws: each is '
           f'uncertain by about {100 * summary["quantile_uncertainty"]:.0f} % of the band\'s '
           'half-width (1 sigma, for a normal spread; more draws narrow it as 1/sqrt(N))']
    for j in np.flatnonzero(~fitted.determined):
        out.append(f'{fitted.names[j]} was not determined by the flights: held at '
                   f'{fitted.values[j]:g}; its uncertainty is not in the band')
    for key, entry in summary['parameters'].items():
        if entry['outside_bounds']:
            out.append(f'{entry["name"]}: {entry["outside_bounds"]} draw(s) outside the '
                       "fit's bounds (drawn from the fitted covariance as they are)")
    others = {k: v for k, v in summary['status'].items() if k != Status.OK}
    if others:
        out.append('draws not run to the end: ' + ', '.join(
            f'{v} {k}' for k, v in sorted(others.items())) + ' (failed and invalid draws are '
            'not in the band; every draw that did not pass counts against the criteria)')
    if fitted.status and fitted.status != 'converged':
        out.append(f"the fit's status is {fitted.status}: see its fit.json problems")
    return out


def sentence(fitted: Fitted, result: PredictionResult) -> str:
    """Return the prediction at the last sample and the criteria's pass fraction."""
    end = result.end
    t = result.time[end]
    after = result.release is not None
    when = f'{t:.6g} s' + (f' ({t - result.release:.6g} s after release)' if after else '')
    parts = []
    for q, (name, unit) in enumerate(QUANTITIES):
        low, median, high = (result.band[k][end, q] for k in range(3))
        parts.append(f'{name.replace("_deg", "")} {median:.4g} {unit} '
                     f'(5-95 %: {low:.4g} to {high:.4g})')
    text = (f'{fitted.body} relative to {fitted.relative_to} at {when}, median of '
            f'{int(result.counted[end])} draws: ' + ', '.join(parts))
    if result.passes:
        p = result.passes
        text += (f'\ncriteria passed by {p["passed"]} of {p["runs"]} draws '
                 f'({100 * p["fraction"]:.1f} %; {100 * p["confidence"]:g} % interval '
                 f'{100 * p["interval"][0]:.1f} to {100 * p["interval"][1]:.1f} %)')
    return text


def draw_sheet(fitted: Fitted, result: PredictionResult, path: str):
    """
    Draw the sheet: per quantity, the band with the median and fitted run, and its spread.

    Left, each quantity with its 5-95 % band (often thinner than the line
    at this scale); right, the band, the median and the fitted run less the
    fitted run, where the uncertainty left is seen.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    zero = result.release if result.release is not None else 0.0
    label = 'time from release (s)' if result.release is not None else 'time (s)'
    t = result.time - zero
    figure, axes = plt.subplots(len(QUANTITIES), 2, figsize=(11, 15), sharex=True)
    for q, (name, unit) in enumerate(QUANTITIES):
        shown = name.replace('_deg', '')
        for side, less in ((0, 0.0), (1, result.fitted[:, q])):
            ax = axes[q, side]
            ax.fill_between(t, result.band[0][:, q] - less, result.band[2][:, q] - less,
                            color='tab:blue', alpha=0.25, lw=0, label='5-95 % of the draws')
            ax.plot(t, result.band[1][:, q] - less, '-', color='tab:blue', label='median')
            ax.plot(t, result.fitted[:, q] - less, '--', color='black', lw=0.8,
                    label='fitted values')
            ax.set_ylabel(f'{shown} ({unit})' if side == 0 else
                          f'{shown} - fitted run ({unit})')
            ax.grid(True, alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel(label)
    axes[0, 1].legend(loc='best', fontsize=8)
    figure.suptitle(f'{fitted.body} relative to {fitted.relative_to} ({fitted.relative_to} '
                    f'axes): {len(result.table)} draws of the fitted parameters')
    figure.subplots_adjust(left=0.09, right=0.98, top=0.95, bottom=0.05, hspace=0.12,
                           wspace=0.25)
    figure.savefig(path, dpi=100)
    plt.close(figure)


def _table(header, rows) -> str:
    out = ['<table><tr>' + ''.join(f'<th>{html.escape(str(h))}</th>' for h in header)
           + '</tr>']
    for row in rows:
        out.append('<tr>' + ''.join(f'<td>{html.escape(str(c))}</td>' for c in row) + '</tr>')
    return '\n'.join(out + ['</table>'])


def page(fitted: Fitted, result: PredictionResult, summary: dict, said: list,
         figure: str) -> str:
    """Return the self-contained page: sentence, parameters, criteria, band, sheet."""
    with open(figure, 'rb') as stream:
        image = base64.b64encode(stream.read()).decode('ascii')
    parameters = [(e['name'], key, f'{e["value"]:.6g}',
                   'held (not determined)' if not e['drawn']
                   else f'{e["standard_error_scaled"]:.3g}', e['unit'])
                  for key, e in summary['parameters'].items()]
    first = 0 if result.release is None else int(np.searchsorted(result.time, result.release))
    first = min(first, len(result.time) - 1)   # from the release: before it the draws agree
    rows = np.unique(np.linspace(first, len(result.time) - 1, PAGE_ROWS).round().astype(int))
    band = []
    for i in rows:
        after = '' if result.release is None else f' ({result.time[i] - result.release:.4g})'
        cells = [f'{result.time[i]:.4g}{after}', int(result.counted[i])]
        for q in range(len(QUANTITIES)):
            cells.append(f'{result.band[1][i, q]:.4g} [{result.band[0][i, q]:.4g}, '
                         f'{result.band[2][i, q]:.4g}]')
        band.append(cells)
    body = [f'<h1>Prediction of {html.escape(os.path.basename(summary["next"]))}</h1>',
            '<p>' + '<br>'.join(html.escape(line) for line in said) + '</p>',
            f'<p>Fit: <code>{html.escape(summary["fit"])}</code>; scenario: '
            f'<code>{html.escape(summary["scenario"])}</code>; {summary["draws"]} draws '
            f'(seed {summary["seed"]}) from the fitted covariance, scaled by the reduced '
            'chi-square. The band is pointwise: at each time it holds the middle 90 % of '
            'the draws.</p>',
            '<h2>Parameters</h2>',
            _table(('parameter', 'key path', 'fitted value', 'scaled standard error',
                    'unit'), parameters)]
    if result.passes:
        p = result.passes
        body += ['<h2>Criteria</h2>',
                 _table(('criterion', 'draws passing', 'of'),
                        [(name, n, p['runs']) for name, n in p['criteria'].items()]
                        + [('all', p['passed'], p['runs'])])]
    header = ['time (s)' if result.release is None else 'time (s; from release)', 'draws']
    header += [f'{n.replace("_deg", "")} ({u}): median [5 %, 95 %]' for n, u in QUANTITIES]
    body += [f'<h2>{html.escape(fitted.body)} relative to {html.escape(fitted.relative_to)}'
             '</h2>', _table(header, band),
             f'<img alt="prediction sheet" style="max-width:100%" '
             f'src="data:image/png;base64,{image}">']
    return ('<!DOCTYPE html><html><head><meta charset="utf-8"><title>cfem-sim predict'
            '</title><style>body{font-family:sans-serif;max-width:1100px;margin:2em auto}'
            'table{border-collapse:collapse;font-size:0.9em;margin:0.5em 0 1em}'
            'th,td{border:1px solid #ccc;padding:3px 8px}th{background:#f0f0f0}</style>'
            '</head><body>\n' + '\n'.join(body) + '\n</body></html>\n')


def write_prediction(fitted: Fitted, nxt, result: PredictionResult, seed: int,
                     outdir: str) -> tuple:
    """Write the outputs into outdir by renames; return (paths, sentence, notes)."""
    summary = prediction_json(fitted, nxt, result, seed)
    said = sentence(fitted, result)
    extra = notes(fitted, result, summary)

    def write(local):
        with open(local['prediction.json'], 'w', encoding='utf-8') as stream:
            json.dump(_clean(summary), stream, indent=1, allow_nan=False)
        _write_parquet(band_table(fitted, result), local['band.parquet'], nxt.document,
                       fitted.body)
        _write_parquet(result.table, local['draws.parquet'], nxt.document, fitted.body)
        draw_sheet(fitted, result, local['prediction.png'])
        with open(local['prediction.html'], 'w', encoding='utf-8') as stream:
            stream.write(page(fitted, result, summary, said.split('\n') + extra,
                              local['prediction.png']))
    return write_by_renames(outdir, NAMES, write), said, extra
