# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Criteria that combine rules with ``and``, ``or`` and parentheses (SPEC section 12).

A lexer turns the text into tokens (names, numbers, comparison operators,
``abs``, ``and``, ``or``, parentheses; anything else is an error naming
the character) and a recursive-descent parser builds the tree::

    expression := conjunction ('or' conjunction)*
    conjunction := primary ('and' primary)*
    primary := '(' expression ')' | rule
    rule := (name | 'abs' '(' name ')') op number

``and`` binds tighter than ``or``; chains are read by loops (an expression
of any number of terms), and parentheses may nest ``MAX_DEPTH`` deep.
Nothing is evaluated as Python. A rule is a ``criteria.Criterion``; a
whole expression of one rule is that rule. The margin of ``a and b`` is
the least of their margins and that of ``a or b`` the largest: below 0
exactly where the expression fails (the rare-event methods' limit state).
"""

from __future__ import annotations

from dataclasses import dataclass
import math
import re

from cfem_ros.study.criteria import Criterion, finished_runs
import numpy as np

#: Longest criterion text, characters.
MAX_LENGTH = 200_000
#: Deepest nesting of parentheses.
MAX_DEPTH = 64
_TOKEN = re.compile(r'\s*(?:(?P<number>[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)(?![\w.])'
                    r'|(?P<name>[A-Za-z_][\w.\[\]]*)|(?P<op><=|>=|<|>)|(?P<paren>[()]))')
KEYWORDS = ('and', 'or', 'abs')


@dataclass(frozen=True)
class _Token:
    kind: str      # 'number', 'name', 'op', 'paren', 'end'
    text: str
    at: int        # character offset in the criterion


def tokens(text: str) -> list:
    """Return the tokens of a criterion's text; ValueError naming the first bad character."""
    out, at = [], 0
    while at < len(text):
        match = _TOKEN.match(text, at)
        if match is None or match.end() == at:
            rest = text[at:].lstrip()
            if not rest:
                break
            where = len(text) - len(rest)
            raise ValueError(f'unexpected {rest[0]!r} at character {where + 1}')
        kind = match.lastgroup
        out.append(_Token(kind, match.group(kind), match.start(kind)))
        at = match.end()
    out.append(_Token('end', '', len(text)))
    return out


@dataclass(frozen=True)
class Combined:
    """Rules joined by ``and`` (``kind`` 'and') or ``or`` ('or')."""

    kind: str
    parts: tuple

    def leaves(self) -> list:
        """Return the rules, left to right."""
        return [leaf for part in self.parts for leaf in _leaves(part)]


def _leaves(node) -> list:
    return node.leaves() if isinstance(node, Combined) else [node]


class _Parser:
    def __init__(self, name: str, text: str):
        self.name = name
        self.tokens = tokens(text)
        self.at = 0
        self.depth = 0

    def peek(self) -> _Token:
        return self.tokens[self.at]

    def take(self) -> _Token:
        token = self.tokens[self.at]
        self.at += 1
        return token

    def fail(self, token: _Token, expected: str):
        shown = repr(token.text) if token.kind != 'end' else 'the end'
        raise ValueError(f'{shown} at character {token.at + 1}: expected {expected}')

    def expression(self):
        parts = [self.conjunction()]
        while self.peek().kind == 'name' and self.peek().text == 'or':
            self.take()
            parts.append(self.conjunction())
        return parts[0] if len(parts) == 1 else Combined('or', tuple(parts))

    def conjunction(self):
        parts = [self.primary()]
        while self.peek().kind == 'name' and self.peek().text == 'and':
            self.take()
            parts.append(self.primary())
        return parts[0] if len(parts) == 1 else Combined('and', tuple(parts))

    def primary(self):
        token = self.peek()
        if token.kind == 'paren' and token.text == '(':
            self.take()
            self.depth += 1
            if self.depth > MAX_DEPTH:
                raise ValueError(f'parentheses nested deeper than {MAX_DEPTH} at character '
                                 f'{token.at + 1}')
            inner = self.expression()
            closing = self.take()
            if closing.kind != 'paren' or closing.text != ')':
                self.fail(closing, "')', 'and' or 'or'")
            self.depth -= 1
            return inner
        return self.rule()

    def rule(self) -> Criterion:
        token = self.take()
        absolute = False
        if token.kind == 'name' and token.text == 'abs' and self.peek().text == '(':
            self.take()
            absolute, token = True, self.take()
            if token.kind != 'name' or token.text in KEYWORDS:
                self.fail(token, 'a column name inside abs( )')
            closing = self.take()
            if closing.text != ')':
                self.fail(closing, "')' after abs(<column>")
        elif token.kind != 'name' or token.text in KEYWORDS:
            self.fail(token, "a rule '<column> <op> <number>', 'abs(<column>) <op> <number>' "
                      "or '('")
        op = self.take()
        if op.kind != 'op':
            self.fail(op, 'a comparison <, <=, > or >=')
        number = self.take()
        if number.kind != 'number':
            self.fail(number, 'a number')
        threshold = float(number.text)
        if not math.isfinite(threshold):
            raise ValueError(f'{number.text!r} at character {number.at + 1} is not a finite '
                             'number')
        return Criterion(name=self.name, column=token.text, op=op.text, threshold=threshold,
                         absolute=absolute)


@dataclass(frozen=True)
class Expression:
    """
    A named criterion combining rules (``and``, ``or``, parentheses).

    Attributes
    ----------
    name, text : str
        The criterion's name and its text as written (spaces collapsed).
    tree : Combined
        The parsed expression; its leaves are ``Criterion`` rules.

    """

    name: str
    text: str
    tree: Combined

    column = None        # no single column: not drawn as a limit line
    absolute = False

    @property
    def columns(self) -> list:
        """Return the columns the rules name, each once, in order."""
        return list(dict.fromkeys(leaf.column for leaf in self.tree.leaves()))

    def passes_of(self, table) -> np.ndarray:
        """Return, per run, whether the expression holds (a NaN value fails its rule)."""
        return _evaluate(self.tree, table, passes=True) & finished_runs(table)

    def margin_of(self, table) -> np.ndarray:
        """Return, per run, the expression's margin (the least of 'and', largest of 'or')."""
        return _evaluate(self.tree, table, passes=False)


def _evaluate(node, table, passes: bool) -> np.ndarray:
    if isinstance(node, Criterion):
        values = table[node.column].to_numpy(dtype=float)
        return node.passes(values) if passes else node.margin(values)
    found = [_evaluate(part, table, passes) for part in node.parts]
    if passes:
        return np.logical_and.reduce(found) if node.kind == 'and' \
            else np.logical_or.reduce(found)
    return np.minimum.reduce(found) if node.kind == 'and' else np.maximum.reduce(found)


def parse_criterion(name: str, text):
    """
    Return the criterion of a text: a ``Criterion`` for one rule, else an ``Expression``.

    Raises
    ------
    ValueError
        If the text is not a criterion (the message says where and what was expected).

    """
    if not isinstance(text, str):
        raise ValueError(f'{text!r:.80} is not a rule')
    if len(text) > MAX_LENGTH:
        raise ValueError(f'is {len(text):,} characters long; at most {MAX_LENGTH:,}')
    parser = _Parser(name, text)
    tree = parser.expression()
    last = parser.take()
    if last.kind != 'end':
        parser.fail(last, "'and', 'or' or the end")
    if isinstance(tree, Criterion):
        return tree
    return Expression(name=name, text=' '.join(text.split()), tree=tree)


def from_json(held: dict):
    """Return a criterion from its ``criteria.json`` entry (``criteria.to_json``)."""
    if held.get('expression'):
        return parse_criterion(held['name'], held['rule'])
    return Criterion(held['name'], held['column'], held['op'], held['threshold'],
                     held['absolute'])
