# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Every command block (```bash) and Python example of the README and the guide runs as written.

The pages' blocks run in order (the README first) in one fresh folder that
holds the repository's ``config/``, ``examples/`` and ``benchmarks/`` and
the environment (``.venv``), with that environment's ``bin`` first on PATH
as ``. .venv/bin/activate`` makes it; nothing is written into the
repository. Each command of a block runs in ``bash -e -o pipefail`` and
fails the page when it exits non-zero. Pages share what earlier commands
wrote (``runs/...``): a command already run as written, with success, is
not run again while the files it names, and the files in the folders it
names, are as it left them (unless a live run is under way), so the first
run that several pages show costs once. Two-terminal
walk-throughs run their first terminal in the background, DDS kept to this
machine and to a domain of its own; every wait has a deadline. The comments
that say how a block runs are described in ``docblocks.py``; a page of the
guide joins by itself.
"""

import concurrent.futures
import os
import pathlib
import signal
import subprocess
import sys
import time
from typing import Optional

import docblocks
import pytest

ROOT = docblocks.ROOT
BIN = pathlib.Path(sys.executable).parent
SHARED = ('config', 'examples', 'benchmarks')
#: Seconds a foreground block, and a background block after Ctrl-C or when
#: waited for, may take.
BLOCK_TIMEOUT = 300.0
STOP_TIMEOUT = 60.0
STARTUP_TIMEOUT = 60.0
WAIT_TIMEOUT = 180.0
#: The blocks that run: commands, and Python examples (each as a script).
RUN = ('bash', 'python')
#: Pages run side by side (the machine's two cores), each lane in its own folder.
LANES = 2
#: A study or a benchmark command's work, in commands (a sweep: seconds, not a fraction).
HEAVY = 6
VERBS = {'', 'skip', 'background', 'interrupt', 'wait', 'interrupt-after'}


def command_pages():
    """Return the pages that have command blocks that run (not all skipped)."""
    return [page for page in docblocks.pages()
            if any(b.lang in RUN and b.verb != 'skip' for b in docblocks.blocks(page))]


def environment(domain: int) -> dict:
    """Return the environment of a shell with the package's environment active."""
    env = dict(os.environ)
    env['PATH'] = f'{BIN}{os.pathsep}{env.get("PATH", "")}'
    env['VIRTUAL_ENV'] = str(BIN.parent)
    env['ROS_DOMAIN_ID'] = str(domain)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['MPLBACKEND'] = 'Agg'
    env['PYTHONUNBUFFERED'] = '1'
    env.pop('PYTHONPATH', None)
    return env


def python_script(text: str) -> str:
    """Return the shell command that runs a Python block as a script."""
    return f"python - <<'CFEM_DOC_PYTHON'\n{text}CFEM_DOC_PYTHON\n"


def commands(text: str) -> list:
    """Return a block's commands: its lines, continuations joined, comments left out."""
    found, current = [], ''
    for line in text.split('\n'):
        current += line
        if current.endswith('\\'):
            current = current[:-1] + ' '
            continue
        if current.strip() and not current.strip().startswith('#'):
            found.append(current.strip())
        current = ''
    return found


def files_named(command: str, work: pathlib.Path) -> tuple:
    """
    Return the size and time of each file a command names (what it read or wrote).

    A folder it names (a sweep's, a figures' folder) stands for the files
    under it.
    """
    state = []
    for word in command.replace('=', ' ').split():
        path = work / word.strip('\'"')
        if word[:1] in '-|>' or path.is_symlink() or path == work \
                or not path.resolve().is_relative_to(work.resolve()):
            continue
        inside = sorted(path.rglob('*')) if path.is_dir() else [path]
        for file in inside:
            if file.is_file() and not file.is_symlink():
                info = file.stat()
                state.append((str(file.relative_to(work)), info.st_size, info.st_mtime_ns))
    return tuple(state)


def folders_named(text: str, work: pathlib.Path) -> tuple:
    """Return the state of the folders of the paths a block names (where it writes)."""
    folders = {str(pathlib.PurePath(word.strip('\'"')).parent)
               for word in text.replace('=', ' ').split() if '/' in word and word[:1] not in '-|>'}
    return files_named(' '.join(sorted(folders)), work)


class Shell:
    """A block, or one command of it, run by bash in its own process group."""

    def __init__(self, block, work: pathlib.Path, env: dict, text: Optional[str] = None):
        self.block = block
        self.text = block.text if text is None else text
        self.log = work / '.logs' / f'{time.monotonic_ns()}.log'
        self.log.parent.mkdir(exist_ok=True)
        with open(self.log, 'wb') as out:
            self.process = subprocess.Popen(
                ['bash', '-e', '-o', 'pipefail', '-c', self.text], cwd=work, env=env,
                stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                start_new_session=True)

    def shows(self, text: str, timeout: float) -> bool:
        """
        Wait until the block has printed text (any output when text is empty).

        Return False if it never does within timeout, or ends without it.
        """
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            ended = self.process.poll() is not None
            if self.log.stat().st_size > 0 and text in self.log.read_text(errors='replace'):
                return True
            if ended:
                return False
            time.sleep(0.05)
        return False

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
        return f'{self.block.where}: {what}\n--- ran:\n{self.text}\n--- output:\n{output}'


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


def run_page(page: pathlib.Path, work: pathlib.Path, env: dict, done: set):
    """Run a page's command blocks in work; raise AssertionError on the first failure."""
    background = []
    ran = 0
    try:
        for block in docblocks.blocks(page):
            if block.lang not in RUN:
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
            if block.verb == 'background':
                shell = Shell(block, work, env)
                background.append(shell)
                ran += 1
                # the user turns to the second terminal once the first shows it is
                # ready: the directive's text, or anything without one
                ready = block.argument
                assert shell.shows(ready, STARTUP_TIMEOUT), shell.report(
                    f'did not print {ready!r} in {STARTUP_TIMEOUT:g} s' if ready
                    else f'printed nothing in {STARTUP_TIMEOUT:g} s')
                continue
            if block.verb == 'interrupt-after':
                before = folders_named(block.text, work)
                shell = Shell(block, work, env)
                ran += 1
                seconds = float(block.argument)
                # the seconds count from its first write beside a file it names (its
                # start-up takes longer on a busy machine), at most STARTUP_TIMEOUT on
                deadline = time.monotonic() + STARTUP_TIMEOUT
                while (folders_named(block.text, work) == before
                       and shell.process.poll() is None and time.monotonic() < deadline):
                    time.sleep(0.05)
                time.sleep(seconds)
                assert shell.process.poll() is None, shell.report(
                    f'ended within {seconds:g} s, before the Ctrl-C it shows')
                shell.signal(signal.SIGINT)
                status = shell.wait(STOP_TIMEOUT)
                assert status == 130, shell.report(f'exit status {status} after Ctrl-C')
                continue
            if block.lang == 'python':
                ran += 1
                shell = Shell(block, work, env, python_script(block.text))
                status = shell.wait(BLOCK_TIMEOUT)
                assert status == 0, shell.report(f'exit status {status}')
                continue
            for command in commands(block.text):
                ran += 1
                named = files_named(command, work)
                # a command that acts on a live run, or names no file it read or
                # wrote, runs every time
                if named and not background and (command, named) in done:
                    continue
                shell = Shell(block, work, env, command)
                status = shell.wait(BLOCK_TIMEOUT)
                assert status == 0, shell.report(f'exit status {status}')
                done.add((command, files_named(command, work)))
        assert not background, f'{page.name}: a background block is never stopped or waited for'
    finally:
        for shell in background:
            shell.signal(signal.SIGKILL)
            shell.process.wait()
    assert ran, f'{page.name}: no command block ran'


def lanes(pages: list, count: int) -> list:
    """
    Split the pages into lanes that run side by side, each in its own folder.

    The README goes first; then, the pages with the most work first, a page
    joins the lane that ends up with the least work, counted in distinct
    commands (a command that a lane's other pages show runs there once), a
    study or a benchmark as several. Each lane runs its pages in the order
    of ``pages``.
    """
    def work(shown: set) -> int:
        return sum(HEAVY if any(w in c.split() for w in ('sweep', 'envelope', 'report'))
                   or 'benchmarks/' in c else 1 for c in shown)

    def shows(page) -> set:
        return {c for b in docblocks.blocks(page) if b.lang == 'bash' and b.verb != 'skip'
                for c in commands(b.text)}

    found = [[] for _ in range(count)]
    shown = [set() for _ in range(count)]
    readme = [p for p in pages if p.name == 'README.md']
    rest = sorted((p for p in pages if p not in readme), key=lambda p: -work(shows(p)))
    for page in readme + rest:
        mine = shows(page)
        lane = min(range(count), key=lambda k: work(shown[k] | mine))
        found[lane].append(page)
        shown[lane] |= mine
    return [sorted(lane, key=pages.index) for lane in found]


def run_lane(pages: list, work: pathlib.Path, domain: int) -> dict:
    """Run pages one after the other in work; return each page's failure (None if none)."""
    for name in SHARED:
        (work / name).symlink_to(ROOT / name)
    (work / '.venv').symlink_to(BIN.parent)
    env, done, failures = environment(domain), set(), {}
    for page in pages:
        try:
            run_page(page, work, env, done)
            failures[page] = None
        except AssertionError as err:
            failures[page] = str(err)
    return failures


@pytest.fixture(scope='module')
def outcomes(tmp_path_factory):
    """Every page's failure (None if none), the pages run in two lanes side by side."""
    split = lanes(command_pages(), LANES)
    folders = [tmp_path_factory.mktemp(f'lane{k}') for k in range(len(split))]
    # a DDS domain of its own per lane: the ones after this process's (conftest.py)
    first = int(os.environ['ROS_DOMAIN_ID']) + 1
    domains = range(first, first + len(split))
    with concurrent.futures.ThreadPoolExecutor(len(split)) as pool:
        results = list(pool.map(run_lane, split, folders, domains))
    return {page: failure for result in results for page, failure in result.items()}


def test_skipped_blocks_say_why():
    for page in docblocks.pages():
        for block in docblocks.blocks(page):
            if block.verb == 'skip':
                assert len(block.argument) > 10, f'{block.where}: a skipped block says why'


@pytest.mark.parametrize('page', command_pages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_page_commands_run(page, outcomes):
    failure = outcomes[page]
    assert failure is None, failure


def test_a_command_s_state_is_its_files_and_the_files_in_its_folders(tmp_path):
    (tmp_path / 'config').symlink_to(ROOT / 'config')
    (tmp_path / 'runs' / 'sweep').mkdir(parents=True)
    table = tmp_path / 'runs' / 'sweep' / 'summary.parquet'
    table.write_bytes(b'12')
    command = 'cfem-sim plot runs/sweep -o runs/figures --overwrite'
    before = files_named(command, tmp_path)
    assert [name for name, _, _ in before] == ['runs/sweep/summary.parquet']
    (tmp_path / 'runs' / 'figures').mkdir()
    (tmp_path / 'runs' / 'figures' / 'a.png').write_bytes(b'png')
    assert len(files_named(command, tmp_path)) == 2   # what it wrote counts too
    table.write_bytes(b'123')
    assert files_named(command, tmp_path)[0] != before[0]   # a changed input: runs again
    # the repository's folders (links), the work folder and paths outside it are no state
    assert files_named('cfem-sim check config/store_separation.yaml . / ..', tmp_path) == ()
    # an interrupted run's first write is a new file beside the one it names
    run = 'cfem-sim run config/double_pendulum.yaml -o runs/figures/stopped.mcap'
    started = folders_named(run, tmp_path)
    (tmp_path / 'runs' / 'figures' / '.stopped.mcap.partial-1').write_bytes(b'')
    assert folders_named(run, tmp_path) != started


def test_lanes_keep_every_page_once():
    pages = command_pages()
    split = lanes(pages, LANES)
    assert sorted(p for lane in split for p in lane) == sorted(pages)
    assert split[0][0].name == 'README.md'
