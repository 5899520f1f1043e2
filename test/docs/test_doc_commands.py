# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Every command block (```bash) of the README and the guide runs as written.

Each page's blocks run in order in one fresh folder that holds the
repository's ``config/``, ``examples/`` and ``benchmarks/`` and the
environment (``.venv``), with that environment's ``bin`` first on PATH as
``. .venv/bin/activate`` makes it, so blocks share what earlier blocks of
the page wrote (``runs/...``) and nothing is written into the repository.
A block fails the page when it exits non-zero (``bash -e``). Two-terminal
walk-throughs run their first terminal in the background, DDS kept to this
machine and to a domain of its own; every wait has a deadline. The comments
that say how a block runs are described in ``docblocks.py``; a page of the
guide joins by itself.
"""

import os
import pathlib
import random
import signal
import subprocess
import sys
import time

import pytest

import docblocks

ROOT = docblocks.ROOT
BIN = pathlib.Path(sys.executable).parent
SHARED = ('config', 'examples', 'benchmarks')
#: Seconds a foreground block, and a background block after Ctrl-C or when
#: waited for, may take.
BLOCK_TIMEOUT = 300.0
STOP_TIMEOUT = 60.0
WAIT_TIMEOUT = 180.0
VERBS = {'', 'skip', 'background', 'interrupt', 'wait', 'interrupt-after'}


def command_pages():
    """Return the pages that have command blocks."""
    return [page for page in docblocks.pages()
            if any(b.lang == 'bash' for b in docblocks.blocks(page))]


def environment() -> dict:
    """Return the environment of a shell with the package's environment active."""
    env = dict(os.environ)
    env['PATH'] = f'{BIN}{os.pathsep}{env.get("PATH", "")}'
    env['VIRTUAL_ENV'] = str(BIN.parent)
    env['ROS_DOMAIN_ID'] = str(random.randint(1, 100))
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['MPLBACKEND'] = 'Agg'
    env['PYTHONUNBUFFERED'] = '1'
    env.pop('PYTHONPATH', None)
    return env


class Shell:
    """One block run by bash in its own process group, its output in a file."""

    def __init__(self, block, work: pathlib.Path, env: dict, index: int):
        self.block = block
        self.log = work / f'.block-{index}.log'
        with open(self.log, 'wb') as out:
            self.process = subprocess.Popen(
                ['bash', '-e', '-o', 'pipefail', '-c', block.text], cwd=work, env=env,
                stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                start_new_session=True)

    def signal(self, number: int):
        """Send a signal to the block's processes, as a terminal's Ctrl-C does."""
        try:
            os.killpg(self.process.pid, number)
        except ProcessLookupError:
            pass

    def wait(self, timeout: float):
        """Return the exit status, or None (and kill it) when it takes longer."""
        try:
            return self.process.wait(timeout)
        except subprocess.TimeoutExpired:
            self.signal(signal.SIGKILL)
            self.process.wait()
            return None

    def report(self, what: str) -> str:
        """Return what happened and the end of the block's output."""
        output = self.log.read_text(errors='replace')[-4000:]
        return f'{self.block.where}: {what}\n--- block:\n{self.block.text}--- output:\n{output}'


def stop(shells, how: int, timeout: float):
    """Signal background shells (None: wait for them) and check how they end."""
    for shell in shells:
        if how is not None:
            shell.signal(how)
    for shell in shells:
        status = shell.wait(timeout)
        expected = (0,) if how is None else (0, 130)
        assert status in expected, shell.report(
            f'the background block ended with status {status} (expected {expected})'
            if status is not None else f'the background block did not end in {timeout:g} s')
    shells.clear()


@pytest.mark.parametrize('page', command_pages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_page_commands_run(page, tmp_path):
    work = tmp_path / 'repository'
    work.mkdir()
    for name in SHARED:
        (work / name).symlink_to(ROOT / name)
    (work / '.venv').symlink_to(BIN.parent)
    env = environment()
    background = []
    ran = 0
    try:
        for index, block in enumerate(docblocks.blocks(page)):
            if block.lang != 'bash':
                continue
            assert block.verb in VERBS, f'{block.where}: unknown doc-test comment'
            if block.verb == 'skip':
                assert len(block.argument) > 10, f'{block.where}: a skipped block says why'
                continue
            if block.verb == 'interrupt':
                assert background, f'{block.where}: nothing runs in the background'
                stop(background, signal.SIGINT, STOP_TIMEOUT)
            elif block.verb == 'wait':
                assert background, f'{block.where}: nothing runs in the background'
                stop(background, None, WAIT_TIMEOUT)
            shell = Shell(block, work, env, index)
            ran += 1
            if block.verb == 'background':
                background.append(shell)
                continue
            if block.verb == 'interrupt-after':
                seconds = float(block.argument)
                time.sleep(seconds)
                assert shell.process.poll() is None, shell.report(
                    f'ended within {seconds:g} s, before the Ctrl-C it shows')
                shell.signal(signal.SIGINT)
                status = shell.wait(STOP_TIMEOUT)
                assert status == 130, shell.report(f'exit status {status} after Ctrl-C')
                continue
            status = shell.wait(BLOCK_TIMEOUT)
            assert status == 0, shell.report(f'exit status {status}')
        assert not background, f'{page.name}: a background block is never stopped or waited for'
    finally:
        for shell in background:
            shell.signal(signal.SIGKILL)
            shell.process.wait()
    assert ran, f'{page.name}: no command block ran'
