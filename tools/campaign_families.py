# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The reliability campaign's families of issue 41.

Contacts at step boundaries, study sizes, damaged study folders, tables of every column
type, studies on a full disk, the node's clock and stamps.

Each family takes the campaign's ``call`` (a cfem-sim command in this process, judged
by the campaign's rules), ``defect`` (a broken rule of its own) and a random generator.
"""

import contextlib
import decimal
import io
import json
import os
import pathlib
import random
import resource
import shutil
import signal
import subprocess
import sys
import time

import yaml

ROOT = pathlib.Path(__file__).resolve().parents[1]
CONFIG = ROOT / 'config'
BIN = pathlib.Path(sys.executable).parent


# ------------------------------------------------------------------ contacts

def contacts(folder, call, defect, rng, count):
    """Grazing forces, touches at step ends, shapes beyond 1e9 m: run exits 0, 2 or 3."""
    base = yaml.safe_load((CONFIG / 'store_separation.yaml').read_text())
    for k in range(count):
        doc = json.loads(json.dumps(base))
        doc['duration'] = 0.3
        doc['contacts'] = [{'bodies': rng.choice([['pylon', 'store'], ['store', 'pylon']])}]
        kind = rng.choice(['force', 'force', 'sphere', 'drop', 'mesh'])
        if kind == 'force':   # around the grazing 100 N of issue 41.2, and anything
            force = rng.choice([100.0, rng.uniform(95, 105), rng.uniform(-5e3, 5e3),
                                rng.choice([1e8, 1e9, 1.1e9, 1e300])])
            doc['wrenches'] = [{'body': 'store', 'force': [0, 0, force], 'frame': 'world'}]
        elif kind == 'sphere':
            doc['bodies']['store']['shape'] = {'sphere': rng.choice(
                [0.25, 0.3, 1e9, 1.0000001e9, 1e30, 1e-9])}
        elif kind == 'mesh':
            scale = rng.choice([1.0, 1e8, 1e9, 1e10, 1e30])
            mesh = folder / f'mesh_{k}.obj'
            mesh.write_text(''.join(f'v {x * scale} {y * scale} {z * scale}\n' for x, y, z in
                                    [(-1.2, -.2, -.2), (1.2, -.2, -.2), (0, .2, -.2),
                                     (0, 0, .25)]) + 'f 1 2 3\nf 1 2 4\nf 2 3 4\nf 1 3 4\n')
            doc['bodies']['store']['shape'] = {'mesh': mesh.name}
        else:   # a ball dropped to touch a floor at a step's end, or just off it
            steps = rng.randint(10, 200)
            t = steps * 0.001 + rng.choice([0.0, 1e-12, -1e-12, 1e-9, 5e-4])
            g = 9.80665
            doc = {'gravity': [0, 0, -g], 'dt': 0.001, 'duration': 0.3,
                   'bodies': {'floor': {'fixed': True, 'shape': {'box': [4, 4, 0.2]}},
                              'ball': {'mass': 2.0, 'inertia': [0.1, 0.1, 0.1],
                                       'position': [0, 0, 0.35 + 0.5 * g * t * t],
                                       'shape': {'sphere': 0.25}}},
                   'contacts': [{'bodies': ['ball', 'floor']}]}
        path = folder / f'contact_{k}.yaml'
        path.write_text(yaml.safe_dump(doc))
        out = folder / 'contact.mcap'
        status, _, err = call('contacts at boundaries', ['run', path, '-o', out, '--overwrite'],
                              allowed={0, 2, 3})
        if status == 3 and 'touches' not in err:
            defect('contacts at boundaries', f'run {path}', 'exit 3 without the contact line')


# ------------------------------------------------------------------ study sizes

def _small_sweep(folder, name, runs, criteria=True):
    scenario = folder / 'small_scenario.yaml'
    doc = yaml.safe_load((CONFIG / 'store_separation.yaml').read_text())
    doc.update(duration=0.1, dt=0.002)
    scenario.write_text(yaml.safe_dump(doc))
    sweep = {'scenario': scenario.name, 'runs': runs, 'seed': 3, 'rate_hz': 50,
             'vary': {'bodies.store.mass': {'normal': [907.0, 10.0]},
                      'joints.pivot.release.angle_deg': {'uniform': [2, 4]}},
             'metrics': {'at': [{'time': 0.1, 'body': 'store'}]}}
    if criteria:
        sweep['criteria'] = {'low': 'store_at_0.1_z <= 0.0491'}
    path = folder / name
    path.write_text(yaml.safe_dump(sweep, sort_keys=False))
    return path


def study_sizes(folder, call, defect, rng, count):
    """Every method and design at sizes around its minimum: refused at once, or answered."""
    sweep = _small_sweep(folder, 'sizes.yaml', 1)
    cases = [(m, n) for m in ('subset', 'nais') for n in (0, 1, 5, 10, 11, 99)]
    cases += [('subset', 105), ('subset', 101)]
    cases += [('form', n) for n in (1, 5, 9)] + [('morris', n) for n in (1,)]
    cases += [('sobol', n) for n in (1, 2, 4, 7)]
    rng.shuffle(cases)
    for k, (name, runs) in enumerate(cases):
        option = ['--design', name] if name in ('morris', 'sobol') else ['--method', name]
        began = time.monotonic()
        status, _, err = call('study sizes', ['sweep', sweep, '-o', folder / f'size_{k}',
                                              *option, '--runs', runs, '--workers', '1'])
        if status == 0:
            defect('study sizes', f'{name} --runs {runs}', 'accepted below its minimum')
        elif time.monotonic() - began > 5.0:
            defect('study sizes', f'{name} --runs {runs}', 'refused only after running')
    # the smallest accepted sizes answer, and say whether any run failed
    for name, runs in [('form', 10), ('morris', 2), ('mc', 20)][:max(1, count)]:
        option = (['--design', name] if name == 'morris' else
                  ['--method', name] if name != 'mc' else [])
        status, out, err = call('study sizes', ['sweep', sweep, '-o', folder / f'ok_{name}',
                                                *option, '--runs', runs, '--workers', '1'],
                                timeout=600, allowed={0, 1, 2})   # 2: FORM found no point
        if status == 0 and name != 'morris' and 'P(any criterion fails)' in out and (
                'no run failed' not in out) and ' 0 failed' in out:
            defect('study sizes', f'{name} --runs {runs}', 'no failure, and not said')


# ------------------------------------------------------------------ study folders

def _finished_folder(folder, call):
    sweep = _small_sweep(folder, 'folder.yaml', 4)
    out = folder / 'finished'
    call('damaged study folders', ['sweep', sweep, '-o', out, '--workers', '1'],
         timeout=300, allowed={0, 1})
    return sweep, out


def _damages(out, rng):
    parts = sorted((out / 'parts').iterdir())
    yield 'results.parquet', 'cut', None
    yield 'results.parquet', 'flip', None
    yield 'results.parquet', 'empty', None
    yield 'results.parquet', 'remove', None
    for text in (b'{', b'[]', b'"x"', b'null', b'\xff\xfe', b'{"digest": 1}', b''):
        yield 'sweep.json', 'text', text
    yield 'sweep.json', 'remove', None
    for _ in range(3):
        yield str(rng.choice(parts).relative_to(out)), rng.choice(['cut', 'flip', 'empty']), None
    yield 'criteria.json', 'text', b'{'


def _damage(copy, name, how, text, rng):
    path = copy / name
    if how == 'remove':
        path.unlink()
    elif how == 'text':
        path.write_bytes(text)
    elif how == 'empty':
        path.write_bytes(b'')
    elif how == 'cut':
        data = path.read_bytes()
        path.write_bytes(data[:rng.randrange(1, len(data))])
    else:
        data = bytearray(path.read_bytes())
        for _ in range(rng.randint(1, 4)):
            data[rng.randrange(len(data))] ^= rng.randint(1, 255)
        path.write_bytes(bytes(data))


def study_folders(folder, call, defect, rng, count):
    """Damaged folders through report, rerun and a resumed sweep; report never overwrites."""
    sweep, out = _finished_folder(folder, call)
    if not (out / 'results.parquet').exists():
        defect('damaged study folders', f'sweep {sweep}', 'the base sweep did not finish')
        return
    family = 'damaged study folders'
    for k, (name, how, text) in enumerate(list(_damages(out, rng))[:count]):
        copy = folder / f'damaged_{k}'
        shutil.copytree(out, copy)
        _damage(copy, name, how, text, rng)
        page = folder / f'page_{k}.html'
        call(family, ['report', copy, '-o', page], timeout=120)
        call(family, ['rerun', copy, '0', '-o', folder / f'rerun_{k}.mcap'], timeout=120,
             allowed={0, 1, 2})
        call(family, ['sweep', sweep, '-o', copy, '--workers', '1'], timeout=300,
             allowed={0, 1, 2})
        shutil.rmtree(copy)
    # report -o onto anything that exists: refused without --overwrite, the file unchanged
    family = 'report outputs'
    for target in [out / 'results.parquet', out / 'sweep.json', sweep, folder / 'exists.html']:
        target = pathlib.Path(target)
        if not target.exists():
            target.write_text('keep')
        before = target.read_bytes()
        status, _, _ = call(family, ['report', out, '-o', target])
        if status != 2 or target.read_bytes() != before:
            defect(family, f'report -o {target}', f'exit {status}; the file changed: '
                   f'{target.read_bytes() != before}')
    fifo = folder / 'report.fifo'
    os.mkfifo(fifo)
    for target in (fifo, folder, '/dev/null'):
        status, _, _ = call(family, ['report', out, '-o', target, '--overwrite'])
        if status != 2:
            defect(family, f'report -o {target} --overwrite', f'exit {status}')
    if not fifo.is_fifo() or not pathlib.Path('/dev/null').is_char_device():
        defect(family, 'report', 'a FIFO or /dev/null was replaced')


# ------------------------------------------------------------------ tables

def _column_types():
    import pyarrow as pa
    numbers = [0.0, 0.5, 1.0]
    return {
        'int8': pa.array([0, 1, 2], pa.int8()), 'uint16': pa.array([0, 1, 2], pa.uint16()),
        'int64': pa.array([0, 1, 2], pa.int64()), 'float16': pa.array(
            [0, 0.5, 1], pa.float16()) if hasattr(pa, 'float16') else pa.array(numbers),
        'float32': pa.array(numbers, pa.float32()), 'float64': pa.array(numbers),
        'string': pa.array(['0', '1', '2']), 'large_string': pa.array(['a', 'b', 'c'],
                                                                      pa.large_string()),
        'binary': pa.array([b'0', b'1', b'2']), 'bool': pa.array([True, False, True]),
        'list': pa.array([[0.0], [1.0], [2.0]]), 'struct': pa.array(
            [{'v': 0.0}, {'v': 1.0}, {'v': 2.0}]),
        'dictionary': pa.array(['a', 'b', 'a']).dictionary_encode(),
        'timestamp': pa.array([0, 1, 2], pa.timestamp('s')),
        'date': pa.array([0, 1, 2], pa.date32()), 'decimal': pa.array(
            [decimal.Decimal('0.0'), decimal.Decimal('0.5'), decimal.Decimal('1.0')]),
        'null': pa.nulls(3), 'nullable': pa.array([0.0, None, 1.0]),
        'nan': pa.array([0.0, float('nan'), 1.0]), 'inf': pa.array([0.0, float('inf'), 1.0]),
        'huge': pa.array([0.0, 1e308, -1e308])}


def tables(folder, call, defect, rng, count):
    """Proximity tables of every column type, shape and encoding: read, or one refusal."""
    import pyarrow as pa
    import pyarrow.parquet as pq
    types = _column_types()
    cases = []
    for name, column in types.items():
        for where in ('dx', 'dCX'):
            other = pa.array([0.0, 1.0, 2.0]) if where == 'dCX' else pa.array([0.1, 0.2, 0.3])
            cases.append((f'{name}_{where}', 'parquet', pa.table(
                {'dx': column if where == 'dx' else other,
                 'dCX': column if where == 'dCX' else other})))
    cases.append(('no_rows', 'parquet', pa.table({'dx': pa.array([], pa.float64()),
                                                  'dCX': pa.array([], pa.float64())})))
    cases.append(('one_row', 'parquet', pa.table({'dx': [0.0], 'dCX': [1.0]})))
    cases.append(('no_columns', 'parquet', pa.table({})))
    csvs = ['dx,dCX\n', 'dx,dCX\n0,1\n', '\ufeffdx,dCX\n0,1\n1,2\n', 'dx,dx\n0,1\n1,2\n',
            'dx,dCX,dx\n0,1,2\n1,2,3\n', 'dx;dCX\n0;1\n1;2\n', 'dx,dCX\n0,1,2\n', '',
            'dx,dCX\n0,nan\n1,2\n', 'dx,dCX\n0,1\n0,2\n', ',\n,\n', 'dx,dCX\n1e309,1\n2,2\n',
            '\x00\x01\x02', 'dx,dCX\r\n0,1\r\n1,2\r\n', 'DX,dCX\n0,1\n1,2\n']
    cases += [(f'csv_{k}', 'csv', text) for k, text in enumerate(csvs)]
    rng.shuffle(cases)
    for k, (name, kind, table) in enumerate(cases[:count]):
        path = folder / f'prox_{k}.{kind}'
        if kind == 'parquet':
            try:
                pq.write_table(table, path)
            except Exception:  # noqa: B902 - pyarrow cannot write that type: not a case
                continue
        else:
            path.write_text(table, encoding='utf-8')
        doc = {'gravity': [0, 0, 9.80665], 'duration': 0.05,
               'bodies': {'aircraft': {'motion': {'velocity': [250.0, 0, 0]}},
                          'store': {'mass': 907.0, 'inertia': [27.0, 488.0, 488.0],
                                    'position': [0.5, 0, 1.2]}},
               'aero': {'store': {'area': 0.2, 'length': 0.5, 'altitude': 7925.0,
                                  'alpha_deg': [-20, 0, 20], 'CX': [0.3, 0.3, 0.3],
                                  'zero': ['CY', 'CZ', 'Cl', 'Cm', 'Cn'],
                                  'proximity': {'carrier': 'aircraft', 'table': path.name,
                                                'outside': 'hold'}}}}
        scenario = folder / f'prox_{k}.yaml'
        scenario.write_text(yaml.safe_dump(doc))
        status, _, _ = call(f'tables ({kind})', ['check', scenario])
        if status == 0:
            call(f'tables ({kind})', ['run', scenario, '-o', folder / 'prox.mcap',
                                      '--overwrite'])


# ------------------------------------------------------------------ full disks in studies

def _limited(limit):
    def set_limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return set_limit


def study_disks(folder, call, defect, rng, count):
    """Run a recorded sweep and a report under a file size limit; resume the sweep with room."""
    sweep = _small_sweep(folder, 'disk.yaml', 4, criteria=False)
    family = 'studies on a full disk'
    for k in range(count):
        out = folder / f'disk_{k}'
        limit = rng.choice([2_000, 20_000, 60_000, 200_000])
        result = subprocess.run([str(BIN / 'cfem-sim'), 'sweep', str(sweep), '-o', str(out),
                                 '--record', 'all', '--workers', '1'], capture_output=True,
                                text=True, timeout=600, preexec_fn=_limited(limit))
        problem = None
        if 'Traceback' in result.stderr or result.returncode not in (0, 1, 2):
            problem = f'exit {result.returncode}: {result.stderr.strip()[-200:]}'
        elif result.returncode != 0 and 'ERROR: ' not in result.stderr:
            problem = f'exit {result.returncode} without an ERROR line'
        call_ok = subprocess.run([str(BIN / 'cfem-sim'), 'sweep', str(sweep), '-o', str(out),
                                  '--record', 'all', '--workers', '1'], capture_output=True,
                                 text=True, timeout=600)
        if problem is None and call_ok.returncode != 0:
            problem = f'the resumed sweep with room: exit {call_ok.returncode}: ' \
                      f'{call_ok.stderr.strip()[-200:]}'
        if problem is None:
            import pandas as pd
            table = pd.read_parquet(out / 'results.parquet')
            if (table['status'] != 'ok').any():
                problem = f'rows not ok after the resume: {table["message"].tolist()[:2]}'
        page = folder / f'disk_{k}.html'
        report = subprocess.run([str(BIN / 'cfem-sim'), 'report', str(out), '-o', str(page)],
                                capture_output=True, text=True, timeout=300,
                                preexec_fn=_limited(rng.choice([1_000, 30_000, 100_000])))
        left = [p.name for p in folder.iterdir() if '.tmp-' in p.name]
        if problem is None and ('Traceback' in report.stderr or left):
            problem = f'report under a limit: exit {report.returncode}, left {left}'
        if problem is None and report.returncode != 0 and 'ERROR: ' not in report.stderr:
            problem = 'report under a limit failed without an ERROR line'
        TOTAL[family] = TOTAL.get(family, 0) + 3
        if problem:
            defect(family, f'sweep --record all under {limit} bytes', problem)


TOTAL = {}


# ------------------------------------------------------------------ the node

def node_clock(folder, call, defect, rng, count):
    """cfem_node following /clock: bad clocks, stamps and forces; SIGINT during a catch-up."""
    os.environ.setdefault('ROS_DOMAIN_ID', str(rng.randint(1, 100)))
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    sys.path.insert(0, str(ROOT / 'test' / 'ros'))
    from geometry_msgs.msg import WrenchStamped
    from rosharness import NodeProcess, Peer
    from test_node import FREE_BODIES, T0, tick, write_scenario
    family = 'node clock and stamps'
    for k in range(count):
        work = folder / f'node_{k}'
        work.mkdir()
        scenario = write_scenario(work, FREE_BODIES)
        node = NodeProcess(work, scenario, use_sim_time=True, record=work / 'node.mcap',
                           rate_hz=rng.choice([100.0, 1000.0]), duration=0.0)
        peer = None
        problem = None
        try:
            peer = Peer(['ball', 'spinner'], [])
            peer.connected(timeout=120.0)
            tick(peer, T0, ['ball', 'spinner'], timeout=60.0)
            for _ in range(rng.randint(3, 12)):
                what = rng.choice(['clock', 'clock', 'stamp', 'force'])
                if what == 'clock':
                    peer.clock(rng.choice([-1_000_000_000, -1, T0 - 1, T0 + 10 ** 14,
                                           (2 ** 31 - 1) * 10 ** 9, T0 + 3601 * 10 ** 9,
                                           T0 + rng.randint(1, 10 ** 9)]))
                else:
                    msg = WrenchStamped()
                    msg.header.frame_id = rng.choice(['world', 'ball', 'ball@1e300,0,0'])
                    sec, nanosec = rng.choice([(2 ** 31 - 1, 2 ** 32 - 1), (0, 2 ** 32 - 1),
                                               (-1, 0), (0, 0), (1000, 5)])
                    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
                    msg.wrench.force.x = rng.choice([1e300, 1.1e9, -1e10, 1.0]) \
                        if what == 'force' else 1.0
                    peer.send(peer.wrench_pubs['ball'], msg)
                peer.spin_for(0.05)
            if not node.alive():
                problem = f'the node ended: {node.output.strip()[-300:]}'
            else:   # a catch-up within the limit, then SIGINT in it
                peer.clock(T0 + rng.randint(100, 3000) * 10 ** 9)
                peer.spin_for(rng.uniform(0.2, 2.0))
                asked = time.monotonic()
                status = node.stop(signal.SIGINT, timeout=30.0)
                took = time.monotonic() - asked
                if status != 0 or took > 5.0 or 'Traceback' in node.output:
                    problem = (f'SIGINT during a catch-up: exit {status} after {took:.1f} s: '
                               f'{node.output.strip()[-300:]}')
                else:
                    from recordings import read_checked
                    read_checked(work / 'node.mcap')
        except Exception as err:  # noqa: B902 - anything is this case's failure
            problem = f'{type(err).__name__}: {err}'
        finally:
            if peer is not None:
                peer.close()
            if node.alive():
                node.stop(signal.SIGKILL)
        TOTAL[family] = TOTAL.get(family, 0) + 1
        if problem:
            defect(family, f'node session {k}', problem)


@contextlib.contextmanager
def quiet():
    """Silence a family's own chatter on stdout."""
    with contextlib.redirect_stdout(io.StringIO()):
        yield


FAMILIES = {
    'contacts': lambda f, c, d, r, n: contacts(f, c, d, r, n(60)),
    'sizes': lambda f, c, d, r, n: study_sizes(f, c, d, r, n(3)),
    'folders': lambda f, c, d, r, n: study_folders(f, c, d, r, n(20)),
    'tables': lambda f, c, d, r, n: tables(f, c, d, r, n(80)),
    'studydisks': lambda f, c, d, r, n: study_disks(f, c, d, r, n(4)),
    'node': lambda f, c, d, r, n: node_clock(f, c, d, r, n(4)),
}

__all__ = ['FAMILIES', 'TOTAL', 'random']
