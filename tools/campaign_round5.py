# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The reliability campaign's families of the fifth round (issues 45, 48 to 52).

Sway braces as hardware, aero completeness (``zero:``) and gravity with aero,
``flight:`` conditions, release envelopes, fits of several flights and the
predictions made from them, ``compare --relative-to``, the units of exports,
and the node's input queue and window.

Each family takes the campaign's ``call`` (a cfem-sim command in this process, judged
by the campaign's rules), ``defect`` (a broken rule of its own) and a random generator.
"""

import json
import math
import os
import pathlib
import random
import signal
import subprocess
import sys
import time

import yaml

ROOT = pathlib.Path(__file__).resolve().parents[1]
CONFIG = ROOT / 'config'
PY = sys.executable
#: Hostile numbers for a key that wants one.
NUMBERS = [0, -1, 1e-300, 5e-324, 1e9, 1e12, 1e300, 1e308, -1e308, '.nan', '.inf', 'x', None,
           [], {}, True, 10 ** 400, '1:30', 0.5, 2.0]
COEFFICIENTS = ('CX', 'CY', 'CZ', 'Cl', 'Cm', 'Cn')
TOTAL = {}
#: (family, outcome) -> sessions, for the node's sessions (no cfem-sim exit status).
STATUS = {}


def _load(name):
    return yaml.safe_load((CONFIG / name).read_text())


def _dump(path, document):
    text = yaml.safe_dump(document, sort_keys=False)
    for hostile in ('.nan', '.inf', '1:30'):   # written as YAML reads them, not as strings
        text = text.replace(f"'{hostile}'", hostile)
    path.write_text(text)
    return path


def _absolute(document, base=CONFIG):
    """Make the file names of a scenario's aero and motion blocks absolute."""
    for aero in (document.get('aero') or {}).values():
        proximity = aero.get('proximity') if isinstance(aero, dict) else None
        if isinstance(proximity, dict) and isinstance(proximity.get('table'), str):
            proximity['table'] = str(base / proximity['table'])
    return document


# ------------------------------------------------------------------ braces

def braces(folder, call, defect, rng, count):
    """Braces as hardware: pads, stiffness, directions; no push once the store is clear."""
    from cfem_ros.recording.analysis import open_run
    base = _load('store_release_two_hooks.yaml')
    inputs = CONFIG / 'inputs' / 'store_release_two_hooks.mcap'
    for k in range(count):
        doc = json.loads(json.dumps(base))
        doc['duration'] = rng.choice([0.5, 1.0, 3.0])
        if rng.random() < 0.5:
            doc.pop('aero', None)
        elif rng.random() < 0.5 and isinstance(doc.get('aero'), dict):
            for aero in doc['aero'].values():
                if isinstance(aero, dict) and isinstance(aero.get('scale'), dict):
                    aero['scale']['Cm'] = rng.choice([-3.0, 3.0, 1e3])
        brace = rng.choice(doc['sway_braces'])
        for _ in range(rng.randint(1, 3)):
            key = rng.choice(['pad_radius', 'stiffness', 'damping', 'preload', 'direction',
                              'point'])
            if key == 'direction':
                value = rng.choice([[-v for v in brace['direction']], [0, 0, 0], [1, 0, 0],
                                    [0, 0, 1e-300], [0, 0, -1], [1e308, 0, 0]])
            elif key == 'point':
                value = rng.choice([[0, 0, 0], [100, 0, 0], [1e9, 0, 0],
                                    [v * 1.01 for v in brace['point']]])
            elif rng.random() < 0.3:
                value = rng.choice(NUMBERS)
            else:   # within reach of a real pad, and the stiff ones of issue 52.2
                value = {'pad_radius': [1e-6, 0.001, 0.02, 0.05, 0.3, 5.0],
                         'stiffness': [1e4, 5e6, 1e8, 1e9, 1e10],
                         'damping': [0, 2e3, 1e6, 1e9], 'preload': [0, 10, 2000, 1e5]}[key]
                value = rng.choice(value)
            brace[key] = value
        _absolute(doc)
        path = _dump(folder / f'braces_{k}.yaml', doc)
        out = folder / 'braces.mcap'
        status, out_text, err = call('braces as hardware',
                                     ['run', path, '--inputs', inputs, '-o', out, '--overwrite'],
                                     timeout=120, allowed={0, 1, 2, 3})
        if status not in (0, 1) or not out.exists():
            continue
        try:   # a pad that touches the store again must be within reach of it
            run = open_run(str(out))
            store, pylon = run.bodies['store'], run.bodies['pylon']
            for event in run.events:
                if event.get('event') == 'brace_contact' and event.get('contact') is True:
                    at = int(abs(store.time - float(event['time'])).argmin())
                    gap = float(math.dist(store.position[at], pylon.position[at])
                                - math.dist(store.position[0], pylon.position[0]))
                    reach = next((b.get('pad_radius', 0.05) for b in doc['sway_braces']
                                  if b.get('name') == event.get('brace')), 0.05)
                    reach = reach if isinstance(reach, (int, float)) else 0.05
                    if gap > 0.5 + reach:   # a pad of that radius reaches that far
                        defect('braces as hardware', f'run {path}',
                               f'brace {event.get("brace")} touches again at t = '
                               f'{event["time"]} s with the store {gap:.3g} m further away')
        except Exception as failure:  # noqa: B902 - an unreadable recording is a defect
            defect('braces as hardware', f'run {path}', f'recording unreadable: {failure}')


# ------------------------------------------------------------------ aero keys

def aero_keys(folder, call, defect, rng, count):
    """zero: lists, missing coefficients, gravity with aero: refused in one line, or whole."""
    base = _load('store_separation_aero.yaml')
    for k in range(count):
        doc = json.loads(json.dumps(base))
        aero = next(iter(doc['aero'].values()))
        removed = rng.sample(COEFFICIENTS, rng.randint(0, 3))
        for name in removed:
            aero.pop(name, None)
        zero = rng.choice([removed, removed[:-1], removed + ['Cl'], removed + removed,
                           ['cm'], ['CD'], 'Cl', [1], [], None, {'Cl': 0}, list(COEFFICIENTS),
                           [None], ['Cl' * 100]])
        if zero is None:
            aero.pop('zero', None)
        else:
            aero['zero'] = zero
        if rng.random() < 0.3:
            doc['gravity'] = rng.choice([[0, 0, 9.80665], [0, 0, -9.80665], [0, 0, 0],
                                         [9.80665, 0, 0], None, [0, 0, 1e308]])
            if doc['gravity'] is None:
                del doc['gravity']
        path = _dump(folder / f'aero_{k}.yaml', _absolute(doc))
        status, out, err = call('aero zero and gravity', ['check', path])
        if status != 0:
            continue
        listed = aero.get('zero') if isinstance(aero.get('zero'), list) else []
        missing = [c for c in COEFFICIENTS if c not in aero and c not in listed]
        gravity = doc.get('gravity', [0, 0, -9.80665])
        if missing:
            defect('aero zero and gravity', f'check {path}',
                   f'accepted with {missing} neither given nor in zero: {listed}')
        elif isinstance(gravity, list) and len(gravity) == 3 and gravity[2] < 0:
            defect('aero zero and gravity', f'check {path}', f'accepted gravity {gravity}')
        else:
            call('aero zero and gravity', ['run', path, '-o', folder / 'aero.mcap',
                                           '--duration', '0.2', '--overwrite'])


# ------------------------------------------------------------------ flight

FLIGHT_KEYS = ('carrier', 'mach', 'airspeed', 'altitude', 'temperature_offset',
               'flight_path_deg', 'load_factor', 'roll_rate_deg_s', 'alpha_deg', 'unknown')


def flight(folder, call, defect, rng, count):
    """flight: conditions at their edges and beyond: refused in one line, or run."""
    base = _load('store_release_two_hooks_pullup.yaml')
    for k in range(count):
        doc = json.loads(json.dumps(base))
        block = doc['flight']
        for _ in range(rng.randint(1, 3)):
            key = rng.choice(FLIGHT_KEYS)
            plausible = {'carrier': ['aircraft', 'store', 'nobody'],
                         'mach': [0.3, 0.95, 1.2, 3.0], 'airspeed': [50, 290, 1000],
                         'altitude': [-500, 0, 11000, 20000, 32000, 1e5],
                         'temperature_offset': [-40, 0, 25], 'flight_path_deg': [-90, -60, 0,
                                                                                 89.9, 90],
                         'load_factor': [-3, 0, 1, 2.5, 7.5, 30],
                         'roll_rate_deg_s': [0, 90, 360, 1e4], 'alpha_deg': [-20, 0, 25, 90],
                         'unknown': [0]}[key]
            value = rng.choice(NUMBERS if rng.random() < 0.2 else plausible)
            block[key] = value
            if key == 'unknown':
                block.pop('unknown')
                block.pop(rng.choice(['mach', 'altitude', 'carrier', 'load_factor']), None)
        if k % 10 == 9:   # a motion beside the flight
            doc['bodies']['aircraft']['motion'] = {'velocity': [250, 0, 0]}
        path = _dump(folder / f'flight_{k}.yaml', _absolute(doc))
        status, _, _ = call('flight conditions', ['check', path])
        if status == 0:
            status, out, _ = call('flight conditions', ['run', path, '-o', folder / 'f.mcap',
                                                        '--duration', '0.3', '--overwrite'],
                                  timeout=120)
            if status == 0 and ' nan' in out.lower():
                defect('flight conditions', f'run {path}', 'NaN in the final state')


# ------------------------------------------------------------------ envelope

def envelope(folder, call, defect, rng, count):
    """cfem-sim envelope with grids and axes at their edges: refused at once, or drawn."""
    base = _load('sweeps/store_release_pullup_envelope.yaml')
    scenario = _load('store_release_two_hooks_pullup.yaml')
    scenario.update(duration=0.3)
    scenario_path = _dump(folder / 'envelope_scenario.yaml', _absolute(scenario))
    for k in range(count):
        doc = json.loads(json.dumps(base))
        doc.update(scenario=str(scenario_path), runs=rng.choice([1, 2]), rate_hz=50)
        doc['metrics'] = {'at': [{'time': 0.2, 'body': 'store', 'relative_to': 'aircraft'}]}
        doc['criteria'] = {'clear': rng.choice(['store_at_0.2_z >= 0.3', 'store_at_0.2_z >= 1e9',
                                                'store_at_0.2_z >= -1e9'])}
        grids = {'flight.mach': [0.6, 0.95], 'flight.altitude': [1500, 9000],
                 'flight.load_factor': [1.0, 3.0]}
        for key in list(grids):
            if rng.random() < 0.4:
                grids[key] = rng.choice([[rng.choice(NUMBERS[:9])], [0.8], [1, 1], []])
        doc['vary'] = {**{k2: {'grid': v} for k2, v in grids.items()},
                       'wrenches[0].force[2]': {'uniform': [8000, 12000]}}
        axes = ['flight.mach', 'flight.altitude', 'flight.load_factor', 'bodies.store.mass',
                'wrenches[0].force[2]', 'nothing']
        if rng.random() < 0.6:   # the axes the grid has
            x, y, z = rng.sample(axes[:3], 3)
        else:
            x, y, z = rng.choice(axes), rng.choice(axes), rng.choice(axes)
        argv = ['envelope', _dump(folder / f'envelope_{k}.yaml', doc), '-o',
                folder / f'envelope_{k}', '--x', x, '--y', y, '--workers', '1']
        if rng.random() < 0.5:
            argv += ['--z', z]
        else:   # a grid key that is no axis is refused: keep two
            doc['vary'].pop(z, None)
            _dump(folder / f'envelope_{k}.yaml', doc)
        status, _, _ = call('envelope', argv, timeout=600, allowed={0, 1, 2})
        table = folder / f'envelope_{k}' / 'envelope.parquet'
        if status in (0, 1) and not table.exists():
            defect('envelope', ' '.join(map(str, argv)), f'exit {status} without {table.name}')


# ------------------------------------------------------------------ fit and predict

def _flights(folder):
    logs = []
    for name, release in (('f37', 0.5), ('f38', 0.3)):
        plan, log = folder / f'{name}_plan.mcap', folder / f'{name}.mcap'
        subprocess.run([PY, str(ROOT / 'examples' / 'write_pullup_log.py'), '-o', str(plan),
                        '--duration', '1.0', '--release', str(release), '--overwrite'],
                       check=True, capture_output=True)
        subprocess.run([PY, str(ROOT / 'examples' / 'photogrammetry_log.py'), str(plan), '-o',
                        str(log), '--seed', '3'], check=True, capture_output=True)
        logs.append(log)
    return logs


def fits(folder, call, defect, rng, count):
    """Fits of several flights fed bad keys and values, then predictions from the last fit."""
    logs = _flights(folder)
    base = _load('fit/fit_two_flights.yaml')
    base['scenario'] = str(CONFIG / 'fit' / base['scenario'])
    for item, log in zip(base['measured'], logs):
        item['file'] = item['inputs'] = str(log)
    fitted = None
    for k in range(count):
        doc = json.loads(json.dumps(base))
        item = rng.choice(doc['measured'])
        what = 'none' if k == 0 else rng.choice(
            ['sigma', 'window', 'parameter', 'set', 'item', 'scenario', 'none', 'none'])
        if what == 'sigma':
            item['sigma'][rng.choice(['position', 'attitude_deg'])] = rng.choice(NUMBERS)
        elif what == 'window':
            end = rng.choice(['from', 'to'])
            item['window'][end] = rng.choice(NUMBERS[:8] + [{'release': 'nohook'},
                                                            {'release': 'hook', 'delay': 1e9},
                                                            {'release': 'hook', 'delay': -1}])
        elif what == 'parameter':
            parameter = rng.choice(list(doc['parameters'].values()))
            key = rng.choice(['start', 'bounds', 'step'])
            parameter[key] = rng.choice(NUMBERS + [[30000, 2000], [0, 1e308], [5, 5]])
        elif what == 'set':
            item['set'] = rng.choice([{'bodies.store.mass': rng.choice(NUMBERS)},
                                      {'flight.mach': 0.8}, {'nothing.here': 1}, [], 'x'])
        elif what == 'item':
            item[rng.choice(['topic', 'body', 'relative_to', 'file'])] = rng.choice(
                ['/nothing', 'nobody', '', str(folder), '/dev/null', 1e308])
        elif what == 'scenario':
            item['scenario'] = rng.choice([doc['scenario'], str(folder / 'none.yaml'), 1])
        path = _dump(folder / f'fit_{k}.yaml', doc)
        outdir = folder / f'fit_{k}'
        status, _, _ = call('fit and predict', ['fit', path, '-o', outdir, '--overwrite'],
                            timeout=600, allowed={0, 1, 2})
        if status == 0:
            fitted = outdir
            for name in ('fit.json',):
                if not (outdir / name).exists():
                    defect('fit and predict', f'fit {path}', f'exit 0 without {name}')
    if fitted is None:
        return
    point = _load('fit/next_point.yaml')
    point['scenario'] = str(CONFIG / 'fit' / point['scenario'])
    for k in range(max(1, count // 3)):
        doc = json.loads(json.dumps(point))
        if rng.random() < 0.6:
            doc[rng.choice(['seed', 'rate_hz'])] = rng.choice(NUMBERS)
        path = _dump(folder / f'next_{k}.yaml', doc)
        draws = rng.choice([2, 3, 5, 0, 1, -1, 'x', 10 ** 12, 100001])
        call('fit and predict', ['predict', fitted, path, '--inputs', logs[0], '-o',
                                 folder / f'band_{k}', '--draws', draws, '--overwrite'],
             timeout=600, allowed={0, 1, 2})


# ------------------------------------------------------------------ compare and units

def compare_relative(folder, call, defect, rng, count):
    """Compare two runs relative to any body, export with units; a run equals itself."""
    from cfem_ros.recording.units import read_units
    runs = []
    two_hooks = CONFIG / 'inputs' / 'store_release_two_hooks.mcap'
    for name, extra in (('pullup', []), ('two_hooks', ['--inputs', two_hooks])):
        out = folder / f'{name}.mcap'
        scenario = CONFIG / ('store_release_two_hooks_pullup.yaml' if name == 'pullup'
                             else 'store_release_two_hooks.yaml')
        call('compare relative', ['run', scenario, '-o', out, '--overwrite', *extra])
        runs.append(out)
    bodies = ['aircraft', 'pylon', 'store', 'nobody', '', 'x' * 300, 'world']
    for k in range(count):
        a, b = rng.choice(runs), rng.choice(runs)
        body = rng.choice(bodies)
        argv = ['compare', a, b, '--relative-to', body]
        if rng.random() < 0.3:
            argv += ['-o', folder / f'sheet_{k}', '--overwrite']
        status, out, _ = call('compare relative', argv, timeout=180)
        if status == 0 and a == b:
            for line in out.splitlines():
                parts = line.split()
                if len(parts) > 4 and parts[-4] in ('m', 'deg', 'deg/s', 'm/s', 'N', 'm') and \
                        parts[-5] not in ('0', 'nan') and '|' not in line:
                    try:
                        differs = float(parts[-5]) > 1e-9
                    except ValueError:
                        differs = False
                    if differs:
                        defect('compare relative', ' '.join(map(str, argv)),
                               f'a recording differs from itself: {line.strip()}')
        table = folder / f'export_{k}.parquet'
        export = ['export', a, '-o', table, '--overwrite']
        if rng.random() < 0.7:
            export += ['--relative-to', body]
        status, _, _ = call('compare relative', export)
        if status == 0:
            import pyarrow.parquet as pq
            names = pq.read_schema(str(table)).names
            units = read_units(str(table))
            if set(names) != set(units):
                defect('compare relative', ' '.join(map(str, export)),
                       f'columns without a unit: {sorted(set(names) - set(units))[:5]}')


# ------------------------------------------------------------------ node inputs

def node_inputs(folder, call, defect, rng, count):
    """cfem_node with input_queue_depth and input_window at their edges, flooded with inputs."""
    _isolated(rng)
    sys.path.insert(0, str(ROOT / 'test' / 'ros'))
    from geometry_msgs.msg import WrenchStamped
    from rosharness import NodeProcess, Peer
    from test_node import FREE_BODIES, T0, tick, write_scenario
    family = 'node input queue and window'
    for k in range(count):
        work = folder / f'inputs_{k}'
        work.mkdir()
        scenario = write_scenario(work, FREE_BODIES)
        params = {'input_queue_depth': rng.choice([1, 2, 1000, 1000000, 0, -1, 1000001, 1.5]),
                  'input_window': rng.choice([0.0, 0.05, 10.0, -0.1, 10.5, 1e-300, 'nan'])}
        node = NodeProcess(work, scenario, use_sim_time=True, record=work / 'node.mcap',
                           rate_hz=100.0, duration=0.0, **params)
        peer, problem = None, None
        valid = (isinstance(params['input_queue_depth'], int)
                 and 1 <= params['input_queue_depth'] <= 1000000
                 and params['input_window'] != 'nan' and 0 <= params['input_window'] <= 10)
        try:
            if not valid:
                status = node.process.wait(timeout=60)
                if status == 0 or 'Traceback' in node.output or 'ERROR' not in node.output:
                    problem = f'{params}: exit {status}: {node.output.strip()[-300:]}'
            else:
                peer = Peer(['ball', 'spinner'], [])
                peer.connected(timeout=120.0)
                tick(peer, T0, ['ball', 'spinner'], timeout=60.0)
                for n in range(rng.choice([10, 300, 3000])):
                    msg = WrenchStamped()
                    msg.header.frame_id = 'world'
                    msg.header.stamp.sec = T0 // 10 ** 9 + rng.choice([0, 1, 100])
                    msg.wrench.force.x = 1.0
                    peer.send(peer.wrench_pubs['ball'], msg)
                peer.clock(T0 + rng.randint(1, 200) * 10 ** 7)
                peer.spin_for(0.5)
                asked = time.monotonic()
                status = node.stop(signal.SIGINT, timeout=30.0)
                if status != 0 or time.monotonic() - asked > 5.0 or 'Traceback' in node.output:
                    problem = f'{params}: SIGINT: exit {status}: {node.output.strip()[-300:]}'
        except Exception as err:  # noqa: B902 - anything is this case's failure
            problem = f'{params}: {type(err).__name__}: {err}'
        finally:
            if peer is not None:
                peer.close()
            if node.alive():
                node.stop(signal.SIGKILL)
        TOTAL[family] = TOTAL.get(family, 0) + 1
        outcome = ('refused' if not valid else 'ran') + (', defect' if problem else '')
        STATUS[family, outcome] = STATUS.get((family, outcome), 0) + 1
        if problem:
            defect(family, f'node session {k}', problem)


def _isolated(rng):
    """Keep the campaign's nodes to a DDS domain of their own, on this machine."""
    # 215 to 232: no test's domain (test/conftest.py takes them from 1 to 101), so the
    # campaign's clients never talk to a test's node, nor a test's to the campaign's
    os.environ.setdefault('ROS_DOMAIN_ID', str(random.Random().randint(215, 232)))
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')


def _control_action(client, rng, calls):
    """One random request of the simulation control interface; return its kind."""
    from simulation_interfaces.action import SimulateSteps
    from simulation_interfaces.msg import SimulationState
    from simulation_interfaces.srv import GetEntities
    kind = rng.choice(['step', 'step', 'filter', 'state', 'set', 'goal', 'reset', 'get'])
    calls[kind] = calls.get(kind, 0) + 1
    calls['last'] = kind
    if kind == 'step':
        client.call('step_simulation', steps=rng.choice([0, 1, 7, 1000, 10000, 10001, 10 ** 12,
                                                         2 ** 64 - 1]))
    elif kind == 'filter':
        filters = GetEntities.Request().filters
        filters.filter = rng.choice(['(' * 1000 + ')' * 1000, 'a{99999999999999999999}', '(',
                                     '(a*)*$', 'st.*', '', 'x' * 100000, '[\\d-a]', '\\'])
        client.call(rng.choice(['get_entities', 'get_entities_states']), filters=filters)
    elif kind == 'state':
        state = SimulationState(state=rng.choice([SimulationState.STATE_PAUSED,
                                                  SimulationState.STATE_PLAYING,
                                                  SimulationState.STATE_STOPPED, 77]))
        client.call('set_simulation_state', state=state)
    elif kind == 'set':
        state = client.call('get_entity_state', entity='store').state
        value = rng.choice([1.7e308, float('nan'), float('inf'), 1e9, 2e9, -1e12, 1.0, 5e-324])
        target = rng.choice([state.twist.linear, state.twist.angular, state.pose.position,
                             state.pose.orientation])
        setattr(target, rng.choice(['x', 'y', 'z']), value)
        client.call('set_entity_state', entity=rng.choice(['store', 'pylon', 'nobody', '']),
                    state=state)
    elif kind == 'goal':
        steps = rng.choice([1, 50, 5000, 10 ** 12])
        goal = client.wait(client.action.send_goal_async(SimulateSteps.Goal(steps=steps)))
        if goal.accepted:
            client.executor.spin_once(timeout_sec=rng.uniform(0.0, 1.0))
            if steps > 50 or rng.random() < 0.5:   # a huge goal is cancelled, or never ends
                client.wait(goal.cancel_goal_async())
            client.wait(goal.get_result_async(), timeout=60.0)
    elif kind == 'reset':
        client.call('reset_simulation')
    else:
        client.call('get_simulation_state')
    return kind


def node_control(folder, call, defect, rng, count):
    """Call the simulation control services and action at their limits, in random order."""
    _isolated(rng)
    sys.path.insert(0, str(ROOT / 'test'))
    from rosharness import NodeProcess
    from simclient import Client
    family = 'node control services'
    for k in range(count):
        work = folder / f'control_{k}'
        work.mkdir()
        node = NodeProcess(work, CONFIG / 'store_separation.yaml', paused=True,
                           duration=rng.choice([0.0, 0.05, 1.0]), record=work / 'node.mcap')
        client, problem, calls = Client(), None, {}
        try:
            client.ready(node)
            for _ in range(rng.randint(10, 40)):
                if not node.alive():   # the run reached its end (duration > 0): it ends
                    break
                _control_action(client, rng, calls)
            if node.alive():
                asked = time.monotonic()
                status = node.stop(signal.SIGINT, timeout=30.0)
                if status != 0 or time.monotonic() - asked > 10.0:
                    problem = f'SIGINT: exit {status} after {time.monotonic() - asked:.1f} s'
            elif node.process.returncode != 0:
                problem = f'the node ended with exit {node.process.returncode}'
            if not problem and ('Traceback' in node.output or 'never awaited' in node.output):
                problem = node.output.strip()[-300:]
        except Exception as err:  # noqa: B902 - no answer, or anything else: this case fails
            time.sleep(1.0)
            if node.alive() or node.process.returncode != 0:   # else: the run ended, and it
                problem = (f'{type(err).__name__}: {err} after {calls}: '
                           f'{node.output.strip()[-200:]}')
        finally:
            client.close()
            if node.alive():
                node.stop(signal.SIGKILL)
        calls.pop('last', None)
        TOTAL[family] = TOTAL.get(family, 0) + sum(calls.values())
        outcome = 'defect' if problem else 'held'
        STATUS[family, outcome] = STATUS.get((family, outcome), 0) + 1
        if problem:
            defect(family, f'node session {k} ({calls})', problem)


FAMILIES = {
    'braces': lambda f, c, d, r, n: braces(f, c, d, r, n(40)),
    'aerokeys': lambda f, c, d, r, n: aero_keys(f, c, d, r, n(60)),
    'flight': lambda f, c, d, r, n: flight(f, c, d, r, n(60)),
    'envelope': lambda f, c, d, r, n: envelope(f, c, d, r, n(6)),
    'fits': lambda f, c, d, r, n: fits(f, c, d, r, n(12)),
    'compare': lambda f, c, d, r, n: compare_relative(f, c, d, r, n(30)),
    'nodeinputs': lambda f, c, d, r, n: node_inputs(f, c, d, r, n(4)),
    'nodecontrol': lambda f, c, d, r, n: node_control(f, c, d, r, n(4)),
}

__all__ = ['FAMILIES', 'STATUS', 'TOTAL']
