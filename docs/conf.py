# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Sphinx configuration of the cfem_ros user guide (Markdown pages read by MyST).

``make docs`` builds it into ``docs/_build/html``; ``rosdoc2 build
--package-path .`` finds it through ``rosdoc2.yaml`` (``sphinx_sourcedir:
docs``). rosdoc2 executes this file from another folder, so nothing here
depends on where the file lies.
"""

import fnmatch
import posixpath
import re

project = 'cfem_ros'
author = 'the cfem_ros authors'
copyright = '2026, the cfem_ros authors'  # noqa: A001 (the name Sphinx reads)
release = '0.1.0'
version = '0.1'

extensions = ['myst_parser']
source_suffix = {'.md': 'markdown', '.rst': 'restructuredtext'}
root_doc = 'index'
master_doc = root_doc  # for rosdoc2's older Sphinx
exclude_patterns = ['_build', 'Thumbs.db', '.DS_Store']

# Headings up to level 3 get anchors, so that [text](page.md#a-heading)
# links are checked and resolved by MyST like any cross-reference.
myst_heading_anchors = 3
myst_enable_extensions = ['colon_fence', 'deflist']
# Every internal reference must resolve: a broken link is a warning, and
# the build treats warnings as errors (test/docs/test_guide_build.py).
nitpicky = True

html_theme = 'alabaster'
html_title = 'cfem_ros user guide'
html_static_path = []

# rosdoc2 reads these settings; plain Sphinx ignores them.
rosdoc2_settings = {
    'enable_breathe': False,
    'enable_exhale': False,
}


# Pages that come with their features are listed in toctrees as glob patterns
# that match only them (release-sequence[s], ...). Until such a page is
# present its pattern matches nothing, which is not a mistake: the entry is
# dropped before Sphinx reads the toctree. An explicit entry that names no
# page, and a page that is in no toctree, are still warnings.
_TOCTREE_START = re.compile(r'^\s*(?:(`{3,}|:{3,})\{toctree\}|\.\. toctree::)')
_GLOB_ENTRY = re.compile(r'^\s*(\S*\[[^\]]+\]\S*)\s*$')


def _drop_empty_globs(app, docname, source):
    """Remove the glob entries of toctrees that match no document."""
    folder = posixpath.dirname(docname)
    kept = []
    fence = None        # the toctree's closing fence (MyST), or '' in an rst toctree
    for line in source[0].split('\n'):
        start = _TOCTREE_START.match(line)
        if start:
            fence = start.group(1) or ''
        elif fence and line.strip() == fence:
            fence = None
        elif fence == '' and line.strip() and not line[:1].isspace():
            fence = None
        entry = _GLOB_ENTRY.match(line) if fence is not None and not start else None
        if entry:
            pattern = posixpath.normpath(posixpath.join(folder, entry.group(1)))
            if not fnmatch.filter(app.env.found_docs, pattern):
                continue
        kept.append(line)
    source[0] = '\n'.join(kept)


#: Files of the repository's root that a page of docs/ includes: a page's link to the
#: file (right on GitHub) is pointed at that page in the HTML guide.
ROOT_FILES = {'CHANGELOG.md': 'changelog.md'}


def _link_root_files(app, docname, source):
    """Point the links to the files of ROOT_FILES at the pages that include them."""
    folder = posixpath.dirname(docname)
    up = '../' * (folder.count('/') + 2 if folder else 1)   # docs/ is one below the root
    for name, page in ROOT_FILES.items():
        target = posixpath.relpath(page, folder or '.')
        source[0] = source[0].replace(f']({up}{name}', f']({target}')


def setup(app):
    """Register the optional toctree entries' filter and the root files' links."""
    app.connect('source-read', _drop_empty_globs)
    app.connect('source-read', _link_root_files)
