# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Fenced code blocks of the README and the user guide, with their run directives.

A block may be preceded by an HTML comment that says how the test suite runs
it (the comment is invisible on GitHub and in the HTML guide)::

    <!-- doc-test: skip REASON -->        not run, for the reason given
    <!-- doc-test: background [TEXT] -->  a first terminal: started, not waited for; the
                                          next block runs once it has printed TEXT (its
                                          "ready" line), or anything without TEXT
    <!-- doc-test: interrupt -->          Ctrl-C the background blocks (SIGINT) and
                                          wait for them to end, then run this block
    <!-- doc-test: wait -->               wait for the background blocks to end by
                                          themselves, then run this block
    <!-- doc-test: interrupt-after S -->  run this block, Ctrl-C it S seconds after it
                                          has begun to write beside a file it names
                                          (it must then exit 130)
    <!-- doc-test: extends FILE -->       a YAML excerpt: merged into FILE (from the
                                          repository root) and run as a scenario
"""

import dataclasses
import pathlib
import re
from typing import List, Optional

ROOT = pathlib.Path(__file__).resolve().parents[2]
GUIDE = ROOT / 'docs' / 'guide'

_FENCE = re.compile(r'^(\s*)(`{3,}|~{3,})\s*([\w+-]*)\s*(.*)$')
_DIRECTIVE = re.compile(r'^\s*<!--\s*doc-test:\s*(.*?)\s*-->\s*$')
_HEADING = re.compile(r'^(#{1,6})\s+(.*?)\s*#*\s*$')


@dataclasses.dataclass
class Block:
    """One fenced code block of a Markdown file."""

    path: pathlib.Path
    line: int            # 1-based line of the opening fence
    lang: str            # 'bash', 'yaml', 'python', '' ...
    text: str
    section: str         # the heading the block is under
    directive: Optional[str] = None   # the doc-test comment's text, if any

    @property
    def where(self) -> str:
        """Return 'FILE:LINE' relative to the repository root."""
        return f'{self.path.relative_to(ROOT)}:{self.line}'

    @property
    def verb(self) -> str:
        """Return the directive's first word ('' without one)."""
        return self.directive.split()[0] if self.directive else ''

    @property
    def argument(self) -> str:
        """Return the directive's text after its first word."""
        return self.directive.partition(' ')[2].strip() if self.directive else ''


def _closes(line: str, marker: str) -> bool:
    """Return whether line closes a fence opened by marker."""
    text = line.strip()
    return text.startswith(marker) and text.strip(marker[0]) == ''


def blocks(path: pathlib.Path) -> List[Block]:
    """Return the fenced code blocks of a Markdown file, in order."""
    lines = path.read_text(encoding='utf-8').split('\n')
    found = []
    section = ''
    pending = None
    i = 0
    while i < len(lines):
        line = lines[i]
        fence = _FENCE.match(line)
        if fence:
            indent, marker, lang = fence.group(1), fence.group(2), fence.group(3)
            body = []
            j = i + 1
            while j < len(lines) and not _closes(lines[j], marker):
                body.append(lines[j][len(indent):] if lines[j].startswith(indent) else lines[j])
                j += 1
            found.append(Block(path, i + 1, lang, '\n'.join(body) + '\n', section, pending))
            pending = None
            i = j + 1
            continue
        directive = _DIRECTIVE.match(line)
        heading = _HEADING.match(line)
        if directive:
            pending = directive.group(1)
        elif heading:
            section = heading.group(2)
            pending = None
        elif line.strip():
            pending = None
        i += 1
    return found


def pages() -> List[pathlib.Path]:
    """Return the README and every page of the guide (new pages join by themselves)."""
    return [ROOT / 'README.md'] + sorted(GUIDE.glob('*.md'))
