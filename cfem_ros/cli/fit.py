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
                     help="runs at once (a Jacobian's, the flights' at one point) and "
                     "processes drawing the figures (default: the machine's cores)")
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
    for line in warnings(fit, result):
        warn(line)
    print(sentence(fit, result))
    print(f'outputs: {outdir}/ ({", ".join(paths)})')
    return EXIT_OK


def add_predict_parser(sub):
    """Add ``cfem-sim predict`` to the command line's subparsers."""
    from cfem_ros.study.fit import DRAWS
    predict = sub.add_parser(
        'predict', help="predict the next test point's trajectory band from a fit",
        description='Run the next test point (a scenario, or a sweep file naming it with '
        'metrics and criteria) with the fitted parameters drawn from their fitted covariance '
        '(scaled by the reduced chi-square): the median and 5-95 %% band of the fitted '
        "body's pose relative to the carrier, and the criteria's pass fraction; write "
        'prediction.json, band.parquet, draws.parquet, prediction.png and prediction.html '
        '(SPEC section 13).')
    predict.add_argument('fit_folder', metavar='FIT_OUTDIR', help='the folder of cfem-sim fit')
    predict.add_argument('next', metavar='NEXT.yaml',
                         help='the next point: a scenario, or a sweep file with metrics and '
                         'criteria (no vary)')
    predict.add_argument('-o', '--output', required=True, metavar='OUTDIR',
                         help='folder to write')
    predict.add_argument('--draws', type=int, default=DRAWS, metavar='N',
                         help=f'draws of the fitted parameters (default {DRAWS})')
    predict.add_argument('--seed', type=int, metavar='S',
                         help="the draws' seed (default: the sweep file's seed, else 0)")
    predict.add_argument('--inputs', metavar='LOG.mcap',
                         help='replayed in every run, as cfem-sim run --inputs')
    predict.add_argument('--odometry', choices=('interpolate', 'extrapolate'),
                         help='how replayed odometry drives a kinematic body (as run)')
    predict.add_argument('--threads', type=int, metavar='N',
                         help="runs at once (default: the machine's cores)")
    predict.add_argument('--overwrite', action='store_true',
                         help="replace a folder's prediction outputs")
    predict.set_defaults(func=predict_command)


def predict_command(args: argparse.Namespace) -> int:
    """Predict the next point from a fit's parameters and covariance (SPEC 13); exit 0-2."""
    import os
    from cfem_ros.study.fit.outputs import folder_problem
    from cfem_ros.study.fit.predict import MOST_DRAWS, Prediction, read_fitted, read_next
    from cfem_ros.study.fit.predictout import NAMES, write_prediction
    for name, value, least in (('--draws', args.draws, 2), ('--threads', args.threads, 1),
                               ('--seed', args.seed, 0)):
        if value is not None and value < least:
            return error(f'{name}: is {value}; expected a whole number >= {least}')
    if args.draws > MOST_DRAWS:
        return error(f'--draws: is {args.draws}; expected at most {MOST_DRAWS:,} (the 5 % and '
                     "95 % lines are within 0.4 % of the band's half-width there)")
    try:
        fitted = read_fitted(args.fit_folder)
        nxt = read_next(args.next)
        inputs, interpolate = [], args.odometry != 'extrapolate'
        if args.inputs:
            from cfem_ros.recording.replay import read_inputs, recorded_interpolation
            try:
                inputs = read_inputs(args.inputs)
                if args.odometry is None:
                    interpolate = recorded_interpolation(args.inputs) is not False
            except CfemError as err:
                return error(f'--inputs {err}')
        prediction = Prediction(fitted, nxt, inputs, interpolate,
                                threads=args.threads or os.cpu_count() or 1)
    except CfemError as err:
        return error(str(err))
    refused = folder_problem(args.output, NAMES, args.overwrite)
    if refused:
        return error(refused)
    seed = nxt.seed if args.seed is None else args.seed
    try:
        result = prediction.run(args.draws, seed)
    except CfemError as err:
        print(f'ERROR: {err}', file=sys.stderr)
        return EXIT_FAILED
    try:
        with signals_to(raise_interrupted):
            paths, said, notes = write_prediction(fitted, nxt, result, seed, args.output)
    except OSError as err:
        print(f'ERROR: {args.output}: cannot write the outputs ({err.strerror or err}); the '
              'folder is as it was', file=sys.stderr)
        return EXIT_FAILED
    print(said)
    for line in notes:
        print(f'note: {line}')
    print(f'outputs: {args.output}/ ({", ".join(paths)})')
    return EXIT_OK
