# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
YAML documents read within fixed bounds of time and memory (PyYAML, safe, YAML 1.1).

Duplicate and unhashable keys are refused, nesting deeper than ``MAX_DEPTH``
and aliases expanding beyond ``MAX_EXPANDED_NODES`` too (an alias bomb is
refused while still small), and numbers in notations a reader rarely means
(``1:30``, ``0x10``, ``010``) are kept as written (``Yaml11Number``).
"""

from __future__ import annotations

import re
from typing import Any

from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio.messages import clip, show
import yaml
from yaml.composer import Composer
from yaml.constructor import ConstructorError, SafeConstructor
from yaml.resolver import BaseResolver, Resolver

try:
    from yaml.cyaml import CParser
except ImportError:  # PyYAML built without libyaml: the pure Python parser only
    CParser = None

#: Deepest nesting of YAML collections (a scenario needs 5).
MAX_DEPTH = 64

#: Most YAML values once aliases are expanded (an alias counts as a copy).
MAX_EXPANDED_NODES = 1_000_000


class _Refused(Exception):
    """A loader bound was passed (``load_yaml`` makes it a ScenarioError)."""

    def __init__(self, problem: str, expected: str, mark=None):
        super().__init__(problem)
        self.problem, self.expected, self.mark = problem, expected, mark


class _BoundedComposer(Composer):
    """
    The YAML composer with bounds on nesting depth and alias expansion.

    A node's size counts every alias in it as a full copy of the node it
    names, so an alias bomb (a billion laughs) is refused while its text and
    its node graph are still small. The same code runs over the pure Python
    parser and over libyaml's (``CParser``).
    """

    def compose_document(self):
        self._depth = 0
        self._sizes = {}
        try:
            return super().compose_document()
        finally:
            self._sizes = {}

    def compose_node(self, parent, index):
        if self.check_event(yaml.events.AliasEvent):
            event = self.peek_event()
            node = super().compose_node(parent, index)
            if id(node) not in self._sizes:
                raise _Refused(f'alias *{clip(event.anchor, 40)} refers to a collection '
                               'that contains it', 'no recursive aliases', event.start_mark)
            return node
        self._depth += 1
        if self._depth > MAX_DEPTH:
            raise _Refused(f'collections nested deeper than {MAX_DEPTH} levels',
                           f'at most {MAX_DEPTH} levels', self.peek_event().start_mark)
        try:
            node = super().compose_node(parent, index)
        finally:
            self._depth -= 1
        if isinstance(node, yaml.MappingNode):
            children = [n for pair in node.value for n in pair]
        elif isinstance(node, yaml.SequenceNode):
            children = node.value
        else:
            children = ()
        size = 1 + sum(self._sizes[id(child)] for child in children)
        if size > MAX_EXPANDED_NODES:
            raise _Refused(f'aliases expand to more than {MAX_EXPANDED_NODES:,} values',
                           f'at most {MAX_EXPANDED_NODES:,} values once aliases are '
                           'expanded', node.start_mark)
        self._sizes[id(node)] = size
        return node


_MERGE_TAG = 'tag:yaml.org,2002:merge'


class _Constructor(SafeConstructor):
    """The safe constructor, refusing unhashable and duplicate mapping keys."""

    def construct_unique_mapping(self, node, deep=False):
        """Build a mapping; refuse a key given twice instead of keeping the last."""
        own = [key_node for key_node, _ in node.value if key_node.tag != _MERGE_TAG]
        self.flatten_mapping(node)      # merge keys (<<): their entries yield to own keys
        seen = {}
        for key_node in own:
            key = self.construct_object(key_node, deep=deep)
            if isinstance(key, (list, dict, set)):
                raise ConstructorError(None, None, f'a {type(key).__name__} is used as a '
                                       'mapping key', key_node.start_mark)
            if key in seen:
                raise ConstructorError(
                    None, None, f'duplicate key {show(key)} (first at line {seen[key] + 1})',
                    key_node.start_mark)
            seen[key] = key_node.start_mark.line
        return SafeConstructor.construct_mapping(self, node, deep)


_Constructor.add_constructor(BaseResolver.DEFAULT_MAPPING_TAG,
                             _Constructor.construct_unique_mapping)


class Yaml11Number(str):
    """
    A YAML 1.1 number in a notation a reader rarely means: sexagesimal, hexadecimal, octal, binary.

    YAML 1.1 (PyYAML) reads ``1:30`` as 90, ``0x10`` as 16 and ``010`` as 8.
    The scenario loader keeps such a value as written (a string, fine where
    text is meant) and ``_Checker.number`` refuses it where a number is
    meant, naming both readings.
    """

    kind: str = ''
    reading: Any = None


_INT_TAG, _FLOAT_TAG = 'tag:yaml.org,2002:int', 'tag:yaml.org,2002:float'
_YAML11_TAG = 'tag:cfem_ros,2026:yaml11-number'
_YAML11_NUMBER = re.compile(r"""^(?:[-+]?0b[0-1_]+
    |[-+]?0[0-7_]+
    |[-+]?0x[0-9a-fA-F_]+
    |[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+(?:\.[0-9_]*)?)$""", re.X)
_DECIMAL_INT = re.compile(r'^[-+]?(?:0|[1-9][0-9_]*)$')
#: Decimal floats, also without a dot or an exponent sign (1e5, 2.5E-3: YAML 1.2, which
#: PyYAML's YAML 1.1 reads as strings), infinities and NaN (refused later as not finite).
_DECIMAL_FLOAT = re.compile(r"""^(?:[-+]?[0-9][0-9_]*(?:\.[0-9_]*(?:[eE][-+]?[0-9]+)?
                                            |[eE][-+]?[0-9]+)
    |[-+]?\.[0-9][0-9_]*(?:[eE][-+]?[0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""", re.X)


class _Resolver(Resolver):
    """YAML 1.1's implicit types, with decimal numbers only (see ``Yaml11Number``)."""

    yaml_implicit_resolvers = {
        first: [(tag, regexp) for tag, regexp in resolvers if tag not in (_INT_TAG, _FLOAT_TAG)]
        for first, resolvers in Resolver.yaml_implicit_resolvers.items()}


for _tag, _pattern, _first in ((_YAML11_TAG, _YAML11_NUMBER, '-+0123456789'),
                               (_INT_TAG, _DECIMAL_INT, '-+0123456789'),
                               (_FLOAT_TAG, _DECIMAL_FLOAT, '-+0123456789.')):
    for _char in _first:   # first: checked before the timestamp's resolver
        _Resolver.yaml_implicit_resolvers.setdefault(_char, [])
    _Resolver.add_implicit_resolver(_tag, _pattern, list(_first))
for _char, _resolvers in _Resolver.yaml_implicit_resolvers.items():   # numbers first
    _resolvers.sort(key=lambda item: item[0] not in (_YAML11_TAG, _INT_TAG, _FLOAT_TAG))


def _construct_yaml11(constructor, node) -> Yaml11Number:
    text = constructor.construct_scalar(node)
    value = Yaml11Number(text)
    plain = text.lstrip('+-').lower()
    value.kind = ('sexagesimal (base 60)' if ':' in plain else 'hexadecimal' if 'x' in plain
                  else 'binary' if 'b' in plain else 'octal')
    try:
        value.reading = (SafeConstructor.construct_yaml_float(constructor, node) if '.' in text
                         else SafeConstructor.construct_yaml_int(constructor, node))
    except (ValueError, OverflowError):
        value.reading = None
    return value


_Constructor.add_constructor(_YAML11_TAG, _construct_yaml11)


class PythonLoader(yaml.reader.Reader, yaml.scanner.Scanner, yaml.parser.Parser,
                   _BoundedComposer, _Constructor, _Resolver):
    """The bounded safe loader over PyYAML's pure Python parser."""

    def __init__(self, stream):
        yaml.reader.Reader.__init__(self, stream)
        yaml.scanner.Scanner.__init__(self)
        yaml.parser.Parser.__init__(self)
        _BoundedComposer.__init__(self)
        _Constructor.__init__(self)
        _Resolver.__init__(self)


if CParser is not None:
    class CLoader(_BoundedComposer, CParser, _Constructor, _Resolver):
        """The bounded safe loader over libyaml's parser: the same results, faster."""

        def __init__(self, stream):
            CParser.__init__(self, stream)
            _BoundedComposer.__init__(self)
            _Constructor.__init__(self)
            _Resolver.__init__(self)

    #: The loaders available, the one ``load_yaml`` uses by default first.
    LOADERS = (CLoader, PythonLoader)
else:  # pragma: no cover - PyYAML without libyaml
    LOADERS = (PythonLoader,)


def load_yaml(text: str, source: str = '<scenario>', loader=None) -> Any:
    """
    Parse one YAML document within the bounds of a scenario file.

    Parameters
    ----------
    text : str
        The document.
    source : str
        Named in error messages.
    loader : class, optional
        One of ``LOADERS``; by default the fastest available.

    Raises
    ------
    ScenarioError
        For YAML syntax, duplicate or unhashable keys, nesting deeper than
        ``MAX_DEPTH``, aliases expanding beyond ``MAX_EXPANDED_NODES``, and
        values Python cannot represent.

    """
    parser = None
    try:
        parser = (loader or LOADERS[0])(text)
        return parser.get_single_data()
    except _Refused as err:
        raise ScenarioError(source, '', _where(err.mark) + err.problem, err.expected) from None
    except yaml.YAMLError as err:
        mark = getattr(err, 'problem_mark', None)
        problem = getattr(err, 'problem', None) or getattr(err, 'reason', None) or str(err)
        if 'maximum nesting depth' in str(problem):   # libyaml's own bound, below ours
            raise ScenarioError(source, '', f'{_where(mark)}collections nested deeper than '
                                f'{MAX_DEPTH} levels', f'at most {MAX_DEPTH} levels') from None
        raise ScenarioError(source, '', f'{_where(mark)}not valid YAML: {clip(problem)}',
                            'a YAML mapping as in SPEC section 1') from None
    except (ValueError, OverflowError) as err:
        problem = ('a number has more than 4300 digits' if 'digits' in str(err)
                   else f'a value cannot be read ({clip(err, 120)})')
        raise ScenarioError(source, '', problem,
                            'numbers of at most 4300 digits and valid dates') from None
    finally:
        if parser is not None:
            parser.dispose()


def _where(mark) -> str:
    return f'line {mark.line + 1}, column {mark.column + 1}: ' if mark is not None else ''
