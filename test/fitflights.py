# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Synthetic flights of known truth for the fit tests (SPEC section 13).

A store pushed off a fixed pylon by two ejectors (forward 10,676 N, aft
42,703 N) in a short, cheap run. A "flight" is a recording of ``cfem-sim
run`` at the true forces under a flight's conditions (``set:`` key-path
values), its store pose taken relative to the pylon by scipy's
``Rotation`` (not by the fit's code), plus seeded Gaussian noise.
"""

import copy
import pathlib

from cfem_ros import cli
from cfem_ros.recording.analysis import open_run
import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[1]
SIGMA_POSITION = 0.005      # m
SIGMA_ATTITUDE = 0.3        # deg
FORWARD, AFT = 10676.0, 42703.0   # N, the ejector forces of the "flights"

EJECTED = {
    'name': 'fit_flights', 'frame_id': 'world', 'gravity': [0, 0, 9.80665],
    'duration': 0.2, 'dt': 0.002,
    'bodies': {'pylon': {'fixed': True},
               'store': {'mass': 907.1848, 'inertia': [27.1164, 488.0944, 488.0944],
                         'position': [0, 0, 0], 'orientation_rpy_deg': [0, 0, 0]}},
    'wrenches': [
        {'name': 'forward_ejector', 'body': 'store', 'point': [0.1798, 0, -0.25],
         'force': [0, 0, FORWARD], 'frame': 'pylon', 'stroke': 0.1006, 'reacts_on': 'pylon'},
        {'name': 'aft_ejector', 'body': 'store', 'point': [-0.3292, 0, -0.25],
         'force': [0, 0, AFT], 'frame': 'pylon', 'stroke': 0.1006, 'reacts_on': 'pylon'}]}

FORCES = {
    'wrenches[0].force[2]': {'start': 9000, 'bounds': [5000, 20000],
                             'name': 'forward ejector force', 'unit': 'N'},
    'wrenches[1].force[2]': {'start': 38000, 'bounds': [30000, 50000],
                             'name': 'aft ejector force', 'unit': 'N'}}


def write(path, document) -> str:
    """Write a YAML document; return its path as text."""
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    return str(path)


def with_settings(document: dict, settings: dict) -> dict:
    """Return a copy of a scenario with dotted key paths (no indices) set."""
    out = copy.deepcopy(document)
    for key, value in settings.items():
        node, *path = key.split('.')
        where = out[node]
        for name in path[:-1]:
            where = where[name]
        where[path[-1]] = value
    return out


def truth(folder, name: str, settings=None, scenario=None):
    """Record a flight at the true forces; return (time, position, Rotation) of the store."""
    document = with_settings(scenario or EJECTED, settings or {})
    path = write(folder / f'{name}.yaml', document)
    recording = str(folder / f'{name}.mcap')
    assert cli.main(['run', path, '-o', recording, '--rate', '500', '--overwrite']) == 0
    run = open_run(recording)
    store, pylon = run.bodies['store'], run.bodies['pylon']
    turn = Rotation.from_quat(pylon.quaternion).inv()
    return (store.time, turn.apply(store.position - pylon.position),
            turn * Rotation.from_quat(store.quaternion))


def noisy(poses, seed: int, factor: float = 1.0):
    """Return poses with seeded Gaussian noise of factor times the stated sigmas."""
    time, position, attitude = poses
    rng = np.random.default_rng(seed)
    moved = position + rng.normal(0.0, factor * SIGMA_POSITION, position.shape)
    turn = Rotation.from_rotvec(np.radians(rng.normal(0.0, factor * SIGMA_ATTITUDE,
                                                      position.shape)))
    return time, moved, turn * attitude


def csv(path, time, position, attitude) -> str:
    """Write poses in the columns of cfem-sim export --relative-to; return the path."""
    euler = attitude.as_euler('ZYX', degrees=True)[:, ::-1]
    columns = {'time': time}
    columns.update({f'store_{q}': position[:, i] for i, q in enumerate('xyz')})
    columns.update({f'store_{q}_deg': euler[:, i]
                    for i, q in enumerate(('roll', 'pitch', 'yaw'))})
    pd.DataFrame(columns).to_csv(path, index=False)
    return str(path)


def measured_entry(file: str, window=None, **extra) -> dict:
    """Return one flight's ``measured:`` mapping."""
    entry = {'file': file, 'body': 'store', 'relative_to': 'pylon',
             'sigma': {'position': SIGMA_POSITION, 'attitude_deg': SIGMA_ATTITUDE}}
    if window:
        entry['window'] = window
    entry.update(extra)
    return entry


def fit_file(folder, scenario: str, measured, parameters, name='fit.yaml', **top) -> str:
    """Write a fit file (measured: a mapping or a list of them); return its path."""
    document = {'scenario': scenario, 'measured': measured, 'parameters': parameters}
    document.update(top)
    return write(folder / name, document)
