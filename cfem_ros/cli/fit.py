# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""``cfem-sim fit``: a scenario's parameters fitted to measured poses (SPEC section 13)."""

from __future__ import annotations

import argparse
import sys

from cfem_ros.cli.cluster import raise_interrupted
from cfem_ros.cli.common import error, EXIT_FAILED, EXIT_OK, signals_to, warn
from cfem_ros.core.errors import CfemError


def add_parser(sub):
    """Add ``cfem-sim fit`` to the command line's subparsers."""
    fit = sub.add_parser('fit', help="fit a scenario's parameters to measured trajectories",
                         description='Find the parameters (key paths) that make the simulated '
                         'poses of a body match measured ones (one flight or several), with '
                         'their standard errors (scaled by the reduced chi-square when it is '
                         'above 1) and correlations; write fit.json, fitted.yaml, fitted.mcap '
                         'and figures (SPEC section 13).')
    fit.add_argument('fit', metavar='FIT.yaml', help='fit file')
    fit.add_argument('-o', '--output', required=True, metavar='OUTDIR', help='folder to write')
    fit.add_argument('--threads', type=int, metavar='N',
                     help="runs of one Jacobian at once (default: the machine's cores)")
    fit.add_argument('--profile', action='store_true',
                     help="add profile-likelihood intervals at the fit file's confidence "
                     '(default 0.95), each point a bounded refit of the other parameters')
    fit.add_argument('--overwrite', action='store_true', help="replace a folder's fit outputs")
    fit.set_defaults(func=fit_command)


def fit_command(args: argparse.Namespace) -> int:
    """Fit a scenario's parameters to measured poses (SPEC section 13); exit 0, 1 or 2."""
    from cfem_ros.study.fit.outputs import folder_problem, output_names, write_outputs
    from cfem_ros.study.fit.run import fit_file
    from cfem_ros.study.fit.say import sentence, warnings
    from cfem_ros.study.fit.spec import FitError, load_fit
    outdir, threads = args.output, args.threads
    if threads is not None and threads < 1:
        return error(f'--threads: is {threads}; expected a whole number >= 1')
    try:
        flights = len(load_fit(args.fit).flights)
    except CfemError as err:
        return error(str(err))
    refused = folder_problem(outdir, output_names(flights), args.overwrite)
    if refused:
        return error(refused)
    try:
        fit, result = fit_file(args.fit, threads=threads, profile=args.profile)
    except FitError as err:
        if err.key == 'parameters':   # a run failed within the bounds: not the file's form
            print(f'ERROR: {err}', file=sys.stderr)
            return EXIT_FAILED
        return error(str(err))
    except CfemError as err:
        return error(str(err))
    try:
        with signals_to(raise_interrupted):
            paths = write_outputs(fit, result, outdir)
    except OSError as err:
        print(f'ERROR: {outdir}: cannot write the outputs ({err.strerror or err}); the folder '
              'is as it was', file=sys.stderr)
        return EXIT_FAILED
    for line in warnings(result):
        warn(line)
    print(sentence(fit, result))
    print(f'outputs: {outdir}/ ({", ".join(paths)})')
    return EXIT_OK
