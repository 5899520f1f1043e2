# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A sweep's runs' models: the base scenario parsed once, each run's parts parsed again.

The same model as a whole parse of the run's document gives, to the bit
(``scenario.reparse``), in a fraction of its time.
"""

from __future__ import annotations

import copy
import json
import threading
from typing import Optional

from cfem_ros.core.scenario.parse import parse_scenario, reparse, unscaled_aero
from cfem_ros.study.draws import RANDOM_NUMBERS
from cfem_ros.study.keypaths import apply_values, resolve
from cfem_ros.study.spec import SweepSpec


#: A body's keys read by other parts of the document: a whole parse (``fixed``; ``cg_offset``
#: moves the points of its wrenches and its aero reference point).
_WHOLE = ('fixed', 'cg_offset')


def _section(tokens, document) -> Optional[tuple]:
    """
    Return the part of the document a key path lies inside, None if none.

    ('bodies'|'joints', name), ('wrenches', ''), or ('aero', name) for a
    key path inside an aero entry's ``scale`` or ``delta`` (outside
    ``flight:``, which sets the aero air).
    """
    if len(tokens) >= 3 and tokens[0] == 'wrenches' and isinstance(tokens[1], int) \
            and isinstance(document.get('wrenches'), list):
        return 'wrenches', ''
    if len(tokens) == 4 and tokens[0] == 'aero' and tokens[2] in ('scale', 'delta') \
            and 'flight' not in document and isinstance(document.get('aero'), dict) \
            and isinstance(document['aero'].get(tokens[1]), dict) \
            and isinstance(document['aero'][tokens[1]].get(tokens[2]), dict):
        return 'aero', tokens[1]
    if len(tokens) < 3 or tokens[0] not in ('bodies', 'joints') \
            or not isinstance(tokens[1], str) or tokens[0] == 'bodies' and tokens[2] in _WHOLE:
        return None
    mapping = document.get(tokens[0])
    if not isinstance(mapping, dict) or not isinstance(mapping.get(tokens[1]), dict):
        return None
    return tokens[0], tokens[1]


def _source(spec: SweepSpec, k: int) -> str:
    return f'{spec.scenario} (run {k})'


def full_model(spec: SweepSpec, k: int, values: dict):
    """Return run k's model, its whole document parsed."""
    return parse_scenario(apply_values(spec.document, spec.variables, values),
                          source=_source(spec, k))


class Models:
    """
    The runs' models, the base scenario parsed once per task.

    A key path inside a body (but its ``fixed`` and ``cg_offset``), a joint or a wrench only
    needs that body or joint, or the wrenches, parsed again, and one inside
    an aero entry's ``scale`` or ``delta`` only needs them set on its tables
    read once (``scenario.reparse``); the others (``dt``, ``aero``, ...) need a whole
    parse, done once per distinct set of their
    values if they are choices or grids (a run drawing numbers for them is
    parsed whole). A run whose values do not parse is parsed whole again,
    so that its message is the whole parse's. A document in which one
    mapping or list sits in two places (a YAML alias) is parsed whole for
    every run: a value set in one place shows in the other. Safe to share
    between threads.
    """

    def __init__(self, spec: SweepSpec):
        self.spec = spec
        sections = {v.path: _section(v.tokens, spec.document) for v in spec.variables}
        self.touched = sorted({s for s in sections.values() if s is not None})
        self.slow = [v for v in spec.variables if sections[v.path] is None]
        if any(v.kind in RANDOM_NUMBERS for v in self.slow) or _shared(spec.document):
            self.touched = []   # a whole parse per run
        self.inside = {s: [v for v in spec.variables if sections[v.path] == s]
                       for s in self.touched}
        self._bases = {}
        self._unscaled = {}   # the base's aero entries unscaled (scenario.unscaled_aero)
        self._lock = threading.Lock()
        self._parts = {kind: [n for k, n in self.touched if k == kind]
                       for kind in ('bodies', 'joints', 'aero')}

    def full(self, k: int, values: dict):
        """Return run k's model parsed whole from its document."""
        return full_model(self.spec, k, values)

    def model(self, k: int, values: dict):
        """Return run k's model, the same to the bit as a whole parse gives."""
        if not self.touched:
            return self.full(k, values)
        key = json.dumps([values[v.path] for v in self.slow], default=repr) if self.slow else ''
        with self._lock:
            base = self._bases.get(key)
        if base is None:
            document = apply_values(self.spec.document, self.slow, values)
            try:
                model = parse_scenario(document, source=_source(self.spec, k))
                unscaled = (unscaled_aero(model, document, source=_source(self.spec, k))
                            if self._parts['aero'] else ())
            except Exception:   # noqa: B902 (this run's whole parse names the error)
                model, unscaled = None, ()
            with self._lock:
                self._unscaled.setdefault(key, unscaled)
                base = self._bases.setdefault(key, (document, model))
        document, model = base
        unscaled = self._unscaled[key]
        if model is None:
            return self.full(k, values)
        try:
            top = dict(document)
            for kind, name in self.touched:
                if kind == 'wrenches':
                    part = top[kind] = list(document[kind])
                    for variable in self.inside[kind, name]:
                        _set_copying(part, variable.tokens[1:], values[variable.path])
                    continue
                top[kind] = dict(top[kind])
                part = top[kind][name] = dict(document[kind][name])
                for variable in self.inside[kind, name]:
                    _set_copying(part, variable.tokens[2:], values[variable.path])
            return reparse(model, top, source=_source(self.spec, k),
                           bodies=self._parts['bodies'], joints=self._parts['joints'],
                           wrenches=('wrenches', '') in self.touched,
                           aero=self._parts['aero'], unscaled=unscaled)
        except Exception:   # noqa: B902
            return self.full(k, values)


def _shared(document) -> bool:
    """Tell whether a mapping or list sits in two places in document (a YAML alias)."""
    seen = set()
    stack = [document]
    while stack:
        node = stack.pop()
        if isinstance(node, (dict, list)):
            if id(node) in seen:
                return True
            seen.add(id(node))
            stack.extend(node.values() if isinstance(node, dict) else node)
    return False


def _set_copying(part: dict, tokens, value):
    """
    Set a key path in part (a copy of a section) to value, copying what it goes through.

    Only the mappings and lists on the path are copied (the rest is shared
    with the base document, which the parse only reads): what a deep copy
    of the section would give, in a fraction of its time, when nothing in
    the document sits in two places (``_shared``).
    """
    node = part
    for token in tokens[:-1]:   # a path that does not lead anywhere raises: a whole parse
        child = node[token]
        node[token] = child = dict(child) if isinstance(child, dict) else list(child)
        node = child
    container, last, _, _ = resolve(node, tokens[-1:])
    container[last] = copy.deepcopy(value)
