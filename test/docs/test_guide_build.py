# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The user guide builds without a warning, and no link of it or of the README is broken.

Sphinx runs as ``make docs`` runs it (``-W --keep-going``, nitpicky): MyST
resolves every cross-reference and relative link to a page or a heading, so
a broken one is a warning, hence a failure. The README is not part of the
Sphinx project; its relative links are checked here against the files and
their headings. Nothing goes to the network.
"""

import pathlib
import re
import shutil
import subprocess
import sys

import docblocks
import pytest

ROOT = docblocks.ROOT
DOCS = ROOT / 'docs'
GUIDE = docblocks.GUIDE

_LINK = re.compile(r'(?<!!)\[[^\]]*\]\(([^)\s]+)\)')
_IMAGE = re.compile(r'!\[[^\]]*\]\(([^)\s]+)\)')
_GLOB_ENTRY = re.compile(r'^\s*([\w-]*\[[^\]]+\][\w-]*)\s*$', re.M)


def sphinx(source: pathlib.Path, out: pathlib.Path) -> subprocess.CompletedProcess:
    """Build the HTML guide from source into out, warnings as errors."""
    return subprocess.run(
        [sys.executable, '-m', 'sphinx', '-b', 'html', '-W', '--keep-going', '-n', '-q',
         '-d', str(out / '.doctrees'), str(source), str(out)],
        capture_output=True, text=True, timeout=300)


@pytest.fixture(scope='module')
def built(tmp_path_factory):
    """Build the guide once for this module's tests."""
    out = tmp_path_factory.mktemp('html')
    done = sphinx(DOCS, out)
    return done, out


def test_guide_builds_without_warnings(built):
    done, out = built
    assert done.returncode == 0, f'sphinx-build -W failed:\n{done.stdout}{done.stderr}'
    assert 'WARNING' not in done.stderr, done.stderr
    for page in GUIDE.glob('*.md'):
        assert (out / 'guide' / (page.stem + '.html')).is_file(), f'{page.name} not built'
    for page in ('SPEC', 'CFEM', 'index'):
        assert (out / (page + '.html')).is_file()


def test_links_between_pages_become_links(built):
    _, out = built
    node = (out / 'guide' / 'node.html').read_text(encoding='utf-8')
    assert 'href="recordings.html#salvaging-a-cut-recording"' in node
    assert 'href="../SPEC.html"' in node
    figures = out / '_images'
    assert any(figures.glob('body_store*.png')), 'the verification figures are not copied'


def small_guide(folder: pathlib.Path, pages: dict) -> pathlib.Path:
    """Write a guide with this configuration, an index listing a.md and an optional page."""
    source = folder / 'docs'
    (source / 'guide').mkdir(parents=True)
    shutil.copy(DOCS / 'conf.py', source / 'conf.py')
    (source / 'index.rst').write_text('Root\n====\n\n.. toctree::\n\n   guide/index\n')
    (source / 'guide' / 'index.md').write_text(
        '# Guide\n\n```{toctree}\n:glob:\n\na\noptional-pag[e]\n```\n\n![figure](a.png)\n')
    (source / 'guide' / 'a.png').write_bytes(b'')
    for name, text in pages.items():
        (source / 'guide' / name).write_text(text, encoding='utf-8')
    return source


def test_an_optional_page_is_listed_once_present(tmp_path):
    source = small_guide(tmp_path, {'a.md': '# A\n\n## Part\n\n[self](a.md#part)\n'})
    done = sphinx(source, tmp_path / 'absent')
    assert done.returncode == 0, done.stderr
    assert 'a.png' in (tmp_path / 'absent' / 'guide' / 'index.html').read_text()
    (source / 'guide' / 'optional-page.md').write_text('# Optional\n')
    done = sphinx(source, tmp_path / 'present')
    assert done.returncode == 0, done.stderr
    assert 'optional-page.html' in (tmp_path / 'present' / 'guide' / 'index.html').read_text()


def test_a_broken_link_or_an_orphan_page_fails_the_build(tmp_path):
    source = small_guide(tmp_path, {
        'a.md': '# A\n\n[gone](a.md#no-such-heading) and [lost](nowhere.md)\n',
        'orphan.md': '# Orphan\n'})
    done = sphinx(source, tmp_path / 'html')
    assert done.returncode != 0
    assert "local id not found in doc 'guide/a': 'no-such-heading'" in done.stderr
    assert 'nowhere.md' in done.stderr
    assert "orphan.md: WARNING: document isn't included in any toctree" in done.stderr


def github_anchor(heading: str) -> str:
    """Return the anchor GitHub (and MyST) gives a heading."""
    text = re.sub(r'[`*_]|\[([^\]]*)\]\([^)]*\)', r'\1', heading).strip().lower()
    text = re.sub(r'[^\w\- ]', '', text)
    return text.replace(' ', '-')


def anchors(path: pathlib.Path) -> set:
    """Return the anchors of a Markdown file's headings (outside code blocks)."""
    found, fenced = set(), False
    for line in path.read_text(encoding='utf-8').split('\n'):
        if line.lstrip().startswith(('```', '~~~')):
            fenced = not fenced
        elif not fenced and re.match(r'#{1,6} ', line):
            found.add(github_anchor(line.lstrip('#')))
    return found


def optional_pages() -> set:
    """Return the guide's pages that the index lists as optional (glob entries)."""
    index = (GUIDE / 'index.md').read_text(encoding='utf-8')
    return set(_GLOB_ENTRY.findall(index))


def readme_links():
    """Yield (line number, target) of the README's relative links and images."""
    for number, line in enumerate((ROOT / 'README.md').read_text().split('\n'), 1):
        for target in _LINK.findall(line) + _IMAGE.findall(line):
            if not re.match(r'[a-z]+:', target):
                yield number, target


def test_readme_links_resolve():
    links = list(readme_links())
    assert len(links) >= 20, 'the README links the guide'
    patterns = optional_pages()
    for number, target in links:
        path, _, anchor = target.partition('#')
        file = (ROOT / path) if path else ROOT / 'README.md'
        if not file.exists():
            # a page that arrives with its feature, listed as optional in the index
            assert file.parent == GUIDE and any(
                pathlib.PurePath(file.stem).match(p) for p in patterns), \
                f'README.md:{number}: {target} does not exist'
            continue
        if anchor:
            assert anchor in anchors(file), f'README.md:{number}: no heading #{anchor} in {path}'


def test_guide_pages_are_all_in_the_readme_table():
    linked = {target.partition('#')[0] for _, target in readme_links()}
    for page in GUIDE.glob('*.md'):
        if page.name != 'index.md':
            assert f'docs/guide/{page.name}' in linked, f'README does not link {page.name}'
