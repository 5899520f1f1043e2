# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The release envelope (SPEC section 14): a grid of flight conditions, each with its dispersions.

A sweep file whose ``vary`` names grids of conditions (``flight.mach: {grid:
[...]}``) and dispersions: the envelope's axes are two or three of those
grids. Each point of the axes' grid is the sweep with the axes' values
written into the scenario and the other variables drawn as the sweep draws
them (the same seed at every point: common random numbers), run by the
sweep's own machinery in ``OUTDIR/points/point_<k>`` (Monte Carlo: ``Sweep``;
a rare-event method: ``methods.run_study``), so a point is resumed as a
sweep is. Each point gets its estimate of P(any criterion fails), its
one-sided bound and, with a ``target``, its decision (section 9);
``envelope.parquet`` holds one row per point (``envelope_chart`` draws it),
each numeric column's unit in its field metadata (``UNITS``).
"""

from __future__ import annotations

import collections
import dataclasses
import itertools
import json
import math
import os
import re
from typing import Callable, Optional

from cfem_ros.core.engine.events import Status
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.study.draws import draw
from cfem_ros.study.errors import SweepError
from cfem_ros.study.keypaths import apply_values
from cfem_ros.study.resources import MethodFailed
from cfem_ros.study.spec import load_sweep, SweepSpec

ENVELOPE = 'envelope.parquet'
MANIFEST = 'envelope.json'
#: Where each point's sweep folder is, under OUTDIR.
POINTS = 'points'
#: The table's columns after the axes.
COLUMNS = ('point', 'method', 'runs', 'failed_runs', 'unfinished_runs', 'pass_fraction',
           'probability', 'p_upper', 'confidence', 'target', 'decision', 'folder', 'note')
#: The units of the numeric columns after the axes (counts and fractions: none); an axis has
#: its key's unit (``labels.unit_rule``), in the Parquet field metadata (SPEC section 15).
UNITS = {'point': '', 'runs': '', 'failed_runs': '', 'unfinished_runs': '',
         'pass_fraction': '', 'probability': '', 'p_upper': '', 'confidence': '', 'target': ''}


@dataclasses.dataclass
class Envelope:
    """
    A checked envelope: the sweep, its axes and the points of their grid.

    Attributes
    ----------
    spec : SweepSpec
        The whole sweep (axes and dispersions).
    axes : list of str
        The key paths of the axes (x, y and maybe z), each a ``grid`` of ``vary``.
    points : list of tuple
        Every combination of the axes' values, x slowest.

    """

    spec: SweepSpec
    axes: list
    points: list

    def point_values(self, k: int) -> dict:
        """Return point k's value of each axis."""
        return dict(zip(self.axes, self.points[k]))

    def point_spec(self, k: int) -> SweepSpec:
        """
        Return point k's sweep: the axes' values in the scenario, the other variables drawn.

        What a sweep file with those values written in its scenario and the
        axes left out of ``vary`` gives (the same draws: the same seed).
        """
        return point_spec(self.spec, self.point_values(k))


def point_spec(spec: SweepSpec, values: dict) -> SweepSpec:
    """Return the sweep with these key paths fixed at these values (out of ``vary``)."""
    fixed = [v for v in spec.variables if v.path in values]
    others = [v for v in spec.variables if v.path not in values]
    document = apply_values(spec.document, fixed, values)
    correlations = [c for c in spec.correlations if c[0] not in values and c[1] not in values]
    return dataclasses.replace(spec, document=document, variables=others,
                               values=draw(others, spec.runs, spec.seed, correlations),
                               correlations=correlations)


def load_envelope(path: str, axes, runs: Optional[int] = None) -> Envelope:
    """
    Read a sweep file and check the envelope's axes against it, before any run.

    Raises
    ------
    SweepError
        An axis that is not a grid of ``vary``, an axis twice, a sweep
        without criteria (a point's answer is P(a criterion fails)), or a
        point whose scenario is refused (named with its values).

    """
    spec = load_sweep(path, runs=runs)
    grids = {v.path: v for v in spec.variables if v.kind == 'grid'}
    for name, axis in zip(('--x', '--y', '--z'), axes):
        if axis in grids:
            continue
        what = ('is varied as ' + next(v.kind for v in spec.variables if v.path == axis)
                if any(v.path == axis for v in spec.variables) else 'is not in vary')
        raise SweepError(path, f'vary.{axis}', f'{what} ({name} {axis})',
                         f'a grid of the conditions: vary: {{{axis}: {{grid: [...]}}}}; '
                         'grids here: ' + (', '.join(grids) or 'none'))
    if len(set(axes)) != len(axes):
        raise SweepError(path, 'vary', f'the axes {", ".join(axes)} name a key path twice',
                         'two or three different grids of vary')
    if not spec.criteria:
        raise SweepError(path, 'criteria', 'missing: each point of an envelope is judged by '
                         'them', 'criteria as in SPEC section 9 (and a target for decisions)')
    points = list(itertools.product(*(grids[a].params for a in axes)))
    envelope = Envelope(spec=spec, axes=list(axes), points=points)
    for k in range(len(points)):
        _check_point(envelope, k)
    return envelope


def _check_point(envelope: Envelope, k: int):
    """Refuse a point whose scenario (with the axes' values, before the draws) is refused."""
    spec = envelope.spec
    fixed = [v for v in spec.variables if v.path in envelope.axes]
    document = apply_values(spec.document, fixed, envelope.point_values(k))
    try:
        parse_scenario(document, source=spec.scenario)
    except ScenarioError as err:
        where = ', '.join(f'{a} = {v!r}' for a, v in envelope.point_values(k).items())
        raise SweepError(spec.path, 'vary', f'the point {where} gives a scenario that is '
                         f'refused: {err}', 'grids of conditions the scenario accepts') from err


def point_folder(outdir: str, k: int) -> str:
    """Return point k's sweep folder."""
    return os.path.join(outdir, POINTS, f'point_{k:04d}')


def write_manifest(envelope: Envelope, outdir: str, method: str):
    """Write ``envelope.json``: the axes, the points and their folders (refused if another)."""
    path = os.path.join(outdir, MANIFEST)
    held = {'sweep': os.path.abspath(envelope.spec.path), 'axes': envelope.axes,
            'points': [list(p) for p in envelope.points], 'method': method,
            'digest': envelope.spec.digest(), 'name': envelope.spec.document.get('name', '')}
    if os.path.exists(path):
        with open(path, encoding='utf-8') as stream:
            try:
                before = json.load(stream)
            except ValueError:
                before = None
        if before != json.loads(json.dumps(held, default=repr)):
            raise SweepError(outdir, MANIFEST, 'holds another envelope (other sweep, axes, '
                             'grid or method)', 'a new -o OUTDIR, or the same command as '
                             'before to resume')
    os.makedirs(os.path.join(outdir, POINTS), exist_ok=True)
    tmp = f'{path}.tmp-{os.getpid()}'
    with open(tmp, 'w', encoding='utf-8') as stream:
        json.dump(held, stream, indent=1, default=repr)
    os.replace(tmp, path)


def run_point(envelope: Envelope, k: int, outdir: str, *, method: str = 'mc',
              client=None, progress: Optional[Callable[[int, int], None]] = None,
              log: Optional[Callable[[str], None]] = None, **options):
    """
    Run point k's sweep (or study) in its folder, resuming it.

    Return (its ``Estimate``, its table). ``options`` go to
    ``methods.run_study`` (``repeat``, ``target_cov``) for a rare-event method.
    """
    from cfem_ros.study import methods
    spec = envelope.point_spec(k)
    folder = point_folder(outdir, k)
    if method == 'mc':
        from cfem_ros.study.reliability import mc_estimate
        from cfem_ros.study.sweep import Sweep
        table = Sweep(spec).run(client, folder, progress=progress)
        estimate = mc_estimate(spec, table)
        methods.write_estimate(folder, estimate, spec.target)
        return estimate, table
    found = methods.run_study(spec, folder, method=method, client=client, log=log, **options)
    return found['estimate'], found['table']


def folder_spec(folder: str, manifest: dict) -> SweepSpec:
    """
    Return the spec a sweep folder was run with: its sweep file's, or its envelope point's.

    A folder ``OUTDIR/points/point_<k>`` beside an ``OUTDIR/envelope.json``
    is point k of that envelope (``cfem-sim rerun`` of one of its runs).
    """
    runs = manifest['resolved']['runs']
    here = os.path.abspath(folder)
    match = re.fullmatch(r'point_(\d+)', os.path.basename(here))
    points = os.path.dirname(here)
    held_path = os.path.join(os.path.dirname(points), MANIFEST)
    if match and os.path.basename(points) == POINTS and os.path.exists(held_path):
        with open(held_path, encoding='utf-8') as stream:
            held = json.load(stream)
        found = load_envelope(held['sweep'], held['axes'], runs=runs)
        k = int(match.group(1))
        if k >= len(found.points):
            raise SweepError(folder, '', f'is point {k} of an envelope of '
                             f'{len(found.points)} points', 'a point folder of the envelope')
        return found.point_spec(k)
    return load_sweep(manifest['sweep'], runs=runs)


def point_done(outdir: str, k: int) -> bool:
    """Return whether point k's folder holds its finished estimate."""
    return os.path.exists(os.path.join(point_folder(outdir, k), 'estimate.json'))


def row(envelope: Envelope, k: int, estimate, outdir: str, unfinished: int = 0) -> dict:
    """Return point k's row of ``envelope.parquet`` (unfinished: its runs that failed)."""
    spec = envelope.spec
    out = dict(envelope.point_values(k))
    decision = getattr(estimate, 'decision', None)
    p_upper = estimate.p_upper
    out.update(point=k, method=estimate.method, runs=int(estimate.runs),
               failed_runs=(-1 if estimate.failed_runs is None else int(estimate.failed_runs)),
               unfinished_runs=int(unfinished),
               pass_fraction=1.0 - float(estimate.probability),
               probability=float(estimate.probability),
               p_upper=math.nan if p_upper is None else float(p_upper),
               confidence=float(spec.confidence),
               target=math.nan if spec.target is None else float(spec.target),
               decision=decision if decision else 'no_target',
               folder=os.path.relpath(point_folder(outdir, k), outdir), note='')
    return out


def unanswered(envelope: Envelope, k: int, method: str, why: str, outdir: str) -> dict:
    """
    Return the row of point k, whose rare-event method gave no estimate (why: its message).

    No number stands for the missing estimate (NaN); the decision is
    ``undecided`` (``no_target`` without a target), the note says why.
    """
    from cfem_ros.study.sweep import saved_runs
    spec = envelope.spec
    out = dict(envelope.point_values(k))
    out.update(point=k, method=method, runs=saved_runs(point_folder(outdir, k)),
               failed_runs=-1, unfinished_runs=0, pass_fraction=math.nan,
               probability=math.nan, p_upper=math.nan, confidence=float(spec.confidence),
               target=math.nan if spec.target is None else float(spec.target),
               decision='no_target' if spec.target is None else 'undecided',
               folder=os.path.relpath(point_folder(outdir, k), outdir),
               note=f'no estimate: {why}')
    return out


def run_envelope(envelope: Envelope, outdir: str, *, method: str = 'mc', client=None,
                 log: Optional[Callable[[str], None]] = None,
                 progress: Optional[Callable[[int], Callable[[int, int], None]]] = None,
                 **options):
    """
    Run every point (resuming each) and write ``envelope.parquet``; return its table.

    The table: one row per point, the axes' columns (named by their key
    paths) then ``COLUMNS``; ``decision`` is meets, does_not_meet or
    undecided with a target, ``no_target`` without. A point whose
    rare-event method fails (``MethodFailed``: no design point where every
    run fails, say) gets no estimate (NaN), ``undecided`` and a ``note``
    saying why; the others go on. Monte Carlo on a Dask client submits
    every point's runs at once (``_run_together``); otherwise the points run
    one after the other. ``log`` gets a line per point done, in the order
    they finish (and a rare-event method's lines); ``progress(k)``, if
    given, returns the callable that point k's Monte Carlo runs report to.
    ``options`` go to ``run_point``.
    """
    import pandas as pd
    from cfem_ros.study.sweep import write_atomic
    write_manifest(envelope, outdir, method)
    rows = {}
    count = len(envelope.points)

    def done(k, estimate, table):
        # a run that failed (singular or diverging) fails every criterion; said apart
        unfinished = int((table['status'] == Status.FAILED).sum())
        rows[k] = row(envelope, k, estimate, outdir, unfinished)
        if log is not None:
            log(f'point {k + 1}/{count} ({describe_point(envelope, k)}): P(fail) '
                f'{rows[k]["probability"]:.3g} over {rows[k]["runs"]} runs, '
                f'{rows[k]["decision"].replace("_", " ")}')
    if method == 'mc' and client is not None:   # every condition's runs on the cluster at once
        _run_together(envelope, outdir, client, progress, done)
    for k in range(count):
        if k in rows:
            continue
        where = describe_point(envelope, k)
        try:
            estimate, table = run_point(
                envelope, k, outdir, method=method, client=client,
                progress=None if progress is None else progress(k),
                log=None if log is None else (lambda line, w=where: log(f'{w}: {line}')),
                **options)
        except MethodFailed as err:   # a condition the method cannot answer: said, not guessed
            rows[k] = unanswered(envelope, k, method, str(err), outdir)
            if log is not None:
                log(f'point {k + 1}/{count} ({where}): no estimate ({err})')
            continue
        done(k, estimate, table)
    table = pd.DataFrame([rows[k] for k in range(count)],
                         columns=list(envelope.axes) + list(COLUMNS))
    write_atomic(table, os.path.join(outdir, ENVELOPE), envelope.spec.document, UNITS)
    return table


def _run_together(envelope: Envelope, outdir: str, client, progress, done):
    """
    Run the Monte Carlo runs of every point on Dask at once; done(k, estimate, table) each.

    The points' tasks are submitted together, so that a cluster larger than
    a point's runs is kept busy; each point's folder is gathered (as
    ``Sweep.run`` gathers it) once its own tasks are done, in the order
    they finish. A point whose runs could not be written (a full disk) is
    left to resume, and the first such failure raised once all are done.
    """
    from dask.distributed import as_completed
    from cfem_ros.study import methods
    from cfem_ros.study.reliability import mc_estimate
    from cfem_ros.study.resources import ResourceFailure
    from cfem_ros.study.sweep import assemble, Sweep, task_done
    sweeps = [Sweep(envelope.point_spec(k)) for k in range(len(envelope.points))]
    owner = {}
    for k, sweep in enumerate(sweeps):
        owner.update({f: k for f in sweep.submit(client, point_folder(outdir, k))})
    left = collections.Counter(owner.values())
    failures, failed = [], set()

    def finish(k):
        folder = point_folder(outdir, k)
        table = assemble(sweeps[k].spec, folder)
        estimate = mc_estimate(sweeps[k].spec, table)
        methods.write_estimate(folder, estimate, sweeps[k].spec.target)
        done(k, estimate, table)
    for k in range(len(sweeps)):
        if not left[k]:   # every run saved before: read back
            finish(k)
    try:
        for future in as_completed(list(owner)):
            k = owner[future]
            before = len(failures)
            task_done(future.result(), None if progress is None else progress(k), failures)
            if len(failures) > before:
                failed.add(k)
            left[k] -= 1
            if not left[k] and k not in failed:
                finish(k)
    finally:
        for future in owner:
            future.cancel()
    if failures:   # the runs written are saved; those not are done again on resume
        raise ResourceFailure(failures[0])


def describe_point(envelope: Envelope, k: int) -> str:
    """Return point k's values on one line (``flight.mach = 0.95, flight.altitude = 1500``)."""
    return ', '.join(f'{a} = {v:g}' if isinstance(v, (int, float)) else f'{a} = {v}'
                     for a, v in envelope.point_values(k).items())


def read_envelope(outdir: str) -> tuple:
    """
    Return (table, manifest) of a finished envelope folder.

    Raises
    ------
    SweepError
        If the folder has no ``envelope.json`` or ``envelope.parquet``, or
        they are not what ``run_envelope`` writes.

    """
    import pandas as pd
    manifest_path, table_path = (os.path.join(outdir, MANIFEST), os.path.join(outdir, ENVELOPE))
    if not os.path.exists(table_path):
        raise SweepError(outdir, ENVELOPE, 'missing', 'a finished envelope folder '
                         '(cfem-sim envelope SWEEP.yaml -o OUTDIR ...; run it again to finish)')
    try:
        with open(manifest_path, encoding='utf-8') as stream:
            manifest = json.load(stream)
        table = pd.read_parquet(table_path)
    except (OSError, ValueError) as err:
        raise SweepError(outdir, MANIFEST, f'cannot be read ({err})',
                         'the envelope.json and envelope.parquet cfem-sim envelope wrote') from err
    axes = manifest.get('axes') if isinstance(manifest, dict) else None
    if not isinstance(axes, list) or not set(axes + list(COLUMNS)) <= set(table.columns):
        raise SweepError(outdir, ENVELOPE, 'is not the table of an envelope (its axes or '
                         'columns are missing)', 'the envelope.parquet cfem-sim envelope wrote')
    return table, manifest
