# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""``cfem-sim fit``: a scenario's parameters fitted to measured poses (SPEC section 13)."""

from __future__ import annotations

import argparse
import os
import sys

from cfem_ros.cli.common import error, EXIT_FAILED, EXIT_OK
from cfem_ros.core.errors import CfemError


def add_parser(sub):
    """Add ``cfem-sim fit`` to the command line's subparsers."""
    fit = sub.add_parser('fit', help="fit a scenario's parameters to a measured trajectory",
                         description='Find the parameters (key paths) that make the simulated '
                         'poses of a body match measured ones, with their standard errors and '
                         'correlations; write fit.json, fitted.yaml, fitted.mcap and figures '
                         '(SPEC section 13).')
    fit.add_argument('fit', metavar='FIT.yaml', help='fit file')
    fit.add_argument('-o', '--output', required=True, metavar='OUTDIR', help='folder to write')
    fit.add_argument('--threads', type=int, metavar='N',
                     help="runs of one Jacobian at once (default: the machine's cores)")
    fit.add_argument('--overwrite', action='store_true', help="replace a folder's fit outputs")
    fit.set_defaults(func=fit_command)


def fit_command(args: argparse.Namespace) -> int:
    """Fit a scenario's parameters to measured poses (SPEC section 13); exit 0, 1 or 2."""
    from cfem_ros.study.fit.outputs import OUTPUTS
    outdir, threads = args.output, args.threads
    held = [name for name in OUTPUTS if os.path.lexists(os.path.join(outdir, name))]
    if held and not args.overwrite:
        return error(f'-o {outdir}: already holds {", ".join(held)}; pass --overwrite to '
                     'replace them, or choose a new folder')
    if threads is not None and threads < 1:
        return error(f'--threads: is {threads}; expected a whole number >= 1')
    from cfem_ros.study.fit.run import fit_file
    from cfem_ros.study.fit.spec import FitError
    try:
        _, _, found = fit_file(args.fit, outdir, threads=threads)
    except FitError as err:
        if err.key == 'parameters':   # a run failed within the bounds: not the file's form
            print(f'ERROR: {err}', file=sys.stderr)
            return EXIT_FAILED
        return error(str(err))
    except CfemError as err:
        return error(str(err))
    except OSError as err:
        return error(f'{outdir}: cannot write ({err.strerror or err})')
    print(found)
    print(f'outputs: {outdir}/ (fit.json, fitted.yaml, fitted.mcap, fit_trajectory.png, '
          'fit_residuals.png)')
    return EXIT_OK
