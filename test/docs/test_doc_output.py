# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The output that the README and the guide show for the first run is what the run prints."""

import pathlib
import re
import subprocess
import sys

import docblocks
import pytest

BIN = pathlib.Path(sys.executable).parent
FIRST_RUN = 'store_separation: '


def shown_outputs():
    """Yield the blocks that show the first run's output."""
    for page in docblocks.pages():
        for block in docblocks.blocks(page):
            if block.lang == '' and block.text.startswith(FIRST_RUN):
                yield block


def matches(shown: str, printed: str) -> bool:
    """Return whether a shown line matches a printed one, '...' standing for any text."""
    pattern = '.*'.join(re.escape(part) for part in shown.split('...'))
    return re.fullmatch(pattern, printed) is not None


@pytest.fixture(scope='module')
def printed(tmp_path_factory):
    """Run the first run and return what it prints (the recording's path as shown)."""
    work = tmp_path_factory.mktemp('first_run')
    (work / 'config').symlink_to(docblocks.ROOT / 'config')
    done = subprocess.run(
        [str(BIN / 'cfem-sim'), 'run', 'config/store_separation.yaml',
         '-o', 'runs/store_separation.mcap', '--overwrite'],
        cwd=work, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout.splitlines()


def test_the_first_run_is_shown_somewhere():
    assert [b.path.name for b in shown_outputs()].count('README.md') == 1


@pytest.mark.parametrize('block', list(shown_outputs()), ids=lambda b: b.where)
def test_shown_output_is_what_the_run_prints(block, printed):
    shown = block.text.rstrip('\n').split('\n')
    assert len(shown) == len(printed), (block.where, printed)
    for want, got in zip(shown, printed):
        assert matches(want, got), f'{block.where}: shows {want!r}, the run prints {got!r}'


def test_a_changed_number_would_not_match():
    assert matches('release pivot at t = ... s (angle)', 'release pivot at t = 0.28 s (angle)')
    assert not matches('recording: x.mcap (788 messages)', 'recording: x.mcap (789 messages)')
