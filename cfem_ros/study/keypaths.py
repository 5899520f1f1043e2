# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Key paths into a scenario document (``wrenches[1].force[2]``): parsed, written, resolved."""

from __future__ import annotations

import copy
import re

_TOKEN = re.compile(r'\.?([A-Za-z_][A-Za-z0-9_]*)|\[(\d+)\]')


def parse_key_path(text: str) -> tuple:
    """
    Split a key path into mapping keys (str) and list indices (int).

    ``wrenches[1].force[2]`` -> ('wrenches', 1, 'force', 2). Raises
    ValueError if the text is not a key path.
    """
    if not isinstance(text, str) or not text or text[0] in '.[':
        raise ValueError('not a key path')
    tokens, at = [], 0
    while at < len(text):
        match = _TOKEN.match(text, at)
        if match is None or (at > 0 and match.group(1) and text[at] != '.') \
                or (at == 0 and text[0] == '.'):
            raise ValueError('not a key path')
        tokens.append(match.group(1) if match.group(1) else int(match.group(2)))
        at = match.end()
    return tuple(tokens)


def format_key_path(tokens) -> str:
    """Return the text of a key path (the inverse of ``parse_key_path``)."""
    out = ''
    for token in tokens:
        out += f'[{token}]' if isinstance(token, int) else (f'.{token}' if out else token)
    return out


def resolve(document, tokens) -> tuple:
    """
    Find where a key path points in a document.

    Returns (container, last token, existing value or None, exists). The
    path must lead through existing mappings and lists; its last key may
    be new in an existing mapping. Raises KeyError with what went wrong.
    """
    node = document
    for depth, token in enumerate(tokens[:-1]):
        node = _step(node, token, tokens[:depth + 1])
    last = tokens[-1]
    if isinstance(last, int):
        if not isinstance(node, list):
            raise KeyError(f'{format_key_path(tokens[:-1]) or "the document"} is '
                           f'{_kind(node)}, not a list')
        if last >= len(node):
            raise KeyError(f'index {last} is past the end of a list of {len(node)}')
        return node, last, node[last], True
    if not isinstance(node, dict):
        raise KeyError(f'{format_key_path(tokens[:-1]) or "the document"} is '
                       f'{_kind(node)}, not a mapping')
    return node, last, node.get(last), last in node


def _step(node, token, path):
    if isinstance(token, int):
        if not isinstance(node, list):
            raise KeyError(f'{format_key_path(path[:-1])} is {_kind(node)}, not a list')
        if token >= len(node):
            raise KeyError(f'{format_key_path(path)}: index {token} is past the end of a '
                           f'list of {len(node)}')
        return node[token]
    if not isinstance(node, dict):
        raise KeyError(f'{format_key_path(path[:-1]) or "the document"} is {_kind(node)}, '
                       'not a mapping')
    if token not in node:   # with the keys there are, for the message
        raise KeyError(f'{format_key_path(path)} does not exist in the scenario',
                       [format_key_path([*path[:-1], str(key)]) for key in node])
    return node[token]


def _kind(value) -> str:
    if value is None:
        return 'empty'
    return {dict: 'a mapping', list: 'a list', str: 'a string'}.get(type(value), 'a number')


def apply_values(document: dict, variables, values: dict) -> dict:
    """Return a copy of document with each variable's key path set to its value."""
    out = copy.deepcopy(document)
    for variable in variables:
        container, last, _, _ = resolve(out, variable.tokens)
        container[last] = copy.deepcopy(values[variable.path])
    return out
