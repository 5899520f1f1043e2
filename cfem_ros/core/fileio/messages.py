# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""How values are shown in error messages: on one line, short, whatever they are."""

from __future__ import annotations

import reprlib
from typing import Any

#: A repr bounded in length and depth.
REPR = reprlib.Repr()
REPR.maxstring = 60
REPR.maxother = 60
REPR.maxlevel = 3
REPR.maxlist = REPR.maxtuple = REPR.maxdict = REPR.maxset = 6
REPR.maxlong = 40


def clip(text: str, limit: int = 160) -> str:
    """Return text on one line and at most limit characters."""
    text = str(text)
    if len(text) > limit:
        text = text[:limit - 3] + '...'
    return text if text.isprintable() else ''.join(c if c.isprintable() else ' ' for c in text)


def show(value: Any) -> str:
    """Return a short one-line repr of any value, however large or deep."""
    try:
        text = REPR.repr(value)
    except Exception:  # noqa: B902 - a repr that fails is shown by its type
        text = f'<{type(value).__name__}>'
    return clip(text, 80)
