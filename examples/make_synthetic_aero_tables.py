# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Write the SYNTHETIC aerodynamic tables of config/store_release_near_pylon.yaml.

No measured wind-tunnel or CFD data ships with cfem_ros. These tables come
from the analytic model below, shaped like a finned store's and a pylon's
flow field, so that the example exercises every part of the input (Mach
tables, a proximity grid over position, attitude and Mach, the fade at the
grid's edge); their numbers are not any real store's.

Free stream, over alpha, beta (deg) and Mach M (a, b in rad)::

    CD0(M)  = 0.25 + 0.15 / (1 + exp(-(M - 0.95) / 0.04))   transonic drag rise
    CNa(M)  = 3.0 (1 + 0.3 M^2)                              normal force, 1/rad
    Cma(M)  = -1.5 (1 + 0.5 (M - 0.6))                       statically stable
    CX = -(CD0 + 0.8 (a^2 + b^2)),  CY = -CNa b,  CZ = -CNa a
    Cl = 0,  Cm = Cma a,  Cn = -Cma b
    Clp = -3, Cmq = -40, Cnr = -40

Pylon flow field (proximity increments), over dx, dz (m, the store's CG
from its carriage position, pylon axes: x forward, z down), dtheta (deg) and
Mach, decaying over 0.6 m below the pylon::

    f     = exp(-dz / 0.6) (1 - 0.15 dx) (1 + 0.5 (M - 0.6))
    dCX   = 0.10 f
    dCZ   = -0.80 f (1 + dtheta / 40)     pulls the store toward the pylon (z up)
    dCm   = -0.40 f (1 - dtheta / 30)     nose down near the pylon

Run from the repository's root to regenerate both files::

    python examples/make_synthetic_aero_tables.py config
"""

import argparse
import math
import os
import sys

import numpy as np

ALPHA_DEG = [-20, -10, -5, 0, 5, 10, 20]
BETA_DEG = [-10, 0, 10]
MACH = [0.6, 0.8, 0.95, 1.1]
DX = [-1.0, 0.0, 1.0]
DZ = [-0.1, 0.0, 0.25, 0.5, 1.0, 1.5, 2.5]
DTHETA_DEG = [-20, -10, 0, 10, 20]
FIELD_MACH = [0.6, 0.95]
TABLE = 'store_release_near_pylon_field.csv'


def free_stream(alpha_deg, beta_deg, mach):
    """Return CX, CY, CZ, Cl, Cm, Cn of the synthetic store at one point."""
    a, b = math.radians(alpha_deg), math.radians(beta_deg)
    cd0 = 0.25 + 0.15 / (1 + math.exp(-(mach - 0.95) / 0.04))
    cna = 3.0 * (1 + 0.3 * mach * mach)
    cma = -1.5 * (1 + 0.5 * (mach - 0.6))
    return (-(cd0 + 0.8 * (a * a + b * b)), -cna * b, -cna * a, 0.0, cma * a, -cma * b)


def increments(dx, dz, dtheta_deg, mach):
    """Return dCX, dCZ, dCm of the synthetic pylon flow field at one point."""
    f = math.exp(-dz / 0.6) * (1 - 0.15 * dx) * (1 + 0.5 * (mach - 0.6))
    return 0.10 * f, -0.80 * f * (1 + dtheta_deg / 40), -0.40 * f * (1 - dtheta_deg / 30)


def tables() -> dict:
    """Return the free-stream coefficient tables, nested alpha, beta, Mach."""
    values = np.array([[[free_stream(a, b, m) for m in MACH] for b in BETA_DEG]
                       for a in ALPHA_DEG])
    out = {'alpha_deg': ALPHA_DEG, 'beta_deg': BETA_DEG, 'mach': MACH}
    for k, name in enumerate(('CX', 'CY', 'CZ', 'Cl', 'Cm', 'Cn')):
        out[name] = np.round(values[..., k], 6).tolist()
    out.update(Clp=-3.0, Cmq=-40.0, Cnr=-40.0)
    return out


def field_rows() -> list:
    """Return the proximity table's rows: dx, dz, dtheta_deg, mach, dCX, dCZ, dCm."""
    return [(dx, dz, t, m) + tuple(round(v, 6) for v in increments(dx, dz, t, m))
            for dx in DX for dz in DZ for t in DTHETA_DEG for m in FIELD_MACH]


def yaml_tables() -> str:
    """Return the tables as the YAML lines of the scenario's aero.store entry."""
    lines = []
    for key, value in tables().items():
        lines.append(f'    {key}: {value}')
    return '\n'.join(lines) + '\n'


def main(argv=None) -> int:
    """Write the proximity CSV into a folder and print the free-stream tables as YAML."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('folder', help='where the CSV goes (config)')
    args = parser.parse_args(argv)
    path = os.path.join(args.folder, TABLE)
    with open(path, 'w') as handle:
        handle.write('# SYNTHETIC pylon flow field (examples/make_synthetic_aero_tables.py); '
                     'not measured data\n')
        handle.write('dx,dz,dtheta_deg,mach,dCX,dCZ,dCm\n')
        for row in field_rows():
            handle.write(','.join(f'{v:g}' for v in row) + '\n')
    print(f'# {path}: {len(field_rows())} grid points; the aero.store tables:')
    sys.stdout.write(yaml_tables())
    return 0


if __name__ == '__main__':
    sys.exit(main())
