# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The scenario checker: typed accessors that refuse a value with its key path, and the limits.

Every section parser takes a ``Checker``: its ``fail`` raises the one-line
``ScenarioError`` (file, key path, value, what would be right), and its
accessors (``mapping``, ``number``, ``vector``, ``direction``, ``name``)
return the value checked. The limits are the ranges a run can represent.
"""

from __future__ import annotations

import math
import os
import re
from typing import Any, Optional

from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio.messages import clip, show
from cfem_ros.core.fileio.yamlfile import Yaml11Number
import numpy as np

#: Names become ROS topic tokens (bodies/<body>/pose), so they must be valid ones.
NAME_PATTERN = re.compile(r'[A-Za-z][A-Za-z0-9_]*')

#: Longest name, so that the longest topic the node makes,
#: /cfem/bodies/<body>/applied/<source> (150 characters), stays far below
#: ROS's limit of 247 characters for a topic name, with room for a namespace.
MAX_NAME_LENGTH = 64

#: Largest magnitude of any position, anchor, velocity, gravity, orientation
#: or angular velocity component, in the unit of its key.
MAX_MAGNITUDE = 1e9

#: Smallest RK4 step, s.
MIN_DT = 1e-9

#: Most RK4 steps in a run, duration / dt.
MAX_STEPS = 1e9

#: Axis vectors with a component larger than this are scaled down before use.
_AXIS_RESCALE = 1e100


def key_path(parent: str, name: Any) -> str:
    """Return the key path of entry name under parent, safe to show."""
    if isinstance(name, str) and name.isprintable() and len(name) <= 80:
        shown = name
    else:
        shown = f'[{show(name)}]'
    return f'{parent}.{shown}' if parent else shown


def one_of(names) -> str:
    names = [str(n) for n in names]
    shown = ', '.join(names[:8]) + (f' (and {len(names) - 8} more)' if len(names) > 8 else '')
    return 'one of ' + clip(shown, 200)


class Checker:
    """
    Typed accessors that raise ScenarioError with the key path.

    error: the ``ScenarioError`` kind raised (a sweep file's ``SweepError``).
    """

    def __init__(self, source: str, error: type = ScenarioError):
        self.source = source
        self.error = error

    def fail(self, key: str, problem: str, expected: str = ''):
        raise self.error(self.source, clip(key, 120), clip(problem, 240), clip(expected, 240))

    def mapping(self, value, key: str, allowed, required=()) -> dict:
        if not isinstance(value, dict):
            self.fail(key, f'is {show(value)}', 'a mapping')
        for name in value:
            if name not in allowed:
                self.fail(key_path(key, name), 'unknown key', one_of(allowed))
        for name in required:
            if name not in value:
                self.fail(key_path(key, name), 'missing', 'it to be given')
        return value

    def number(self, value, key: str, *, minimum=None, positive=False,
               limit: Optional[float] = None) -> float:
        if isinstance(value, Yaml11Number):
            reading = '' if value.reading is None else f' ({value.reading!r})'
            self.fail(key, f'is {value} as written, a YAML 1.1 {value.kind} number{reading}',
                      'a decimal number (write what you mean, e.g. 90 or 16.0)')
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, f'is {show(value)}', 'a number')
        try:
            value = float(value)
        except OverflowError:
            self.fail(key, f'is {show(value)}, too large for a double', 'a finite number')
        if not math.isfinite(value):
            self.fail(key, f'is {value}', 'a finite number')
        if positive and value <= 0:
            self.fail(key, f'is {value:g}', 'a number > 0')
        if minimum is not None and value < minimum:
            self.fail(key, f'is {value:g}', f'a number >= {minimum:g}')
        if limit is not None and abs(value) > limit:
            self.fail(key, f'is {value:g}', f'a magnitude of at most {limit:g}')
        return value

    def vector(self, value, key: str, length: int = 3, lengths=None,
               limit: Optional[float] = MAX_MAGNITUDE) -> np.ndarray:
        lengths = lengths or (length,)
        if isinstance(value, (list, tuple)) and len(value) in lengths:
            numbers = _plain_numbers(value, limit)
            if numbers is not None:     # what the checks below give, without their calls
                return np.array(numbers)
        if not isinstance(value, (list, tuple)) or len(value) not in lengths:
            want = ' or '.join(str(n) for n in lengths)
            self.fail(key, f'is {show(value)}', f'a list of {want} numbers')
        return np.array([self.number(v, f'{key}[{i}]', limit=limit)
                         for i, v in enumerate(value)])

    def direction(self, value, key: str) -> np.ndarray:
        """Return a direction of any finite length, scaled so that norms cannot overflow."""
        vector = self.vector(value, key, limit=None)
        x, y, z = vector.tolist()
        scale = max(abs(x), abs(y), abs(z))
        if 1e-12 <= scale <= _AXIS_RESCALE:
            # kept as it is; its norm, scale * |vector / scale| >= scale * 1, is not < 1e-12
            return vector
        if scale > _AXIS_RESCALE:
            vector = vector / scale
            scale = 1.0
        if scale == 0.0 or scale * np.linalg.norm(vector / scale) < 1e-12:
            self.fail(key, f'has zero length {show(value)}', 'a non-zero direction')
        return vector

    def name(self, value, key: str) -> str:
        if not isinstance(value, str) or not NAME_PATTERN.fullmatch(value):
            self.fail(key, f'{show(value)} is not a usable name',
                      'a letter then letters, digits or _ (it becomes a ROS topic name)')
        if len(value) > MAX_NAME_LENGTH:
            self.fail(key, f'{show(value)} has {len(value)} characters',
                      f'a name of at most {MAX_NAME_LENGTH} characters (it becomes part of '
                      'ROS topic names)')
        return value


def _plain_numbers(value, limit: Optional[float]) -> Optional[list]:
    """
    Return value's items as floats if each is an int or float that ``Checker.number`` takes.

    Only items of type exactly int or float, finite and of magnitude at most
    limit (if given); None for anything else, which the checks then name.
    """
    numbers = []
    for item in value:
        kind = type(item)
        if kind is float:
            number = item
        elif kind is int:
            try:
                number = float(item)
            except OverflowError:
                return None
        else:
            return None
        if limit is None:
            if not math.isfinite(number):
                return None
        elif not -limit <= number <= limit:    # NaN and infinities fail too
            return None
        numbers.append(number)
    return numbers


def body_of(check: Checker, value, key: str, index: dict) -> int:
    if not isinstance(value, str) or value not in index:   # a list is no name (nor hashable)
        check.fail(key, f'{show(value)} is not a body', 'one of ' + ', '.join(index))
    return index[value]


def source_dir(check: Checker) -> str:
    """
    Return the folder of the scenario file, which files it names are relative to.

    A sweep names its runs' sources ``<file> (run k)``: the file is what counts.
    """
    source = check.source
    if not os.path.isfile(source):
        source = re.sub(r' \(run \d+\)$', '', source)
    return os.path.dirname(os.path.abspath(source)) if os.path.isfile(source) else ''
