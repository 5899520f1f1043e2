# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The next test point predicted from a fit (``cfem-sim predict``, SPEC section 13).

The fitted parameters are drawn from their fitted covariance (``fit.json``'s
``covariance_scaled``: the standard errors scaled by the reduced
chi-square, so the draws carry the uncertainty the fit reports, never
less); each draw runs in the next point's scenario. A parameter the
flights did not determine has no covariance: it is held at its value (its
start) and the prediction says so, since its uncertainty is not in the band.

From the runs: the fit's body's pose relative to the fit's ``relative_to``
(the carrier), in its axes, at every sample; at each sample time the
median and the 5 % and 95 % quantiles over the draws (pointwise: the band
holds 90 % of the draws at each time, not 90 % of whole trajectories); and
when the next point is given as a sweep file (SPEC sections 6 and 9), its
metrics per draw and the fraction of draws that pass its criteria, with
the exact (Clopper-Pearson) interval of that fraction over the draws.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
import json
import logging
import math
import os
from typing import Optional

from cfem_ros.core.engine.events import Status, STOPS
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio.textfile import read_text
from cfem_ros.core.fileio.yamlfile import load_yaml
from cfem_ros.core.run.session import Session
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.study.criteria import INVALID, judge
from cfem_ros.study.fit import DRAWS, MOST_DRAWS
from cfem_ros.study.fit.flights import FitError, show
from cfem_ros.study.fit.measured import relative_poses
from cfem_ros.study.keypaths import parse_key_path, resolve
from cfem_ros.study.metrics import Collector, compute, empty
from cfem_ros.study.metricspec import Metrics
import numpy as np

#: The runs of a prediction log here (a replayed input refused is said once per run otherwise).
LOG = logging.getLogger('cfem_ros.predict.runs')
#: The band's quantiles (%).
QUANTILES = (5.0, 50.0, 95.0)
#: The runs the band is made of: those that ran (to the end, or stopped by a contact or an
#: aero table's edge as the scenario asks); a failed or invalid draw is counted and said.
BANDED = frozenset({Status.OK}) | STOPS
#: The six quantities of the pose relative to the carrier: (column suffix, unit).
QUANTITIES = (('x', 'm'), ('y', 'm'), ('z', 'm'), ('roll_deg', 'deg'), ('pitch_deg', 'deg'),
              ('yaw_deg', 'deg'))


@dataclass
class Fitted:
    """What a fit folder's ``fit.json`` says of its parameters (scaled covariance)."""

    path: str                  # fit.json
    paths: list                # key paths, in the fit's order
    names: list
    units: list
    values: np.ndarray
    determined: np.ndarray     # bool
    covariance: np.ndarray     # scaled; NaN where a parameter is not determined
    bounds: np.ndarray         # (n, 2)
    body: str
    relative_to: str
    status: str

    def draws(self, count: int, seed: int) -> np.ndarray:
        """Return count sets of the parameters (count x n), jointly normal about their values."""
        out = np.tile(self.values, (count, 1))
        index = np.flatnonzero(self.determined)
        if index.size:
            inner = self.covariance[np.ix_(index, index)]
            w, v = np.linalg.eigh(0.5 * (inner + inner.T))   # a square root, PSD or not
            root = v * np.sqrt(np.clip(w, 0.0, None))
            z = np.random.default_rng(seed).standard_normal((count, index.size))
            out[:, index] += z @ root.T
        return out


def read_fitted(folder: str) -> Fitted:
    """
    Read a fit folder's ``fit.json``.

    Raises
    ------
    FitError
        If the folder holds no fit.json, or one without the parameters'
        values and scaled covariance (a fit of an older version).

    """
    path = os.path.join(folder, 'fit.json')
    if not os.path.isfile(path):
        raise FitError(folder, 'fit.json', 'is not in the folder',
                       'the folder cfem-sim fit -o wrote')
    try:
        with open(path, encoding='utf-8') as stream:
            found = json.load(stream)
        parameters = found['parameters']
        paths = list(parameters)
        covariance = np.array([[math.nan if c is None else float(c) for c in row]
                               for row in found['covariance_scaled']], dtype=float)
        entries = [parameters[p] for p in paths]
        values = np.array([float(e['value']) for e in entries])
        determined = np.array([bool(e['determined']) for e in entries])
        bounds = np.array([[-math.inf if e['bounds'][0] is None else e['bounds'][0],
                            math.inf if e['bounds'][1] is None else e['bounds'][1]]
                           for e in entries], dtype=float)   # null: no bound
        measured = found['measured']
        names = [e.get('name', p) for p, e in zip(paths, entries)]
        fitted = Fitted(path=path, paths=paths, names=names,
                        units=[e.get('unit', '') for e in entries], values=values,
                        determined=determined, covariance=covariance, bounds=bounds,
                        body=measured['body'], relative_to=measured['relative_to'],
                        status=str(found.get('status', '')))
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise FitError(path, '', f'cannot be read as a fit ({type(err).__name__}: {err})',
                       'the fit.json cfem-sim fit wrote') from err
    if covariance.shape != (len(paths),) * 2 or not np.all(
            np.isfinite(covariance[np.ix_(determined, determined)])):
        raise FitError(path, 'covariance_scaled', f'is {covariance.shape} with values that '
                       'are not finite', 'a covariance of the determined parameters')
    return fitted


@dataclass
class NextPoint:
    """The next test point: its scenario and, from a sweep file, metrics and criteria."""

    path: str
    scenario: str
    document: dict
    metrics: Metrics = field(default_factory=Metrics)
    criteria: list = field(default_factory=list)
    rate_hz: float = 100.0
    confidence: float = 0.95
    seed: int = 0


def read_next(path: str) -> NextPoint:
    """
    Read the next point: a scenario, or a sweep file naming one (metrics and criteria).

    Raises
    ------
    ScenarioError
        For a scenario or sweep file that is not valid; a sweep file that
        varies anything is refused (the draws are the fitted parameters').

    """
    document = load_yaml(read_text(path), source=path)
    if isinstance(document, dict) and 'scenario' in document and 'bodies' not in document:
        from cfem_ros.study.spec import load_sweep
        if document.get('vary'):
            raise FitError(path, 'vary', f'is {show(document["vary"])}', 'no vary: predict '
                           'draws the fitted parameters; study other dispersions with '
                           'cfem-sim sweep on fitted.yaml')
        spec = load_sweep(path, runs=1)
        return NextPoint(path=path, scenario=spec.scenario, document=spec.document,
                         metrics=spec.metrics, criteria=spec.criteria, rate_hz=spec.rate_hz,
                         confidence=spec.confidence, seed=spec.seed)
    parse_scenario(document, source=path)
    return NextPoint(path=path, scenario=path, document=document)


def check_parameters(fitted: Fitted, nxt: NextPoint):
    """Refuse a fitted key path that is not a number of the next point's scenario."""
    for key in fitted.paths:
        try:
            _, _, value, exists = resolve(nxt.document, parse_key_path(key))
        except (KeyError, ValueError):
            exists, value = False, None
        if not exists or isinstance(value, bool) or not isinstance(value, (int, float)):
            raise FitError(nxt.scenario, key, f'is {show(value)} (a parameter of '
                           f'{fitted.path})', 'a number at that key path, to set to the '
                           'fitted value')


@dataclass
class PredictionResult:
    """The draws' table, the band and what they say."""

    table: 'pandas.DataFrame'   # noqa: F821 (one row per draw)
    time: np.ndarray            # s, the fitted run's samples (on at the rate to the end)
    fitted: np.ndarray          # (n, 6) the run at the fitted values
    band: np.ndarray            # (3, n, 6) quantiles QUANTILES over the draws
    counted: np.ndarray         # (n,) draws with a sample at each time
    release: Optional[float]    # s, the fitted run's first release (None if none)
    passes: Optional[dict] = None   # criteria: {'passed', 'runs', 'fraction', 'interval'}

    @property
    def end(self) -> int:
        """Return the index of the last sample time that a draw reached (-1 if none did)."""
        reached = np.flatnonzero(self.counted)
        return int(reached[-1]) if reached.size else -1


class Prediction:
    """
    Run the next point at draws of the fitted parameters.

    Parameters
    ----------
    fitted : Fitted
    nxt : NextPoint
    inputs : list of Input
        Replayed in every run, as ``cfem-sim run --inputs`` does.
    interpolate_odometry : bool
    threads : int
        Runs at once (the compiled step releases the GIL).

    """

    def __init__(self, fitted: Fitted, nxt: NextPoint, inputs=(),
                 interpolate_odometry: bool = True, threads: int = 1):
        check_parameters(fitted, nxt)
        self.fitted, self.next = fitted, nxt
        self.inputs, self.interpolate = list(inputs), interpolate_odometry
        self.threads = max(1, threads)
        model = parse_scenario(nxt.document, source=nxt.scenario)
        self.duration = model.duration
        names = [b.name for b in model.bodies]
        for key, name in (('body', fitted.body), ('relative_to', fitted.relative_to)):
            if name not in names and not (key == 'relative_to' and name == nxt.document.get(
                    'frame_id', 'world')):
                raise FitError(fitted.path, f'measured.{key}', f'is {name}, not a body of '
                               f'{nxt.scenario}', 'a next point with the fitted bodies')

    def run_one(self, values) -> tuple:
        """Return (row, times, poses (n, 6) or None, releases) of a run at values."""
        row = dict(zip(self.fitted.paths, map(float, values)))
        row.update(status=Status.OK, message='')
        document = _with_values(self.next.document, self.fitted.paths, values)
        try:
            model = parse_scenario(document, source=self.next.scenario)
            sim = Simulator(model, logger=LOG)
        except ScenarioError as err:   # the scenario's checks refuse the draw: not run
            row.update(status=INVALID, message=str(err), **empty(self.next.metrics))
            return row, None, None, {}
        except Exception as err:   # noqa: B902 (any other refusal is this draw's failure)
            row.update(status=Status.FAILED, message=str(err), **empty(self.next.metrics))
            return row, None, None, {}
        collector = Collector(sim)
        session = Session(sim, rate_hz=self.next.rate_hz, duration=model.duration,
                          outputs=[collector], warn=LOG.warning,
                          interpolate_odometry=self.interpolate)
        for item in self.inputs:
            if item.time <= model.duration:
                session.submit(item, check=False)
        try:
            session.run()
            samples = collector.samples()
            row.update(compute(samples, self.next.metrics))
        except Exception as err:   # noqa: B902 (as a sweep's run: the draw failed, said)
            row.update(status=Status.FAILED, message=f'{type(err).__name__}: {err}',
                       **empty(self.next.metrics))
            if sim.refusal:   # cfem-sim check refuses the draw: invalid, in its words
                row.update(status=INVALID, message=sim.refusal)
            return row, None, None, {}
        if sim.refusal:   # cfem-sim check refuses the draw (asked as its run ended at its start)
            row.update(status=INVALID, message=sim.refusal, **empty(self.next.metrics))
            return row, None, None, {}
        if sim.status.stopped_by_scenario:   # stopped as the scenario asks
            row.update(status=sim.status, message=sim.message)
        elif session.failed:
            row.update(status=Status.FAILED, message=f'the run failed {sim.message}')
        times, poses = self._poses(samples)
        releases = {}
        for t, joint, _ in samples.releases:
            releases.setdefault(joint, float(t))
        return row, times, poses, releases

    def _poses(self, samples) -> tuple:
        """Return (times, (n, 6)): the body relative to the carrier, m and deg (Z-Y-X)."""
        times, position, quaternion = samples.bodies[self.fitted.body]
        if self.fitted.relative_to in samples.bodies:
            _, position_ref, quaternion_ref = samples.bodies[self.fitted.relative_to]
        else:   # the world frame
            position_ref = np.zeros_like(position)
            quaternion_ref = np.tile([0.0, 0.0, 0.0, 1.0], (len(times), 1))
        moved, attitude = relative_poses(position, quaternion, position_ref, quaternion_ref)
        angles = np.unwrap(attitude.as_euler('ZYX', degrees=True)[:, ::-1], period=360.0,
                           axis=0)
        keep = np.concatenate([[True], np.diff(times) > 0])   # one sample per time
        return times[keep], np.hstack([moved, angles])[keep]

    def run(self, count: int = DRAWS, seed: Optional[int] = None) -> PredictionResult:
        """Run the fitted values and count draws; return the table and the band."""
        import pandas as pd
        seed = self.next.seed if seed is None else seed
        draws = self.fitted.draws(count, seed)
        row, times, poses, releases = self.run_one(self.fitted.values)
        if poses is None or row['status'] not in BANDED:
            raise FitError(self.next.scenario, 'parameters', f'the run at the fitted values '
                           f'is {row["status"]}: {row["message"]}', 'a next point that runs '
                           'at the fitted values')
        # a contact may stop the fitted run early and a draw later: the band's times are
        # the scenario's samples to its end, each draw's past its own end left out
        time = _grid(times, self.duration, self.next.rate_hz)
        fitted = _on(time, times, poses)
        with ThreadPoolExecutor(max_workers=self.threads) as pool:
            runs = list(pool.map(self.run_one, draws))
        rows, tracks = [], np.full((count, len(time), 6), np.nan)
        for k, (row, times, poses, _) in enumerate(runs):
            rows.append({'run': k, **row})
            if poses is not None and row['status'] in BANDED:
                tracks[k] = _on(time, times, poses)
        table = pd.DataFrame(rows)
        counted = np.sum(np.isfinite(tracks[:, :, 0]), axis=0)
        with np.errstate(invalid='ignore'):
            band = (np.nanpercentile(tracks, QUANTILES, axis=0) if counted.min() > 0 else
                    _band_where_counted(tracks, counted))
        result = PredictionResult(table=table, time=time, fitted=fitted, band=band,
                                  counted=counted,
                                  release=min(releases.values()) if releases else None)
        if self.next.criteria:
            result.table = judge(table, self.next.criteria)
            result.passes = pass_fraction(result.table, self.next.criteria,
                                          self.next.confidence)
        return result


def _with_values(document: dict, paths, values) -> dict:
    import copy
    out = copy.deepcopy(document)
    for key, value in zip(paths, values):
        container, last, _, _ = resolve(out, parse_key_path(key))
        container[last] = float(value)
    return out


def _grid(times: np.ndarray, duration: float, rate: float) -> np.ndarray:
    """Return a run's sample times, continued at the rate to the duration if it ended early."""
    if times[-1] >= duration - 1e-9:
        return times
    first = int(np.floor(times[-1] * rate + 1e-9)) + 1
    last = int(np.floor(duration * rate + 1e-9))
    return np.concatenate([times, np.arange(first, last + 1) / rate])


def _on(time: np.ndarray, times: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """Return poses at time (linear between samples; NaN past the run's end)."""
    out = np.full((len(time), 6), np.nan)
    inside = time <= times[-1] + 1e-12
    for q in range(6):
        out[inside, q] = np.interp(time[inside], times, poses[:, q])
    return out


def _band_where_counted(tracks, counted) -> np.ndarray:
    band = np.full((len(QUANTILES),) + tracks.shape[1:], np.nan)
    some = counted > 0
    band[:, some] = np.nanpercentile(tracks[:, some], QUANTILES, axis=0)
    return band


def pass_fraction(table, criteria, confidence: float) -> dict:
    """Return the draws that pass every criterion, their fraction and its exact interval."""
    from cfem_ros.study.confidence import clopper_pearson
    valid = table[table['status'] != INVALID]
    runs = int(len(valid))
    passed = int(valid['pass'].fillna(False).astype(bool).sum())
    out = {'passed': passed, 'runs': runs, 'confidence': confidence,
           'fraction': passed / runs if runs else math.nan, 'interval': [math.nan, math.nan],
           'criteria': {}}
    if runs:
        low, high = clopper_pearson(runs - passed, runs, confidence)
        out['interval'] = [1.0 - high, 1.0 - low]
        for c in criteria:
            out['criteria'][c.name] = int(np.sum(c.passes_of(valid)))
    return out


__all__ = ['DRAWS', 'Fitted', 'MOST_DRAWS', 'NextPoint', 'Prediction', 'PredictionResult',
           'QUANTILES', 'QUANTITIES', 'read_fitted', 'read_next']
