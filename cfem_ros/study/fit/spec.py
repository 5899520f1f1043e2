# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Fit files (SPEC section 13): YAML in, a checked ``FitSpec`` out.

Everything is checked before any run: the scenario parses, every parameter
is a number in the scenario at its key path (named once: ``force[2]`` and
``force[02]`` are one key path), starts within its bounds with a
finite-difference step that fits inside them, and each measured file
exists (``flights``). A ``FitError`` names the file, the key path, the
value and what would be right: the scenario's ``Checker`` idiom, as the sweep
file's parser has it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math

from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio.messages import show
from cfem_ros.core.fileio.textfile import read_text
from cfem_ros.core.fileio.yamlfile import load_yaml
from cfem_ros.core.scenario.checker import Checker
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.study.fit.flights import (finite_number, FitError, read_flights, read_scenario,
                                        WindowEnd)
from cfem_ros.study.keypaths import format_key_path, parse_key_path, resolve
import numpy as np

TOP_KEYS = ('scenario', 'measured', 'parameters', 'max_evaluations', 'confidence')
PARAMETER_KEYS = ('start', 'bounds', 'step', 'name', 'unit')
#: Relative step of the central differences of the Jacobian, times a parameter's scale:
#: about the cube root of the double precision (the truncation and rounding errors of a
#: central difference balance there).
RELATIVE_STEP = 6e-6
#: Most least-squares evaluations (runs of the residual) by default.
MAX_EVALUATIONS = 100
#: The profile intervals' confidence by default.
CONFIDENCE = 0.95

__all__ = ['FitError', 'FitSpec', 'Parameter', 'WindowEnd', 'load_fit']


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
    """A checked fit file (SPEC section 13): its flights and the parameters they share."""

    path: str
    scenario: str
    document: dict
    flights: list
    parameters: list = field(default_factory=list)
    max_evaluations: int = MAX_EVALUATIONS
    confidence: float = CONFIDENCE

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
        """Return a copy of the fit's scenario with each parameter set to its value."""
        import copy
        out = copy.deepcopy(self.document)
        for parameter, value in zip(self.parameters, values):
            container, last, _, _ = resolve(out, parameter.tokens)
            container[last] = float(value)
        return out


def load_fit(path: str) -> FitSpec:
    """
    Read and check a fit file, its scenario(s) and its flights.

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

    fail = Checker(path, FitError).fail   # the scenario's idiom: file, key path, value

    if not isinstance(document, dict):
        fail('', f'is {show(document)}', 'a mapping with scenario, measured, parameters')
    for key in document:
        if key not in TOP_KEYS:
            fail(str(key), 'unknown key', 'one of ' + ', '.join(TOP_KEYS))
    for key in ('scenario', 'measured', 'parameters'):
        if key not in document:
            fail(key, 'missing', 'see SPEC section 13')
    scenario = read_scenario(fail, path, 'scenario', document['scenario'])
    flights = read_flights(fail, path, document['measured'], scenario)
    parameters = _parameters(fail, document['parameters'], flights)
    evaluations = document.get('max_evaluations', MAX_EVALUATIONS)
    if isinstance(evaluations, bool) or not isinstance(evaluations, int) or evaluations < 1:
        fail('max_evaluations', f'is {show(evaluations)}', 'a whole number >= 1')
    confidence = document.get('confidence', CONFIDENCE)
    if not finite_number(confidence) or not 0 < confidence < 1:
        fail('confidence', f'is {show(confidence)}', 'a probability between 0 and 1, '
             'e.g. 0.95')
    spec = FitSpec(path=path, scenario=scenario[0], document=scenario[1], flights=flights,
                   parameters=parameters, max_evaluations=evaluations,
                   confidence=float(confidence))
    for flight in flights:   # the start values run
        parse_scenario(flight.document_with(parameters, spec.x0), source=flight.scenario)
    return spec


def _parameters(fail, parameters, flights) -> list:
    if not isinstance(parameters, dict) or not parameters:
        fail('parameters', f'is {show(parameters)}',
             "key paths with their start and bounds ('wrenches[1].force[2]': "
             '{start: 42703, bounds: [30000, 50000]})')
    out, seen = [], {}
    for path, entry in parameters.items():
        key = f'parameters.{path}'
        try:
            tokens = parse_key_path(path)
        except ValueError:
            fail(key, 'is not a key path', "names and [index]es, as 'wrenches[1].force[2]'")
        canonical = format_key_path(tokens)
        if canonical in seen:
            fail(key, f'is {canonical}, as parameters.{seen[canonical]} is',
                 'each key path once')
        seen[canonical] = path
        for flight in flights:   # a flight's condition is not also a fitted value
            for name in flight.settings:
                try:
                    fixed = format_key_path(parse_key_path(name))
                except ValueError:
                    continue
                if fixed == canonical:
                    fail(key, f'is also set by {flight.key}.set ({name}: '
                         f'{show(flight.settings[name])})', 'a key path fitted, or set per '
                         'flight, not both')
        value = None
        for flight in flights:
            try:
                _, _, value, exists = resolve(flight.document, tokens)
            except KeyError as err:
                fail(key, f'{err.args[0]} ({flight.key})', 'a key path of the scenario')
            if not exists or not finite_number(value):
                fail(key, f'is {show(value)} in the scenario of {flight.key}',
                     'a number there to fit')
        _, _, value, _ = resolve(flights[0].document, tokens)
        if not isinstance(entry, dict) or set(entry) - set(PARAMETER_KEYS):
            fail(key, f'is {show(entry)}', '{start: x, bounds: [low, high]} (step, name, '
                 'unit optional)')
        start = entry.get('start', value)
        bounds = entry.get('bounds', [-math.inf, math.inf])
        if not (isinstance(bounds, list) and len(bounds) == 2
                and all(isinstance(b, (int, float)) and not isinstance(b, bool)
                        and not math.isnan(b) for b in bounds) and bounds[0] < bounds[1]):
            fail(f'{key}.bounds', f'is {show(bounds)}', '[low, high] with low < high')
        if not finite_number(start) or not bounds[0] <= start <= bounds[1]:
            fail(f'{key}.start', f'is {show(start)}', f'a number within {bounds}')
        width = bounds[1] - bounds[0]
        step = entry.get('step', _default_step(start, bounds))
        if not finite_number(step) or step <= 0:
            fail(f'{key}.step', f'is {show(step)}', 'a step > 0 (of the parameter)')
        if step > width / 2:
            fail(f'{key}.step', f'is {show(step)}, wider than half the bounds {bounds}',
                 f'a step <= {width / 2:.6g}, so that a difference fits within the bounds '
                 'at every value')
        name, unit = entry.get('name', canonical), entry.get('unit', '')
        if not isinstance(name, str) or not isinstance(unit, str):
            fail(key, 'has a name or unit that is not text', 'text')
        out.append(Parameter(path=canonical, tokens=tokens, start=float(start),
                             low=float(bounds[0]), high=float(bounds[1]), step=float(step),
                             name=name, unit=unit))
    return out


def _default_step(start: float, bounds) -> float:
    """
    Return the central difference's step of a parameter.

    ``RELATIVE_STEP`` times its scale: the larger of its start value and a
    tenth of its bounds' width (a start of 0 still has a scale), or 1 for
    a parameter with neither; never more than a quarter of the bounds' width.
    """
    width = bounds[1] - bounds[0]
    scale = max(abs(float(start)), width / 10 if math.isfinite(width) else 0.0)
    return min(RELATIVE_STEP * (scale if scale > 0 else 1.0), width / 4)
