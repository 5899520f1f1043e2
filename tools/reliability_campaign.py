# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A tester's reliability campaign of ``cfem-sim``: hostile inputs, damaged files, interrupts.

Usage: ``python test/reliability_campaign.py [--scale S] [--seed N] [--out DIR]``.
Prints, per family of cases (scenarios, CSV tables, sweep files, damaged
recordings through every reading command, special files, command-line
values, full disks, interrupts of runs and sweeps), how many commands ran
and how many broke a rule: a traceback, a hang (60 s), an exit status
outside the documented ones, an exit 2 without exactly one ``ERROR:``
line, a numpy warning, an output lost or unreadable, a recovered message
that is not one of the original's. Every defect is listed with its
command. Not part of ``make test`` (it takes tens of minutes).
"""

import argparse
import collections
import contextlib
import copy
import io
import math
import os
import pathlib
import random
import resource
import signal
import struct
import subprocess
import sys
import tempfile
import time
import traceback

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / 'test'))

from cfem_ros import cli  # noqa: E402
from mcap.reader import make_reader  # noqa: E402
from recordings import read_mcap, rewrite_zstd, top_records  # noqa: E402
import yaml  # noqa: E402

CONFIG = ROOT / 'config'
CFEM_SIM = [str(pathlib.Path(sys.executable).parent / 'cfem-sim')]   # the console script
ALLOWED = {'run': {0, 1, 2, 130, 143}, 'sweep': {0, 1, 2, 130, 143}}
TOTALS = collections.Counter()
DEFECTS = collections.defaultdict(list)
#: (family, exit status) -> commands: what the commands did, beside what broke a rule.
STATUSES = collections.Counter()


class Hang(BaseException):
    """A command that did not return within its time."""


def _alarm(signum, frame):
    raise Hang()


def defect(family: str, command: str, problem: str):
    """Record a broken rule that a family found by itself."""
    DEFECTS[family].append((command[:300], problem[:300]))


def call(family: str, argv, timeout: int = 60, check_output=None, allowed=None) -> tuple:
    """Run cfem-sim in this process; record a defect if a rule is broken; return (rc, out, err)."""
    out, err = io.StringIO(), io.StringIO()
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(timeout)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            status = cli.main([str(a) for a in argv])
    except Hang:
        status = 'hang'
    except SystemExit as end:   # argparse's usage errors
        status = end.code
    except BaseException:  # noqa: B902 - the campaign counts every escape
        status = 'traceback'
        err.write(traceback.format_exc())
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    judge(family, argv, status, out.getvalue(), err.getvalue(), check_output, allowed)
    return status, out.getvalue(), err.getvalue()


def judge(family, argv, status, out, err, check_output=None, allowed=None):
    TOTALS[family] += 1
    STATUSES[family, str(status)] += 1
    command = str(argv[0]) if argv else ''
    if allowed is None:
        allowed = ALLOWED.get(command, {0, 1, 2} if command in ('summarize', 'recover')
                              else {0, 2})
    problem = None
    if status in ('hang', 'traceback') or 'Traceback' in err:
        problem = f'{status}: {err.strip().splitlines()[-1] if err.strip() else ""}'
    elif status not in allowed:
        problem = f'exit {status}'
    elif status == 2 and command != 'summarize' and (
            not err.startswith('ERROR: ') or err.count('ERROR: ') != 1):
        problem = f'exit 2 without one ERROR line: {err[:200]!r}'
    elif 'Warning:' in err and 'WARNING:' not in err:
        problem = f'a Python warning: {err[:200]!r}'
    elif check_output is not None:
        problem = check_output(status, out, err)
    if problem:
        DEFECTS[family].append((' '.join(map(str, argv))[:300], problem[:300]))


def messages_of(path):
    with open(path, 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        reader.get_summary()
        return [(c.topic, m.log_time, bytes(m.data)) for _, c, m in reader.iter_messages()]


def readable(path) -> bool:
    try:
        read_mcap(path)
    except Exception:  # noqa: B902 - any failure is an unreadable output
        return False
    return True


# ------------------------------------------------------------------ recordings

def make_recordings(folder: pathlib.Path) -> dict:
    cfem = folder / 'run.mcap'
    with contextlib.redirect_stdout(io.StringIO()):
        assert cli.main(['run', str(CONFIG / 'store_separation.yaml'), '-o', str(cfem),
                         '--rate', '500', '--duration', '0.5']) == 0
    zstd = folder / 'zstd.mcap'
    rewrite_zstd(cfem, zstd, chunk_size=16 * 1024)
    return {'cfem': cfem, 'zstd': zstd}


def mutate(data: bytes, rng: random.Random) -> tuple:
    kind = rng.choice(['flip', 'flips', 'truncate', 'insert', 'delete', 'duplicate',
                       'swap', 'length', 'body'])
    if kind in ('flip', 'flips'):
        out = bytearray(data)
        for _ in range(1 if kind == 'flip' else rng.randint(2, 8)):
            out[rng.randrange(len(out))] ^= rng.randint(1, 255)
        return kind, bytes(out)
    if kind == 'truncate':
        return kind, data[:rng.randrange(len(data))]
    if kind == 'insert':
        at = rng.randrange(len(data))
        return kind, data[:at] + os.urandom(rng.randint(1, 32)) + data[at:]
    spans = top_records(data)
    k = rng.randrange(len(spans) - 1)
    (start, end), (_, after) = spans[k], spans[k + 1]
    if kind == 'delete':
        return kind, data[:start] + data[end:]
    if kind == 'duplicate':
        return kind, data[:end] + data[start:end] + data[end:]
    if kind == 'swap':
        return kind, data[:start] + data[end:after] + data[start:end] + data[after:]
    if kind == 'length':
        value = rng.choice([0, 1, rng.randrange(1 << 64), end - start + rng.randint(-20, 20)])
        return kind, data[:start + 1] + struct.pack('<Q', max(0, value)) + data[start + 9:]
    return kind, data[:start + 9] + os.urandom(end - start - 9) + data[end:]


def damaged_recordings(folder, recordings, metrics, count, rng, plot_every=25):
    from cfem_ros.study.summarize import summarize_file
    originals = {name: set(messages_of(path)) for name, path in recordings.items()}
    for name, path in recordings.items():
        data = path.read_bytes()
        cases = []
        stride = max(1, len(data) // count)
        for position in range(0, len(data), stride):    # one flipped byte at every stride
            copy_ = bytearray(data)
            copy_[position] ^= 0xFF
            cases.append((f'byte {position}', bytes(copy_)))
        for _ in range(count):
            cases.append(mutate(data, rng))
        for k, (kind, damaged) in enumerate(cases):
            bad = folder / f'{name}_bad.mcap'
            bad.write_bytes(damaged)
            family = f'damaged recordings ({name})'
            call(family, ['info', bad])
            call(family, ['compare', path, bad])
            call(family, ['run', CONFIG / 'store_separation.yaml', '-o', folder / 'replay.mcap',
                          '--inputs', bad, '--duration', '0.01', '--overwrite'])
            if k % plot_every == 0:
                call(family, ['plot', bad, '-o', folder / 'figures'])
            fixed = folder / f'{name}_fixed.mcap'
            if fixed.exists():
                fixed.unlink()

            def recovered(status, out, err, fixed=fixed, original=originals[name]):
                if status != 0:
                    return 'output left after a failure' if fixed.exists() else None
                if not readable(fixed):
                    return 'recovered file not readable by the indexed reader and decoder'
                if not set(messages_of(fixed)) <= original:
                    return 'recovered a message that is not one of the original'
                return None
            call(family, ['recover', bad, '-o', fixed], check_output=recovered)
            TOTALS[family + ': summarize rows'] += 1
            try:
                row = summarize_file(str(bad), metrics)
                if row['status'] not in ('ok', 'failed') or '\n' in row['message']:
                    DEFECTS[family].append((f'summarize {bad}', f'row {row["status"]}'))
            except BaseException as err:  # noqa: B902
                DEFECTS[family].append((f'summarize {bad}', f'{type(err).__name__}: {err}'))


# ------------------------------------------------------------------ scenarios

NASTY = [1e308, -1e308, 1e300, -1e300, 1e9, -1e9, 1e-320, 0, -0.0, '1:30', '0x10', '010',
         '0b11', '1e5', '.nan', '.inf', '-.inf', 'x', [], {}, None, True, [1e308] * 3,
         [0, 0, 0], [1, 2], 10 ** 400, '1_000']


def leaves(node, path=()):
    if isinstance(node, dict):
        for key, value in node.items():
            yield from leaves(value, path + (key,))
    elif isinstance(node, list):
        for i, value in enumerate(node):
            yield from leaves(value, path + (i,))
    yield path


def set_at(document, path, value):
    node = document
    for key in path[:-1]:
        node = node[key]
    if path:
        node[path[-1]] = value


def dump(document) -> str:
    text = yaml.safe_dump(document, sort_keys=False)
    for token in ('1:30', '0x10', '010', '0b11', '1e5', '.nan', '.inf', '-.inf', '1_000'):
        text = text.replace(f"'{token}'", token)   # as a user would type them
    return text


def scenarios(folder, count, rng):
    files = sorted(CONFIG.glob('*.yaml')) + sorted((CONFIG / 'joints').glob('*.yaml'))
    files = [f for f in files if 'params' not in f.name]
    for k in range(count):
        base = yaml.safe_load(rng.choice(files).read_text())
        document = copy.deepcopy(base)
        for _ in range(rng.randint(1, 3)):
            paths = [p for p in leaves(document) if p]
            if paths:
                set_at(document, rng.choice(paths), copy.deepcopy(rng.choice(NASTY)))
        duration = document.get('duration', 1.0)
        if type(duration) in (int, float) and abs(duration) < 1e300:
            document['duration'] = min(float(duration), 0.2)   # short runs
        path = folder / f'scenario_{k}.yaml'
        path.write_text(dump(document))
        status, _, err = call('scenarios', ['check', path])
        if status == 0:
            out = folder / 'scenario_run.mcap'
            run_status, _, run_err = call('scenarios', ['run', path, '-o', out, '--overwrite'])
            if run_status == 1 and 'at t = 0 s' in run_err and 'WARNING' not in err:
                DEFECTS['scenarios'].append((f'check {path}',
                                             'check accepted, run fails at t = 0: '
                                             + run_err.strip()[-160:]))
            if run_status in (0, 1) and not readable(out):
                DEFECTS['scenarios'].append((f'run {path}', 'recording not readable'))


def csv_tables(folder, rng):
    rows = ['0,0,0,0,0,0,0,1', '0.5,1,0,0,0,0,0,1', '1,2,0,0,0,0,0,1']
    header = 't,x,y,z,qx,qy,qz,qw'
    bodies = [('\ufeff' + header, rows), (header, rows), ('qw,qx,qy,qz,t,x,y,z', [
        '1,0,0,0,0,0,0,0', '1,0,0,0,0.5,1,0,0', '1,0,0,0,1,2,0,0'])]
    odd = ['-1e308', '1e308', 'nan', 'inf', '', 'x', '1e-320', '0x10', '1:30', '9' * 400]
    cases = list(bodies)
    for _ in range(120):
        changed = [r.split(',') for r in rows]
        i, j = rng.randrange(3), rng.randrange(8)
        changed[i][j] = rng.choice(odd)
        cases.append((rng.choice([header, '\ufeff' + header, '', 't,x,y']),
                      [','.join(r) for r in changed]))
    cases += [(header, ['0,0,0,0,0,0,0,1', '1e-300,0,0,0,0,0,0,1']),
              (header, ['0,0,0,0,0,0,0,1', '0,0,0,0,0,0,0,1']), (header, []),
              (header, ['0,0,0,0,0,0,0,1'] * 2), ('', ['\x00\x01\x02'])]
    for k, (head, lines) in enumerate(cases):
        table = folder / f'table_{k}.csv'
        table.write_text('\n'.join(([head] if head else []) + lines) + '\n')
        document = {'name': 'carrier', 'duration': 0.2, 'dt': 0.001, 'bodies': {
            'jet': {'fixed': False, 'motion': {'table': table.name}},
            'store': {'mass': 100.0, 'inertia': [1.0, 2.0, 2.0], 'position': [0, 0, 1.0]}}}
        scenario = folder / f'table_{k}.yaml'
        scenario.write_text(yaml.safe_dump(document))
        status, _, _ = call('CSV tables', ['check', scenario])
        if status == 0:
            call('CSV tables', ['run', scenario, '-o', folder / 'table.mcap', '--overwrite'])


def sweep_files(folder, rng, runs_ok=3):
    base = yaml.safe_load((CONFIG / 'store_separation.yaml').read_text())
    base['duration'] = 0.3
    (folder / 'base.yaml').write_text(yaml.safe_dump(base))
    good = {'scenario': 'base.yaml', 'runs': 2, 'seed': 1, 'rate_hz': 100,
            'vary': {'bodies.store.mass': {'uniform': [900, 910]}},
            'metrics': {'at': [{'time': 0.1, 'body': 'store'}]}}
    values = [0, -1, 10 ** 12, 1.5, 'x', None, 1e9, -1e308, 1e308, [], {}, '1:30', '0x10']
    keys = [('runs',), ('seed',), ('rate_hz',), ('vary', 'bodies.store.mass', 'uniform'),
            ('vary', 'bodies.store.mass'), ('metrics', 'at', 0, 'time'),
            ('metrics', 'at', 0, 'body')]
    cases = []
    for _ in range(100):
        document = copy.deepcopy(good)
        set_at(document, rng.choice(keys), copy.deepcopy(rng.choice(values)))
        cases.append(document)
    extra = copy.deepcopy(good)
    extra['vary'] = {'bodies.store.' + 'x' * 500: {'uniform': [1, 2]}}
    cases.append(extra)
    extra = copy.deepcopy(good)
    extra['metrics']['at'] *= 2
    cases.append(extra)
    extra = copy.deepcopy(good)
    extra['vary']['bodies.store.mass'] = {'uniform': [-1e308, 1e308]}
    cases.append(extra)
    accepted = 0
    for k, document in enumerate(cases):
        path = folder / f'sweep_{k}.yaml'
        path.write_text(dump(document))
        from cfem_ros.core.errors import CfemError
        from cfem_ros.study import load_sweep
        try:
            load_sweep(str(path))
            ok = True
        except CfemError:
            ok = False
        except BaseException as err:  # noqa: B902
            DEFECTS['sweep files'].append((f'load_sweep {path}', repr(err)[:200]))
            ok = False
        TOTALS['sweep files'] += 1
        if not ok:
            call('sweep files', ['sweep', path, '-o', folder / f'sweep_out_{k}', '--workers', '1'])
        elif accepted < runs_ok:
            accepted += 1
            call('sweep files', ['sweep', path, '-o', folder / f'sweep_out_{k}', '--workers', '1',
                                 '--runs', '1'], timeout=300)


# ------------------------------------------------------------------ special files

def special_files(folder, recordings, metrics_file):
    fifo = folder / 'fifo.mcap'
    os.mkfifo(fifo)
    loop = folder / 'loop.mcap'
    os.symlink(loop, loop)
    dangling = folder / 'dangling.mcap'
    os.symlink(folder / 'nowhere', dangling)
    folder_path = folder / 'adir'
    folder_path.mkdir()
    empty = folder / 'empty.mcap'
    empty.write_bytes(b'')
    sources = [fifo, loop, dangling, folder_path, empty, '/dev/null', '/dev/zero',
               folder / 'missing.mcap', '']
    good = recordings['cfem']
    for source in sources:
        family = 'special files (inputs)'
        call(family, ['info', source])
        call(family, ['compare', good, source])
        call(family, ['compare', source, good])
        call(family, ['recover', source, '-o', folder / 'fixed_special.mcap'])
        call(family, ['plot', source, '-o', folder / 'fig_special'])
        call(family, ['run', CONFIG / 'store_separation.yaml', '-o', folder / 'x.mcap',
                      '--inputs', source, '--overwrite'])
        call(family, ['check', source])
        call(family, ['play', source])
        call(family, ['summarize', source, '--metrics', metrics_file, '-o',
                      folder / 'summary.parquet'])
    regular = folder / 'regular.mcap'
    regular.write_bytes(b'keep me')
    outputs = [fifo, '/dev/null', '/dev/zero', folder_path, str(folder_path) + '/', '',
               regular / 'x.mcap', folder / 'new' / 'deep' / 'x.mcap',
               folder / 'sub' / '..' / 'dotdot.mcap', dangling]
    for output in outputs:
        family = 'special files (outputs)'
        for overwrite in ([], ['--overwrite']):
            call(family, ['run', CONFIG / 'store_separation.yaml', '-o', output,
                          '--duration', '0.05', *overwrite])
        call(family, ['recover', good, '-o', output])
    if regular.read_bytes() != b'keep me':
        DEFECTS['special files (outputs)'].append(('regular file', 'changed'))
    if not os.path.exists('/dev/null') or not os.path.exists('/dev/zero'):
        DEFECTS['special files (outputs)'].append(('/dev/null', 'replaced'))


def command_line_values(folder):
    scenario = CONFIG / 'store_separation.yaml'
    values = ['0', '-1', 'nan', 'inf', '-inf', '1e-300', '1e300', '1e6', 'x', '', '1e5']
    out = folder / 'cl.mcap'
    for option in ('--rate', '--duration', '--dt', '--max-samples', '--max-gb'):
        for value in values:
            call('command-line values', ['run', scenario, '-o', out, option, value,
                                         '--overwrite', *(['--duration', '0.05']
                                                          if option != '--duration' else [])])
    good = folder / 'good_for_play.mcap'
    if not good.exists():
        with contextlib.redirect_stdout(io.StringIO()):
            cli.main(['run', str(scenario), '-o', str(good), '--duration', '0.05'])
    for option in ('--rate', '--wait', '--delay'):
        for value in values:
            call('command-line values', ['play', good, option, value, '--topics', '/none'])
    for remap in ('nothing', ':=', '/a:=', '/a:=//bad', '/a:=/b c', '/a:=1x', '/a:=/fine'):
        call('command-line values', ['play', good, '--remap', remap, '--topics', '/none'])
    for workers in ('0', '-1', 'x'):
        call('command-line values', ['sweep', CONFIG / 'sweeps' / 'store_separation_sweep.yaml',
                                     '-o', folder / 'sw', '--workers', workers])
    for runs in ('0', '-5', '1000000000000', 'x'):
        call('command-line values', ['sweep', CONFIG / 'sweeps' / 'store_separation_sweep.yaml',
                                     '-o', folder / 'sw', '--runs', runs, '--workers', '1'])
    for argv in (['compare', good, good, '--map', 'x'], ['compare', good, good, '--map', '/a=b'],
                 ['recover', good, '-o', good], ['run', scenario, '-o', scenario],
                 ['nosuchcommand'], [], ['run'], ['check']):
        call('command-line values', argv)


# ------------------------------------------------------------------ subprocesses

def subprocess_case(family, argv, *, limit=None, signal_after=None, sig=signal.SIGINT,
                    timeout=300, allowed=None, check=None):
    def limits():
        if limit is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    process = subprocess.Popen([*CFEM_SIM, *map(str, argv)], preexec_fn=limits,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if signal_after is not None:
        time.sleep(signal_after)
        process.send_signal(sig)
    try:
        out, err = process.communicate(timeout=timeout)
        status = process.returncode
    except subprocess.TimeoutExpired:
        process.kill()
        out, err = process.communicate()
        status = 'hang'
    TOTALS[family] += 1
    problem = None
    if status == 'hang' or 'Traceback' in err:
        problem = f'{status}: {err.strip()[-200:]}'
    elif allowed is not None and status not in allowed:
        problem = f'exit {status}: {err.strip()[-200:]}'
    elif check is not None:
        problem = check(status, out, err)
    if problem:
        DEFECTS[family].append((' '.join(map(str, argv))[:200] + (
            f' (signal after {signal_after:.2f} s)' if signal_after is not None else '')
            + (f' (file size limit {limit})' if limit else ''), problem[:300]))
    return status, out, err


def full_disks(folder, rng, count):
    scenario = CONFIG / 'store_separation.yaml'
    whole = folder / 'whole.mcap'
    with contextlib.redirect_stdout(io.StringIO()):
        cli.main(['run', str(scenario), '-o', str(whole), '--rate', '1000'])
    size = whole.stat().st_size
    cut = folder / 'cut.mcap'
    cut.write_bytes(whole.read_bytes()[:size * 2 // 3])
    for k in range(count):
        limit = rng.randint(1000, size)
        out = folder / f'full_{k}.mcap'
        out.write_bytes(b'previous')

        def run_check(status, stdout, err, out=out):
            leftovers = [p for p in folder.iterdir() if '.partial-' in p.name]
            if leftovers:
                return f'partial files left: {leftovers}'
            if status == 1 and out.read_bytes() != b'previous':
                return 'the existing output was changed'
            if status == 0 and not readable(out):
                return 'output not readable'
            if status == 1 and err.count('ERROR: ') != 1:
                return 'not one ERROR line'
            return None
        subprocess_case('full disks (run)', ['run', scenario, '-o', out, '--rate', '1000',
                                             '--overwrite'], limit=limit, allowed={0, 1},
                        check=run_check)
        fixed = folder / f'full_fixed_{k}.mcap'

        def recover_check(status, stdout, err, fixed=fixed):
            if status == 1 and fixed.exists():
                return 'partial recovered file left'
            if status == 0 and not readable(fixed):
                return 'recovered file not readable'
            return None
        subprocess_case('full disks (recover)', ['recover', cut, '-o', fixed],
                        limit=rng.randint(1000, size), allowed={0, 1}, check=recover_check)


def interrupts(folder, rng, count, sweeps):
    scenario = CONFIG / 'store_separation.yaml'
    for k in range(count):
        out = folder / f'int_{k}.mcap'
        existing = k % 2 == 0
        if existing:
            out.write_bytes(b'previous')
        sig = rng.choice([signal.SIGINT, signal.SIGTERM, signal.SIGKILL])
        after = rng.uniform(0.2, 4.0)

        def check(status, stdout, err, out=out, sig=sig, existing=existing):
            if sig == signal.SIGKILL:
                partial = [p for p in folder.iterdir()
                           if p.name.startswith(f'.{out.name}.partial')]
                if existing and out.read_bytes() != b'previous' and not readable(out):
                    return 'the existing output was damaged by a kill'
                for p in partial:
                    fixed = folder / f'{p.name}.fixed.mcap'
                    with contextlib.redirect_stdout(io.StringIO()):
                        rc = cli.main(['recover', str(p), '-o', str(fixed)])
                    if rc not in (0, 2) or (rc == 0 and not readable(fixed)):
                        return f'recover of the partial file gave {rc}'
                    p.unlink()
                    # its name holds '.partial-': left, it read as the next case's leftover
                    fixed.unlink(missing_ok=True)
                return None
            if status not in (0, 2, 128 + sig, 1):
                return f'exit {status}'
            if status in (0, 128 + sig) and out.exists() and out.read_bytes() != b'previous' \
                    and not readable(out):
                return 'output not readable'
            if [p for p in folder.iterdir() if '.partial-' in p.name]:
                return 'partial file left'
            return None
        subprocess_case('interrupts (run)', ['run', scenario, '-o', out, '--rate', '2000',
                                             '--duration', '3', '--overwrite'],
                        signal_after=after, sig=sig, check=check)
    sweep = CONFIG / 'sweeps' / 'store_separation_sweep.yaml'
    for k in range(sweeps):
        outdir = folder / f'sweep_int_{k}'
        after = rng.uniform(3.0, 25.0)
        sig = rng.choice([signal.SIGINT, signal.SIGTERM])
        subprocess_case('interrupts (sweep)', ['sweep', sweep, '-o', outdir, '--workers', '2',
                                               '--runs', '3'], signal_after=after, sig=sig,
                        allowed={0, 1, 130, 143})
        subprocess_case('interrupts (sweep)', ['sweep', sweep, '-o', outdir, '--workers', '2',
                                               '--runs', '3'], allowed={0, 1})


def _subfolder(folder, name):
    path = folder / name
    path.mkdir(exist_ok=True)
    return path


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--scale', type=float, default=1.0, help='multiplies the case counts')
    parser.add_argument('--seed', type=int, default=20261124)
    parser.add_argument('--only', nargs='*', help='families to run (default all)')
    parser.add_argument('--deadline', type=float, default=math.inf,
                        help='start no family after this time (seconds since the epoch)')
    args = parser.parse_args()
    rng = random.Random(args.seed)
    # the nodes' DDS domain: 215 to 232, never a test's (test/conftest.py: 1 to 101)
    os.environ.setdefault('ROS_DOMAIN_ID', str(random.Random().randint(215, 232)))
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    n = lambda count: max(1, int(count * args.scale))  # noqa: E731
    started = time.monotonic()
    with tempfile.TemporaryDirectory() as tmp:
        folder = pathlib.Path(tmp)
        recordings = make_recordings(folder)
        metrics_file = folder / 'metrics.yaml'
        metrics_file.write_text(f'scenario: {CONFIG / "store_separation.yaml"}\nmetrics:\n'
                                '  at:\n    - {time: 0.1, body: store}\n')
        from cfem_ros.study import load_sweep
        metrics = load_sweep(str(metrics_file), runs=1).metrics
        families = {
            'recordings': lambda: damaged_recordings(folder, recordings, metrics, n(150), rng),
            'scenarios': lambda: scenarios(folder, n(300), rng),
            'csv': lambda: csv_tables(folder, rng),
            'sweeps': lambda: sweep_files(folder, rng),
            'special': lambda: special_files(folder, recordings, metrics_file),
            'values': lambda: command_line_values(folder),
            'disks': lambda: full_disks(folder, rng, n(10)),
            'interrupts': lambda: interrupts(folder, rng, n(24), n(3)),
        }
        from campaign_families import FAMILIES   # issue 41's kinds
        from campaign_round5 import FAMILIES as ROUND5   # issues 45 and 48 to 52
        from campaign_round6 import FAMILIES as ROUND6   # issues 45, 46, 48 and 49
        for name, family in {**FAMILIES, **ROUND5, **ROUND6}.items():
            families[name] = (lambda family=family, name=name: family(
                _subfolder(folder, name), call, defect, rng, n))
        for name, run in families.items():
            if args.only and name not in args.only or time.time() > args.deadline:
                continue
            begun = time.monotonic()
            try:
                run()
            except Exception:  # noqa: B902 - the campaign's own mistake: say so, go on
                print(f'[{name}: the campaign script failed]\n{traceback.format_exc()}',
                      file=sys.stderr, flush=True)
            print(f'[{name}: {time.monotonic() - begun:.0f} s; commands so far '
                  f'{sum(TOTALS.values())}, defects {sum(map(len, DEFECTS.values()))}]',
                  file=sys.stderr, flush=True)
            for family in sorted(TOTALS):
                print(f'  {family}: {TOTALS[family]} commands, '
                      f'{len(DEFECTS.get(family, []))} defects', file=sys.stderr, flush=True)
    from campaign_families import TOTAL
    from campaign_round5 import TOTAL as ROUND5_TOTAL
    TOTALS.update(TOTAL)
    TOTALS.update(ROUND5_TOTAL)
    print(f'reliability campaign, seed {args.seed}, {time.monotonic() - started:.0f} s')
    print(f'{"family":<45} {"commands":>9} {"defects":>8}')
    for family in sorted(TOTALS):
        print(f'{family:<45} {TOTALS[family]:>9} {len(DEFECTS.get(family, [])):>8}')
    print(f'{"total":<45} {sum(TOTALS.values()):>9} {sum(map(len, DEFECTS.values())):>8}')
    from campaign_round5 import STATUS as ROUND5_STATUS
    STATUSES.update(ROUND5_STATUS)
    for family in sorted(TOTALS):
        seen = ', '.join(f'{status}: {n}' for (f, status), n in sorted(STATUSES.items())
                         if f == family)
        print(f'  {family}: exit status {seen}')
    for family, items in sorted(DEFECTS.items()):
        for command, problem in items[:20]:
            print(f'DEFECT [{family}] {command}\n    {problem}')
    return 1 if DEFECTS else 0


if __name__ == '__main__':
    sys.exit(main())
