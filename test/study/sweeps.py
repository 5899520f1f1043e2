# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Small scenarios and sweep files written by the study tests."""

import os

from cfem_ros.study import load_sweep
from cfem_ros.study.sweep import columns
import yaml

#: The linear studies' input: the release angle, normal with this mean and SD (deg).
ANGLE = 'joints.pivot.release.angle_deg'
MEAN, SIGMA = 10.0, 1.0

#: The store on its hinge (config/store_separation.yaml), shorter and coarser.
STORE = {
    'name': 'store_test', 'gravity': [0, 0, 9.80665], 'duration': 0.6, 'dt': 0.002,
    'bodies': {
        'pylon': {'fixed': True},
        'store': {'mass': 907.1848, 'inertia': [27.1164, 488.0944, 488.0944],
                  'position': [0, 0, 0]},
    },
    'joints': {
        'pivot': {'type': 'hinge', 'parent': 'pylon', 'child': 'store',
                  'anchor': [-0.3292, 0, -0.25], 'axis': [0, 1, 0],
                  'release': {'angle_deg': 10}},
    },
}

METRICS = {
    'clearance': [{'bodies': ['store', 'pylon'], 'points_a': [[1.5, 0, 0], [-1.5, 0, 0]],
                   'points_b': [[0, 0, -0.25]]}],
    'at': [{'time': 0.5, 'body': 'store', 'relative_to': 'pylon'}],
}

VARY = {
    'bodies.store.mass': {'normal': [907.1848, 10.0]},
    'joints.pivot.release.angle_deg': {'uniform': [8, 12]},
    'joints.pivot.anchor[0]': {'truncnormal': [-0.3292, 0.01, -0.35, -0.31]},
    'dt': {'grid': [0.002, 0.001]},
}


def write_sweep(folder, *, runs=3, seed=7, vary=None, metrics=None, scenario=None,
                **extra):
    """Write scenario.yaml and sweep.yaml in folder; return the sweep file's path."""
    folder = str(folder)
    with open(os.path.join(folder, 'scenario.yaml'), 'w') as stream:
        yaml.safe_dump(STORE if scenario is None else scenario, stream)
    sweep = {'scenario': 'scenario.yaml', 'runs': runs, 'seed': seed,
             'vary': VARY if vary is None else vary,
             'metrics': METRICS if metrics is None else metrics, **extra}
    path = os.path.join(folder, 'sweep.yaml')
    with open(path, 'w') as stream:
        yaml.safe_dump(sweep, stream, sort_keys=False)
    return path


def linear_sweep(folder, z_fail, runs, seed=5, **extra):
    """Return a sweep that fails when the (normal) release angle is beyond z_fail SDs."""
    threshold = float(0.1 - 0.01 * SIGMA * z_fail)
    path = write_sweep(folder, runs=runs, seed=seed,
                       vary={ANGLE: {'normal': [MEAN, SIGMA]},
                             'bodies.store.mass': {'uniform': [900.0, 910.0]}},   # ignored
                       criteria={'miss': f'clearance_store_pylon_min >= {threshold!r}'},
                       **extra)
    return load_sweep(path)


def computed_rows(spec, runs, metrics):
    """
    Return the runs' rows without simulating, each an ok run with its drawn values.

    metrics(values, k): the row's metric values (a dict) from run k's drawn values.
    """
    names = columns(spec)
    out = []
    for k in runs:
        values = spec.run_values(k)
        row = dict.fromkeys(names, float('nan'))
        row.update(run=k, status='ok', message='', **values)
        row.update(metrics(values, k))
        out.append(row)
    return out


def linear_rows(spec, runs):
    """Return the runs' rows without simulating: the clearance falls with the angle."""
    return computed_rows(spec, runs, lambda values, k: {
        'clearance_store_pylon_min': 0.1 - 0.01 * (values[ANGLE] - MEAN)})
