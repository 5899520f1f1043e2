# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Compile the numerical core ahead of its first use, and tell whether it is compiled.

The kernel is compiled by numba on first call and cached on disk next to its
source. ``make`` runs ``python -m cfem_ros.core.warmup`` right after
installing, so that the first ``cfem-sim run`` or node start compiles
nothing; a colcon install can run the same once. It then builds the kernel
ahead of time into an extension module (``core.aot``), with which a run
does not even import numba. The warm-up drives every
path of the kernel a run uses: the tree solve and the dense one (a closed
loop), samples taken by the kernel and one by one, release conditions of
each kind located in a step, velocity projection and the redundancy check,
and a kinematic carrier (a table, then odometry).
"""

from __future__ import annotations

import glob
import logging
import math
import os
import sys
import time

from cfem_ros.core import aot, kernel
from cfem_ros.core.engine import Simulator
from cfem_ros.core.sampling import SampleGrid
from cfem_ros.core.scenario import parse_scenario
import numpy as np


def _pendulums():
    """Two pendulums: a chain released at an angle, and a closed loop released on force."""
    box = {'mass': 1.0, 'inertia': [0.1, 0.1, 0.1]}
    return {
        'name': 'warmup', 'dt': 0.001,
        'bodies': {
            'ground': {'fixed': True},
            'a': dict(box, position=[0.5, 0, 0]),
            'b': dict(box, position=[1.5, 0, 0], velocity=[0, 0, 0.1]),
            'c': dict(box, position=[0, 0, -0.5]),
        },
        'joints': {
            'j1': {'type': 'hinge', 'parent': 'ground', 'child': 'a', 'anchor': [0, 0, 0],
                   'axis': [0, 1, 0], 'release': {'distance': 10.0}},
            'j2': {'type': 'hinge', 'parent': 'a', 'child': 'b', 'anchor': [1, 0, 0],
                   'axis': [0, 1, 0], 'release': {'angle_deg': 0.05, 'time': 0.5}},
            'j3': {'type': 'ball', 'parent': 'ground', 'child': 'c', 'anchor': [0, 0, 0],
                   'release': {'force': 1.0}},
            'j4': {'type': 'slider', 'parent': 'ground', 'child': 'c', 'anchor': [0, 0, -0.5],
                   'axis': [0, 0, 1]},
        },
        # an ejector with a stroke and a table, and aerodynamic tables (core/loads.py)
        'wrenches': [{'name': 'push', 'body': 'b', 'point': [0.1, 0, 0], 'frame': 'a',
                      'force': {'against': 'stroke',
                                'table': [[0.0, 0, 0, 1.0], [0.002, 0, 0, 0.5]]},
                      'stroke': 0.001, 'reacts_on': 'a', 'start': 0.01, 'end': 0.9}],
        'aero': {'a': {'area': 0.01, 'length': 0.1, 'altitude': 1000.0,
                       'freestream': [-10.0, 0, 0], 'alpha_deg': [-30, 0, 30],
                       'beta_deg': [-20, 20], 'CX': [[-0.3, -0.3]] * 3,
                       'CZ': [0.5, 0.0, -0.5], 'Cm': [0.2, 0.0, -0.2],
                       'Clp': -1.0, 'Cmq': -5.0, 'Cnr': -5.0}},
    }


def _carrier():
    """Return a store hinged to a kinematic carrier flying a table (core/motion.py)."""
    rows = [[t, 250.0 * t, 0, 0, 0, math.sin(0.01 * t), 0, math.cos(0.01 * t)]
            for t in (0.0, 0.5, 1.0, 1.5)]
    return {
        'name': 'warmup_carrier', 'dt': 0.001,
        'bodies': {'aircraft': {'motion': {'table': rows}},
                   'store': {'mass': 1.0, 'inertia': [0.1, 0.1, 0.1],
                             'position': [0, 0, -1.0]}},
        'joints': {'hook': {'type': 'hinge', 'parent': 'aircraft', 'child': 'store',
                            'anchor': [0.2, 0, -0.5], 'axis': [0, 1, 0],
                            'release': {'time': 0.04}}},
    }


def compiled_code_ready() -> bool:
    """Return True if the kernel is compiled ahead of time or cached for its current source."""
    if getattr(kernel, 'COMPILED_AHEAD', False):
        return True
    source = kernel.__file__
    cache = os.path.join(os.environ.get('NUMBA_CACHE_DIR') or os.path.dirname(source),
                         '' if os.environ.get('NUMBA_CACHE_DIR') else '__pycache__')
    index = glob.glob(os.path.join(cache, '**', 'kernel.advance-*.nbi'), recursive=True)
    # the index is named after the function's line: older ones may stay behind
    sources = [os.path.join(os.path.dirname(source), name) for name in aot.COMPILED_SOURCES]
    return bool(index) and (max(os.path.getmtime(p) for p in index)
                            >= max(os.path.getmtime(p) for p in sources))


def warm_up() -> float:
    """Run the kernel's every path once (compiling what is not cached); return the seconds."""
    started = time.monotonic()
    logging.getLogger('cfem_ros').disabled, was = True, logging.getLogger('cfem_ros').disabled
    try:
        sim = Simulator(parse_scenario(_pendulums(), source='<warm-up>'))
        sim.set_wrench('b', [0.0, 0.0, 1.0], [0.0, 0.1, 0.0], body_axes=True)
        grid = SampleGrid(100.0)
        grid.reset(0, np.zeros((4, sim.outputs().size)))
        sim.advance_to(0.03, samples=grid)
        sim.advance_to(0.05, limit=math.inf)
        sim.outputs()
        sim.joint_wrenches()
        sim.constraint_violation()
        sim.advance_to(1.0)
        # the Python form of the in-step search (releases.py, loads.py) beside kernel.locate
        sim._rk4(sim.y, sim.dt)
        sim.releases.values(sim.y, np.arange(len(sim.model.joints)), sim._joint_forces)
        sim._scheduled.strokes(sim.y)
        carrier = Simulator(parse_scenario(_carrier(), source='<warm-up>'))
        grid = SampleGrid(100.0)
        grid.reset(0, np.zeros((4, carrier.outputs().size)))
        carrier.advance_to(0.03, samples=grid)
        carrier.set_odometry('aircraft', carrier.t, [7.5, 0, 0], [0, 0, 0, 1], [250, 0, 0],
                             [0, 0.01, 0])
        carrier.advance_to(0.05)
        carrier.joint_wrenches()
        points = np.zeros((2, 3))   # study.metrics' clearance
        attitudes = np.tile([0.0, 0.0, 0.0, 1.0], (2, 1))
        kernel.clearance(points, attitudes, points, points, attitudes, points, np.empty(4))
    finally:
        logging.getLogger('cfem_ros').disabled = was
    return time.monotonic() - started


def main() -> int:
    """Compile the kernel if needed (JIT cache, then the extension) and say how long it took."""
    if getattr(kernel, 'COMPILED_AHEAD', False):
        print(f'cfem_ros: numerical core compiled ahead of time, run in {warm_up():.2f} s',
              file=sys.stderr)
        return 0
    ready = compiled_code_ready()
    if not ready:
        print('cfem_ros: compiling the numerical core (once per install, a few minutes)...',
              file=sys.stderr, flush=True)
    seconds = warm_up()
    print(f'cfem_ros: numerical core {"loaded" if ready else "compiled"} in {seconds:.1f} s',
          file=sys.stderr)
    if os.environ.get(aot.FORCE_JIT):
        return 0   # the JIT is asked for: no extension to build
    # a fresh process: the build must import numba itself, with its own cache
    import subprocess   # only to build the extension
    if subprocess.run([sys.executable, '-m', 'cfem_ros.core.aot']).returncode:
        print('cfem_ros: WARNING: the ahead-of-time build failed (see above); runs use the '
              'JIT, which imports numba at start-up', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
