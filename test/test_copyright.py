# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Every source file carries a copyright line and the license identifier."""

import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
SKIP = {'.venv', 'build', 'install', 'log', '.git'}


def sources():
    for path in sorted(ROOT.rglob('*.py')):
        if not SKIP.intersection(path.relative_to(ROOT).parts):
            yield path


@pytest.mark.copyright
@pytest.mark.linter
def test_copyright():
    missing = []
    files = list(sources())
    for path in files:
        head = path.read_text(encoding='utf-8').splitlines()[:5]
        if not (any(line.startswith('# Copyright ') for line in head)
                and '# SPDX-License-Identifier: Apache-2.0' in head):
            missing.append(str(path.relative_to(ROOT)))
    assert len(files) > 10, 'the scan found too few files to be looking in the right place'
    assert not missing, 'no copyright/license header in: ' + ', '.join(missing)
