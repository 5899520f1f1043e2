# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Fit files (SPEC section 13): YAML in, a checked ``FitSpec`` out.

Everything is checked before any run: the scenario parses, every parameter
is a number in the scenario at its key path, starts within its bounds, and
the measured file exists. A ``FitError`` names the file, the key path, the
value and what would be right.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
import math
import os
from typing import Optional

from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio.textfile import read_text
from cfem_ros.core.fileio.yamlfile import load_yaml
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.study.keypaths import format_key_path, parse_key_path, resolve
import numpy as np

TOP_KEYS = ('scenario', 'measured', 'parameters', 'max_evaluations')
MEASURED_KEYS = ('file', 'topic', 'body', 'relative_to', 'inputs', 'window', 'sigma',
                 'odometry')
PARAMETER_KEYS = ('start', 'bounds', 'step', 'name', 'unit')
SIGMA_KEYS = ('position', 'attitude_deg')
WINDOW_END = ('a time (s), or {release: JOINT, delay: s}')
#: Relative step of the central differences of the Jacobian, times a parameter's scale:
#: about the cube root of the double precision (the truncation and rounding errors of a
#: central difference balance there).
RELATIVE_STEP = 6e-6
#: Most least-squares evaluations (runs of the residual) by default.
MAX_EVALUATIONS = 100


class FitError(ScenarioError):
    """A fit file that cannot be fitted (file, key path, problem, expected)."""


@dataclass(frozen=True)
class WindowEnd:
    """One end of the fit's window: a time, or a delay after a joint's release."""

    time: float = 0.0
    release: Optional[str] = None

    def describe(self) -> str:
        """Return the end as the file gives it."""
        if self.release is None:
            return f'{self.time:g} s'
        return f'{self.time:g} s after the release of {self.release}'


@dataclass(frozen=True)
class Parameter:
    """A fitted key path: its start value, bounds and finite-difference step."""

    path: str
    tokens: tuple
    start: float
    low: float
    high: float
    step: float
    name: str
    unit: str = ''


@dataclass
class FitSpec:
    """A checked fit file (SPEC section 13)."""

    path: str
    scenario: str
    document: dict
    measured_file: str
    topic: Optional[str]
    body: str
    relative_to: str
    inputs: Optional[str]
    odometry: Optional[str]
    start: WindowEnd
    end: Optional[WindowEnd]
    sigma_position: float
    sigma_attitude_deg: float
    parameters: list = field(default_factory=list)
    max_evaluations: int = MAX_EVALUATIONS

    @property
    def x0(self) -> np.ndarray:
        """Return the start values, in the parameters' order."""
        return np.array([p.start for p in self.parameters])

    @property
    def bounds(self) -> tuple:
        """Return (lower, upper) arrays, as ``scipy.optimize.least_squares`` takes them."""
        return (np.array([p.low for p in self.parameters]),
                np.array([p.high for p in self.parameters]))

    def document_with(self, values) -> dict:
        """Return a copy of the scenario with each parameter set to its value."""
        out = copy.deepcopy(self.document)
        for parameter, value in zip(self.parameters, values):
            container, last, _, _ = resolve(out, parameter.tokens)
            container[last] = float(value)
        return out


def _show(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + '...'


def _number(value) -> bool:
    return (not isinstance(value, bool) and isinstance(value, (int, float))
            and math.isfinite(value))


def _relative(base: str, name: str) -> str:
    """Return a file named in the fit file base, relative to its folder (``..`` as written)."""
    return name if os.path.isabs(name) else os.path.normpath(
        os.path.join(os.path.dirname(base), name))


def load_fit(path: str) -> FitSpec:
    """
    Read and check a fit file and its scenario.

    Raises
    ------
    FitError
        For anything wrong in the fit file; a ``ScenarioError`` (its parent)
        if the scenario itself is not valid.

    """
    try:
        document = load_yaml(read_text(path), source=path)
    except ScenarioError as err:
        raise FitError(path, err.key, err.problem,
                       err.expected or 'a fit file as in SPEC section 13') from err

    def fail(key, problem, expected=''):
        raise FitError(path, key, problem, expected)

    if not isinstance(document, dict):
        fail('', f'is {_show(document)}', 'a mapping with scenario, measured, parameters')
    for key in document:
        if key not in TOP_KEYS:
            fail(str(key), 'unknown key', 'one of ' + ', '.join(TOP_KEYS))
    for key in ('scenario', 'measured', 'parameters'):
        if key not in document:
            fail(key, 'missing', 'see SPEC section 13')
    if not isinstance(document['scenario'], str):
        fail('scenario', f'is {_show(document["scenario"])}', 'a scenario file name')
    scenario = _relative(path, document['scenario'])
    base = load_yaml(read_text(scenario), source=scenario)
    model = parse_scenario(base, source=scenario)
    measured = document['measured']
    if not isinstance(measured, dict):
        fail('measured', f'is {_show(measured)}', 'a mapping with file, body, relative_to, '
             'sigma')
    for key in measured:
        if key not in MEASURED_KEYS:
            fail(f'measured.{key}', 'unknown key', 'one of ' + ', '.join(MEASURED_KEYS))
    names = [b.name for b in model.bodies]
    file, topic = _measured_file(fail, path, measured)
    body = measured.get('body')
    if body not in names:
        fail('measured.body', f'is {_show(body)}, not a body of {scenario}',
             'one of ' + ', '.join(names))
    relative_to = measured.get('relative_to')
    frames = [n for n in names if n != body] + [model.frame_id]
    if relative_to not in frames:
        fail('measured.relative_to', f'is {_show(relative_to)}',
             'the body the measured pose is relative to, one of ' + ', '.join(frames))
    inputs = measured.get('inputs')
    if inputs is not None:
        if not isinstance(inputs, str):
            fail('measured.inputs', f'is {_show(inputs)}', 'an MCAP log to replay')
        inputs = _relative(path, inputs)
    odometry = measured.get('odometry')
    if odometry not in (None, 'interpolate', 'extrapolate'):
        fail('measured.odometry', f'is {_show(odometry)}', 'interpolate or extrapolate')
    joints = [j.name for j in model.joints]
    window = measured.get('window') or {}
    if not isinstance(window, dict) or set(window) - {'from', 'to'}:
        fail('measured.window', f'is {_show(window)}', 'a mapping with from and to')
    start = _window_end(fail, 'measured.window.from', window.get('from', 0.0), joints)
    end = (None if window.get('to') is None
           else _window_end(fail, 'measured.window.to', window['to'], joints))
    sigma = measured.get('sigma')
    if not isinstance(sigma, dict) or set(sigma) != set(SIGMA_KEYS):
        fail('measured.sigma', f'is {_show(sigma)}', '{position: m, attitude_deg: deg}, '
             'the measurement noise (1 sigma) that weighs the residuals')
    for key in SIGMA_KEYS:
        if not _number(sigma[key]) or sigma[key] <= 0:
            fail(f'measured.sigma.{key}', f'is {_show(sigma[key])}', 'a number > 0')
    parameters = _parameters(fail, document['parameters'], base)
    evaluations = document.get('max_evaluations', MAX_EVALUATIONS)
    if isinstance(evaluations, bool) or not isinstance(evaluations, int) or evaluations < 1:
        fail('max_evaluations', f'is {_show(evaluations)}', 'a whole number >= 1')
    spec = FitSpec(path=path, scenario=scenario, document=base, measured_file=file,
                   topic=topic, body=body, relative_to=relative_to, inputs=inputs,
                   odometry=odometry, start=start, end=end,
                   sigma_position=float(sigma['position']),
                   sigma_attitude_deg=float(sigma['attitude_deg']),
                   parameters=parameters, max_evaluations=evaluations)
    parse_scenario(spec.document_with(spec.x0), source=scenario)   # the start values run
    return spec


def _measured_file(fail, path: str, measured: dict) -> tuple:
    file = measured.get('file')
    if not isinstance(file, str) or not file:
        fail('measured.file', f'is {_show(file)}', 'an MCAP recording or a CSV file')
    file = _relative(path, file)
    if not os.path.isfile(file):
        fail('measured.file', f'{_show(file)} is not a file', 'an existing MCAP or CSV file')
    topic = measured.get('topic')
    if file.lower().endswith('.mcap'):
        if not isinstance(topic, str) or not topic:
            fail('measured.topic', f'is {_show(topic)}', 'the PoseStamped topic of the '
                 'measured body in the MCAP file')
    elif file.lower().endswith('.csv'):
        if topic is not None:
            fail('measured.topic', 'given for a CSV file', "no topic: the CSV's columns are "
                 'those of cfem-sim export')
    else:
        fail('measured.file', f'{_show(file)} is neither .mcap nor .csv',
             'an MCAP recording or a CSV file in the columns of cfem-sim export')
    return file, topic


def _window_end(fail, key: str, value, joints) -> WindowEnd:
    if _number(value):
        if value < 0:
            fail(key, f'is {_show(value)}', 'a time >= 0 s')
        return WindowEnd(time=float(value))
    if not isinstance(value, dict) or set(value) - {'release', 'delay'} \
            or 'release' not in value:
        fail(key, f'is {_show(value)}', WINDOW_END)
    if value['release'] not in joints:
        fail(f'{key}.release', f'is {_show(value["release"])}, not a joint',
             'one of ' + ', '.join(joints))
    delay = value.get('delay', 0.0)
    if not _number(delay) or delay < 0:
        fail(f'{key}.delay', f'is {_show(delay)}', 'a delay >= 0 s')
    return WindowEnd(time=float(delay), release=value['release'])


def _parameters(fail, parameters, base) -> list:
    if not isinstance(parameters, dict) or not parameters:
        fail('parameters', f'is {_show(parameters)}',
             "key paths with their start and bounds ('wrenches[1].force[2]': "
             '{start: 42703, bounds: [30000, 50000]})')
    out = []
    for path, entry in parameters.items():
        key = f'parameters.{path}'
        try:
            tokens = parse_key_path(path)
        except ValueError:
            fail(key, 'is not a key path', "names and [index]es, as 'wrenches[1].force[2]'")
        try:
            _, _, value, exists = resolve(base, tokens)
        except KeyError as err:
            fail(key, str(err.args[0]), 'a key path of the scenario')
        if not exists or not _number(value):
            fail(key, f'is {_show(value)} in the scenario', 'a number there to fit')
        if not isinstance(entry, dict) or set(entry) - set(PARAMETER_KEYS):
            fail(key, f'is {_show(entry)}', '{start: x, bounds: [low, high]} (step, name, '
                 'unit optional)')
        start = entry.get('start', value)
        bounds = entry.get('bounds', [-math.inf, math.inf])
        if not (isinstance(bounds, list) and len(bounds) == 2
                and all(isinstance(b, (int, float)) and not isinstance(b, bool)
                        for b in bounds) and bounds[0] < bounds[1]):
            fail(f'{key}.bounds', f'is {_show(bounds)}', '[low, high] with low < high')
        if not _number(start) or not bounds[0] <= start <= bounds[1]:
            fail(f'{key}.start', f'is {_show(start)}', f'a number within {bounds}')
        step = entry.get('step', _default_step(start, bounds))
        if not _number(step) or step <= 0:
            fail(f'{key}.step', f'is {_show(step)}', 'a step > 0 (of the parameter)')
        name, unit = entry.get('name', path), entry.get('unit', '')
        if not isinstance(name, str) or not isinstance(unit, str):
            fail(key, 'has a name or unit that is not text', 'text')
        out.append(Parameter(path=format_key_path(tokens), tokens=tokens, start=float(start),
                             low=float(bounds[0]), high=float(bounds[1]), step=float(step),
                             name=name, unit=unit))
    return out


def _default_step(start: float, bounds) -> float:
    """
    Return the central difference's step of a parameter.

    ``RELATIVE_STEP`` times its scale: the larger of its start value and a
    tenth of its bounds' width (a start of 0 still has a scale), or 1 for
    a parameter with neither.
    """
    width = bounds[1] - bounds[0]
    scale = max(abs(float(start)), width / 10 if math.isfinite(width) else 0.0)
    return RELATIVE_STEP * (scale if scale > 0 else 1.0)
