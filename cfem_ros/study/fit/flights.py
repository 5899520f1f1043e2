# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The measured flights of a fit file (SPEC section 13): one ``measured:`` mapping or a list.

Each flight names its measured file (and topic), the measured body and the
body it is measured against, the inputs to replay, the window, the noise
(sigma) and, optionally, its own ``scenario`` and ``set:`` (key-path
values for that flight's conditions: a Mach number, a release time).
Everything is checked before any run; a ``FitError`` names the fit file,
the key path (``measured[1].window.to``), the value and what would be
right.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
import math
import os
from typing import Optional

from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio.messages import show
from cfem_ros.core.fileio.textfile import read_text
from cfem_ros.core.fileio.yamlfile import load_yaml
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.study.keypaths import format_key_path, parse_key_path, resolve

MEASURED_KEYS = ('file', 'topic', 'body', 'relative_to', 'inputs', 'window', 'sigma',
                 'odometry', 'scenario', 'set')
SIGMA_KEYS = ('position', 'attitude_deg')
#: The measurement noise a fit takes, (least, largest) per key (m; deg): below the least
#: the weighted residuals overflow (1e-300 made them infinite: a traceback); above the
#: largest the poses of a store leaving its carrier (a few metres and tens of degrees in
#: the window) weigh nothing, and a parameter would be "not determined" for a wrong reason.
SIGMA_RANGE = {'position': (1e-9, 10.0), 'attitude_deg': (1e-9, 90.0)}
WINDOW_END = 'a time (s), or {release: JOINT or RELEASE_GROUP, delay: s}'


class FitError(ScenarioError):
    """A fit file that cannot be fitted (file, key path, problem, expected)."""


@dataclass(frozen=True)
class WindowEnd:
    """One end of a window: a time, or a delay after a joint's or release group's release."""

    time: float = 0.0
    release: Optional[str] = None

    def describe(self) -> str:
        """Return the end as the file gives it."""
        if self.release is None:
            return f'{self.time:g} s'
        return f'{self.time:g} s after the release of {self.release}'


@dataclass
class Flight:
    """One measured flight: its scenario (with its ``set:`` applied) and what was measured."""

    key: str                     # 'measured' or 'measured[k]', for messages
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
    groups: dict = field(default_factory=dict)   # release group -> its joints
    settings: dict = field(default_factory=dict)  # the flight's set: (key path -> value)

    def document_with(self, parameters, values) -> dict:
        """Return a copy of the flight's scenario with each parameter set to its value."""
        out = copy.deepcopy(self.document)
        for parameter, value in zip(parameters, values):
            container, last, _, _ = resolve(out, parameter.tokens)
            container[last] = float(value)
        return out


def finite_number(value) -> bool:
    """Return whether value is a finite int or float (not a bool)."""
    return (not isinstance(value, bool) and isinstance(value, (int, float))
            and math.isfinite(value))


def relative(base: str, name: str) -> str:
    """Return a file named in the fit file base, relative to its folder."""
    return name if os.path.isabs(name) else os.path.normpath(
        os.path.join(os.path.dirname(base), name))


def read_scenario(fail, path: str, key: str, name) -> tuple:
    """Return (file, document, model) of a scenario named in the fit file at key."""
    if not isinstance(name, str) or not name:
        fail(key, f'is {show(name)}', 'a scenario file name')
    scenario = relative(path, name)
    if not os.path.isfile(scenario):
        fail(key, f'{show(scenario)} is not a file', 'an existing scenario file')
    document = load_yaml(read_text(scenario), source=scenario)
    return scenario, document, parse_scenario(document, source=scenario)


def read_flights(fail, path: str, measured, scenario: tuple) -> list:
    """Return the fit file's flights (``measured:`` a mapping, or a list of them)."""
    if isinstance(measured, list):
        if not measured:
            fail('measured', 'is an empty list', 'one flight or more')
        return [_flight(fail, path, f'measured[{k}]', item, scenario)
                for k, item in enumerate(measured)]
    return [_flight(fail, path, 'measured', measured, scenario)]


def _flight(fail, path: str, key: str, measured, scenario: tuple) -> Flight:
    if not isinstance(measured, dict):
        fail(key, f'is {show(measured)}', 'a mapping with file, body, relative_to, sigma')
    for name in measured:
        if name not in MEASURED_KEYS:
            fail(f'{key}.{name}', 'unknown key', 'one of ' + ', '.join(MEASURED_KEYS))
    file, document, model = scenario
    if 'scenario' in measured:
        file, document, model = read_scenario(fail, path, f'{key}.scenario',
                                              measured['scenario'])
    settings = measured.get('set') or {}
    if settings:
        document, model = _with_settings(fail, key, file, document, settings)
    names = [b.name for b in model.bodies]
    measured_file, topic = _measured_file(fail, path, key, measured)
    body = measured.get('body')
    if body not in names:
        fail(f'{key}.body', f'is {show(body)}, not a body of {file}',
             'one of ' + ', '.join(names))
    relative_to = measured.get('relative_to')
    frames = [n for n in names if n != body] + [model.frame_id]
    if relative_to not in frames:
        fail(f'{key}.relative_to', f'is {show(relative_to)}',
             'the body the measured pose is relative to, one of ' + ', '.join(frames))
    inputs = measured.get('inputs')
    if inputs is not None:
        if not isinstance(inputs, str):
            fail(f'{key}.inputs', f'is {show(inputs)}', 'an MCAP log to replay')
        inputs = relative(path, inputs)
    odometry = measured.get('odometry')
    if odometry not in (None, 'interpolate', 'extrapolate'):
        fail(f'{key}.odometry', f'is {show(odometry)}', 'interpolate or extrapolate')
    groups = {g.name: tuple(model.joints[j].name for j in g.joints)
              for g in model.release_groups}
    releases = [j.name for j in model.joints] + list(groups)
    window = measured.get('window') or {}
    if not isinstance(window, dict) or set(window) - {'from', 'to'}:
        fail(f'{key}.window', f'is {show(window)}', 'a mapping with from and to')
    start = _window_end(fail, f'{key}.window.from', window.get('from', 0.0), releases)
    end = (None if window.get('to') is None
           else _window_end(fail, f'{key}.window.to', window['to'], releases))
    sigma = measured.get('sigma')
    if not isinstance(sigma, dict) or set(sigma) != set(SIGMA_KEYS):
        fail(f'{key}.sigma', f'is {show(sigma)}', '{position: m, attitude_deg: deg}, '
             'the measurement noise (1 sigma) that weighs the residuals')
    for name in SIGMA_KEYS:
        if not finite_number(sigma[name]) or sigma[name] <= 0:
            fail(f'{key}.sigma.{name}', f'is {show(sigma[name])}', 'a number > 0')
        least, largest = SIGMA_RANGE[name]
        if not least <= sigma[name] <= largest:
            unit = 'm' if name == 'position' else 'deg'
            fail(f'{key}.sigma.{name}', f'is {show(sigma[name])}', f'the measurement noise '
                 f'(1 sigma), from {least:g} to {largest:g} {unit}')
    return Flight(key=key, scenario=file, document=document, measured_file=measured_file,
                  topic=topic, body=body, relative_to=relative_to, inputs=inputs,
                  odometry=odometry, start=start, end=end,
                  sigma_position=float(sigma['position']),
                  sigma_attitude_deg=float(sigma['attitude_deg']), groups=groups,
                  settings=dict(settings))


def _with_settings(fail, key: str, file: str, document: dict, settings) -> tuple:
    """Return the scenario with a flight's ``set:`` values, and its model."""
    if not isinstance(settings, dict):
        fail(f'{key}.set', f'is {show(settings)}', "key paths with values ('aero.mach': 0.9)")
    out = copy.deepcopy(document)
    for name, value in settings.items():
        where = f'{key}.set.{name}'
        try:
            container, last, _, _ = resolve(out, parse_key_path(name))
        except ValueError:
            fail(where, 'is not a key path', "names and [index]es, as 'aero.mach'")
        except KeyError as err:
            fail(where, str(err.args[0]), f'a key path of {file}')
        container[last] = copy.deepcopy(value)
    try:
        model = parse_scenario(out, source=file)
    except ScenarioError as err:
        fail(f'{key}.set', f'makes {file} invalid: {err}', 'values the scenario takes')
    return out, model


def _measured_file(fail, path: str, key: str, measured: dict) -> tuple:
    file = measured.get('file')
    if not isinstance(file, str) or not file:
        fail(f'{key}.file', f'is {show(file)}', 'an MCAP recording or a CSV file')
    file = relative(path, file)
    if not os.path.isfile(file):
        fail(f'{key}.file', f'{show(file)} is not a file', 'an existing MCAP or CSV file')
    topic = measured.get('topic')
    if file.lower().endswith('.mcap'):
        if not isinstance(topic, str) or not topic:
            fail(f'{key}.topic', f'is {show(topic)}', 'the PoseStamped topic of the '
                 'measured body in the MCAP file')
    elif file.lower().endswith('.csv'):
        if topic is not None:
            fail(f'{key}.topic', 'given for a CSV file', "no topic: the CSV's columns are "
                 'those of cfem-sim export')
    else:
        fail(f'{key}.file', f'{show(file)} is neither .mcap nor .csv',
             'an MCAP recording or a CSV file in the columns of cfem-sim export')
    return file, topic


def _window_end(fail, key: str, value, releases) -> WindowEnd:
    if finite_number(value):
        if value < 0:
            fail(key, f'is {show(value)}', 'a time >= 0 s')
        return WindowEnd(time=float(value))
    if not isinstance(value, dict) or set(value) - {'release', 'delay'} \
            or 'release' not in value:
        fail(key, f'is {show(value)}', WINDOW_END)
    if value['release'] not in releases:
        fail(f'{key}.release', f'is {show(value["release"])}, not a joint nor a release '
             'group', 'one of ' + ', '.join(releases))
    delay = value.get('delay', 0.0)
    if not finite_number(delay) or delay < 0:
        fail(f'{key}.delay', f'is {show(delay)}', 'a delay >= 0 s')
    return WindowEnd(time=float(delay), release=value['release'])


__all__ = ['FitError', 'Flight', 'WindowEnd', 'format_key_path', 'read_flights',
           'read_scenario']
