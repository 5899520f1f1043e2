# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
One self-contained HTML page of a study folder (``cfem-sim report OUTDIR -o REPORT.html``).

An envelope folder (``cfem-sim envelope``) gets the release envelope's
section instead: its conditions, decisions, chart and dispersions.

The scenario and the sweep, the criteria with their failure fractions and
exact intervals, the rare-event estimate, the worst runs (each with the
command that runs it again alone), the sensitivity indices, and the
figures (``cfem-sim plot``'s, given as PNG files) embedded as data URIs:
the page needs no other file.
"""

from __future__ import annotations

import base64
import html
import json
import os
import shlex
import time

from cfem_ros.core.engine.events import Status
from cfem_ros.study.criteria import margins
from cfem_ros.study.decision import down, up
from cfem_ros.study.labels import label
import numpy as np

#: Runs listed as the worst.
WORST = 10
STYLE = """
body { font-family: sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 0.5em 0 1em; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 3px 8px; text-align: left; }
th { background: #f0f0f0; } td.num { text-align: right; font-family: monospace; }
code { background: #f4f4f4; padding: 1px 4px; font-size: 0.85em; }
.fail { color: #b00; font-weight: bold; } .pass { color: #060; font-weight: bold; }
.undecided { color: #a60; font-weight: bold; }
img { max-width: 100%; border: 1px solid #ddd; margin: 0.5em 0; }
"""


def _e(value) -> str:
    return html.escape(str(value))


def _num(value, fmt='{:.6g}') -> str:
    try:
        return fmt.format(float(value))
    except (TypeError, ValueError):
        return _e(value)


def _table(header, rows) -> str:
    out = ['<table><tr>' + ''.join(f'<th>{_e(h)}</th>' for h in header) + '</tr>']
    for row in rows:
        cells = []
        for cell in row:
            if isinstance(cell, tuple):   # (html, class)
                cells.append(f'<td class="{cell[1]}">{cell[0]}</td>')
            elif isinstance(cell, (int, float, np.floating, np.integer)) \
                    and not isinstance(cell, bool):
                cells.append(f'<td class="num">{_num(cell)}</td>')
            else:
                cells.append(f'<td>{_e(cell)}</td>')
        out.append('<tr>' + ''.join(cells) + '</tr>')
    return '\n'.join(out) + '</table>'


def _image(path: str) -> str:
    with open(path, 'rb') as stream:
        data = base64.b64encode(stream.read()).decode('ascii')
    name = os.path.basename(path)
    return f'<figure><img alt="{_e(name)}" src="data:image/png;base64,{data}"></figure>'


_DECISION_CLASS = {'meets': 'pass', 'does_not_meet': 'fail', 'undecided': 'undecided'}


def _bound(value) -> str:
    return 'none (too few failed runs)' if value is None else f'P <= {up(value)}'


def _estimate_section(est: dict, level: float) -> list:
    """Return the estimate's heading, its table (with the tail check) and its notes."""
    pct = f'{100 * est.get("level", level):g} %'
    cov = (est['cov'] if est['cov'] is not None and est['probability'] > 0
           else 'undefined (no failure)')   # no failure seen: no coefficient of variation
    interval = ('none' if est['ci_low'] is None or est['ci_high'] is None
                else f'[{down(est["ci_low"], 4)}, {up(est["ci_high"], 4)}]')
    rows = [['inputs as given', est['method'], est['probability'], cov, interval,
             _bound(est.get('p_upper')), est.get('bound', ''), est['runs']]]
    if est.get('tail_probability') is not None:
        rows.append(['heavier tails (each normal input a Student-t, 5 dof, same median and '
                     'standard deviation)', est['method'], est['tail_probability'], '', '',
                     _bound(est.get('tail_p_upper')), est.get('tail_note') or '', ''])
    out = ['<h2>Estimate of P(any criterion fails)</h2>',
           _table(['inputs', 'method', 'probability', 'coefficient of variation',
                   f'{pct} interval', f'{pct} one-sided bound', 'bound from', 'runs'], rows)]
    notes = [n for n in (est.get('disagreement'), est.get('tail_note')
                         if est.get('tail_probability') is None else '') if n]
    out.extend(f'<p>{_e(n)}</p>' for n in notes)
    return out


def rerun_command(outdir: str, run: int) -> str:
    """Return the command that runs one run of a study folder again, alone, recorded."""
    return (f'cfem-sim rerun {shlex.quote(os.path.abspath(outdir))} {int(run)} '
            f'-o run_{int(run)}.mcap')


def worst_runs(table, criteria, count: int = WORST):
    """Return the runs with the least criterion margin (the failed first), or by status."""
    if criteria:
        order = np.argsort(margins(table, criteria), kind='stable')
    else:
        order = np.argsort((table['status'] == Status.OK).to_numpy(), kind='stable')
    return table.iloc[order[:count]]


def build(outdir: str, figures=()) -> str:
    """Return the report of a study folder as HTML text."""
    import pandas as pd
    from cfem_ros.study.confidence import fractions
    table = pd.read_parquet(os.path.join(outdir, 'results.parquet'))
    with open(os.path.join(outdir, 'sweep.json'), encoding='utf-8') as stream:
        manifest = json.load(stream)
    resolved = manifest.get('resolved', {})
    document = resolved.get('document', {})
    from cfem_ros.study.criteria import INVALID, valid_runs
    from cfem_ros.study.expressions import from_json
    criteria, level = [], 0.95
    path = os.path.join(outdir, 'criteria.json')
    if os.path.exists(path):
        with open(path, encoding='utf-8') as stream:
            held = json.load(stream)
        criteria = [from_json(c) for c in held['criteria']]
        level = held['confidence']
    method = manifest.get('method', 'mc')
    ok = int((table['status'] == Status.OK).sum())
    invalid = int((table['status'] == INVALID).sum())
    everything, table = table, valid_runs(table)
    parts = [f'<h1>Separation study: {_e(document.get("name", ""))}</h1>',
             f'<p>Generated {_e(time.strftime("%Y-%m-%d %H:%M:%S %Z"))} from '
             f'<code>{_e(os.path.abspath(outdir))}</code>.</p>',
             '<h2>Scenario and sweep</h2>',
             _table(['item', 'value'], [
                 ['sweep file', manifest.get('sweep', '')],
                 ['scenario', resolved.get('scenario', '')],
                 ['method', {'mc': 'Monte Carlo (the runs of the file)', 'subset':
                             'subset sampling (OpenTURNS)', 'nais': 'non-parametric adaptive '
                             'importance sampling (OpenTURNS)', 'form': 'FORM, then importance'
                             ' sampling at its design point (OpenTURNS)', 'morris':
                             'Morris screening (SALib)', 'sobol': 'Sobol indices (SALib)'}.get(
                                 method, method)],
                 ['runs', f'{len(everything)} ({ok} finished, {len(table) - ok} did not, '
                          f"{invalid} invalid draws: refused by the scenario's checks, not "
                          'run, left out of every probability)'],
                 ['seed', resolved.get('seed', '')],
                 ['bodies', ', '.join(document.get('bodies') or {})],
                 ['joints', ', '.join(document.get('joints') or {}) or 'none'],
                 ['duration, step', f'{document.get("duration", "")} s, '
                                    f'{document.get("dt", "")} s']]),
             '<h3>Varied parameters</h3>',
             _table(['parameter', 'key path', 'distribution'],
                    [[label(v[0], document), v[0], f'{v[1]} {v[2]}']
                     for v in resolved.get('vary', [])])]
    if resolved.get('correlate'):
        parts.append(_table(['key path', 'key path', 'rho'], resolved['correlate']))
    if criteria:
        parts.append(f'<h2>Criteria and failure probabilities ({100 * level:g} % '
                     'confidence)</h2>')
        rows = []
        by_name = {c.name: c for c in criteria}
        for f in fractions(table, criteria, level):
            low, high = f.interval
            rule = by_name[f.name].text if f.name in by_name else 'any criterion fails'
            verdict = ('<span class="pass">none failed</span>' if f.failures == 0
                       else f'<span class="fail">{f.failures} failed</span>')
            rows.append([f.name, rule, (verdict, ''), f.runs, f.fraction,
                         f'[{down(low)}, {up(high)}]', f'P(fail) <= {up(f.bound)}'])
        parts.append(_table(['criterion', 'rule', 'failures', 'runs', 'fraction',
                             f'exact {100 * level:g} % interval', 'one-sided bound'], rows))
        if method != 'mc':
            parts.append('<p>The runs of a rare-event method are not drawn from the input '
                         'distributions: their failure fractions are not P(fail). The '
                         'estimate below is.</p>')
    estimate = os.path.join(outdir, 'estimate.json')
    if os.path.exists(estimate):
        with open(estimate, encoding='utf-8') as stream:
            est = json.load(stream)
        parts.extend(_estimate_section(est, level))
    worst = worst_runs(table, criteria)
    if criteria:
        why = ('The runs with the least margin to a criterion (margin in units of the '
               'threshold, below 0: fails).')
    else:
        why = 'The runs that did not finish first.'
    parts.append(f'<h2>Worst runs</h2><p>{why} Each command runs one again, alone, and '
                 'records it.</p>')
    varied = [v[0] for v in resolved.get('vary', []) if v[0] in table]
    least = margins(worst, criteria) if criteria else [np.nan] * len(worst)
    rows = []
    for (_, row), margin in zip(worst.iterrows(), least):
        failed = row.get('failed_criterion', '') if criteria else ''
        rows.append([int(row['run']), row['status'], failed or '-', float(margin),
                     '; '.join(f'{label(v, document)} = {_num(row[v])}' for v in varied),
                     row['message'] or '-',
                     (f'<code>{_e(rerun_command(outdir, row["run"]))}</code>', '')])
    parts.append(_table(['run', 'status', 'failed criterion', 'margin', 'values', 'message',
                         'reproduce'], rows))
    sensitivity = os.path.join(outdir, 'sensitivity.parquet')
    if os.path.exists(sensitivity):
        indices = pd.read_parquet(sensitivity)
        parts.append('<h2>Sensitivities</h2>')
        names = [c for c in indices.columns if c not in ('metric', 'parameter', 'design')]
        parts.append(_table(['metric', 'parameter'] + names, [
            [label(r['metric'], document), label(r['parameter'], document)]
            + [float(r[n]) for n in names] for _, r in indices.iterrows()]))
    if figures:
        parts.append('<h2>Figures</h2>')
        parts.extend(_image(p) for p in figures)
    if os.path.exists(estimate) and est.get('decision_sentence'):
        parts.append(f'<h2>Decision</h2><p class="{_DECISION_CLASS[est["decision"]]}">'
                     f'{_e(est["decision_sentence"])}</p>')
    return ('<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f'<title>Separation study {_e(document.get("name", ""))}</title>'
            f'<style>{STYLE}</style></head><body>\n' + '\n'.join(parts)
            + '\n</body></html>\n')


def envelope_section(outdir: str, figures=()) -> list:
    """
    Return the release envelope's section (SPEC section 14) of an envelope folder.

    The conditions and their decisions, the chart (figures), the
    dispersions each condition ran with, and the command that reports one
    condition's sweep alone.
    """
    from cfem_ros.study.envelope import read_envelope
    table, manifest = read_envelope(outdir)
    axes = manifest['axes']
    target = table['target'].dropna()
    level = float(table['confidence'].iloc[0]) if len(table) else 0.95
    counts = table['decision'].value_counts().to_dict()
    judged = ', '.join(f'{n} {_e(d.replace("_", " "))}' for d, n in counts.items())
    against = (f'against the target P(fail) &lt; {float(target.iloc[0]):g} at '
               f'{100 * level:g} % one-sided confidence' if len(target) else
               'without a target (pass fractions, no decision)')
    parts = ['<h2>Release envelope</h2>',
             f'<p>{len(table)} conditions, the grid of {", ".join(_e(a) for a in axes)}; '
             f'at each, the sweep\'s dispersions by {_e(manifest.get("method", "mc"))}, '
             f'judged {against}: {judged}. A line between conditions on the chart is '
             'interpolated, not run.</p>']
    parts.extend(_image(p) for p in figures)
    rows = []
    for _, row in table.iterrows():
        verdict = row['decision']
        bound = row['p_upper']
        rows.append([_num(row[a]) for a in axes] + [
            int(row['runs']), int(row['failed_runs']), int(row['unfinished_runs']),
            'none' if row['probability'] != row['probability'] else float(row['probability']),
            'none' if bound != bound else _bound(float(bound)),
            (f'<span class="{_DECISION_CLASS.get(verdict, "")}">'
             f'{_e(verdict.replace("_", " "))}</span>', ''),
            (f'<code>{_e(row["folder"])}</code>', ''), row.get('note', '') or '-'])
    parts.append(_table([label(a) for a in axes] + [
        'runs', 'runs failing a criterion', 'runs that failed', 'P(fail)',
        f'{100 * level:g} % one-sided bound', 'decision', 'folder', 'note'], rows))
    first = os.path.join(outdir, str(table['folder'].iloc[0]), 'sweep.json') if len(table) \
        else ''
    if first and os.path.exists(first):
        with open(first, encoding='utf-8') as stream:
            resolved = json.load(stream).get('resolved', {})
        document = resolved.get('document', {})
        parts.append('<h3>Dispersions at each condition</h3>')
        parts.append(_table(['parameter', 'key path', 'distribution'],
                            [[label(v[0], document), v[0], f'{v[1]} {v[2]}']
                             for v in resolved.get('vary', [])]))
    folder = os.path.join(os.path.abspath(outdir), 'points', 'point_0000')
    parts.append('<p>Each condition is a sweep folder: its own report, worst runs and '
                 f'commands come from <code>cfem-sim report {_e(shlex.quote(folder))} -o '
                 'point_0000.html</code>.</p>')
    return parts


def build_envelope(outdir: str, figures=()) -> str:
    """Return the report of an envelope folder as HTML text."""
    from cfem_ros.study.envelope import read_envelope
    _, manifest = read_envelope(outdir)
    name = manifest.get('name') or ''
    parts = [f'<h1>Release envelope: {_e(name)}</h1>',
             f'<p>Generated {_e(time.strftime("%Y-%m-%d %H:%M:%S %Z"))} from '
             f'<code>{_e(os.path.abspath(outdir))}</code> (sweep file '
             f'<code>{_e(manifest.get("sweep", ""))}</code>).</p>']
    parts.extend(envelope_section(outdir, figures))
    return ('<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f'<title>Release envelope {_e(name)}</title>'
            f'<style>{STYLE}</style></head><body>\n' + '\n'.join(parts)
            + '\n</body></html>\n')


def write_report(outdir: str, output: str, figures=()) -> str:
    """Write the report (an envelope folder's, or a sweep's) through a temporary file."""
    from cfem_ros.study.envelope import MANIFEST
    if os.path.exists(os.path.join(outdir, MANIFEST)):
        text = build_envelope(outdir, figures)
    else:
        text = build(outdir, figures)
    tmp = f'{output}.tmp-{os.getpid()}'
    try:
        with open(tmp, 'w', encoding='utf-8') as stream:
            stream.write(text)
        os.replace(tmp, output)
    finally:   # a full disk or file size limit leaves nothing behind
        if os.path.lexists(tmp):
            os.remove(tmp)
    return output
