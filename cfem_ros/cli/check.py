# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""``cfem-sim check``: validate a scenario and print what it holds."""

from __future__ import annotations

import argparse
import math
import sys

from cfem_ros.cli.common import cannot_start, error, EXIT_OK, vec, warnings_held
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import CfemError, InputError
from cfem_ros.core.scenario.aeroparse import describe as describe_aero
from cfem_ros.core.scenario.parse import load_scenario
import numpy as np


def add_parser(sub):
    """Add ``cfem-sim check`` to the command line's subparsers."""
    check = sub.add_parser('check', help='validate a scenario and summarize it',
                           description='Validate a scenario and print its bodies, joints '
                           'and degrees of freedom.')
    check.add_argument('scenario', metavar='SCENARIO', help='scenario file (YAML)')
    check.set_defaults(func=check_command)


def check_command(args: argparse.Namespace) -> int:
    """Validate a scenario and print a summary; exit status 0 or 2."""
    from cfem_ros.core.engine.startcheck import cannot_analyse, start_problems
    scenario = args.scenario
    try:
        with warnings_held():   # a refused scenario says only its ERROR line
            model = load_scenario(scenario)
            with np.errstate(all='raise', under='ignore'):
                sim = Simulator(model)
            errors, warnings = start_problems(sim)
            if errors:
                raise InputError(cannot_start(scenario, errors))
    except CfemError as err:
        return error(str(err))
    except (ArithmeticError, np.linalg.LinAlgError) as err:
        return error(cannot_analyse(scenario, err))
    for text in warnings:
        print(f'WARNING: {scenario}: {text}', file=sys.stderr)
    print(f'{scenario}: valid scenario {model.name!r}')
    print(f'  world frame {model.frame_id!r}, gravity {vec(model.gravity)} m/s^2, '
          f'dt {model.dt:g} s, duration {model.duration:g} s, '
          f'baumgarte {model.baumgarte:g} 1/s')
    _print_flight(scenario)
    _print_bodies(model)
    _print_joints(model)
    if model.wrenches:
        _print_wrenches(model)
    _print_aero(model)
    _print_braces_and_contacts(model)
    free = sum(b.dynamic for b in model.bodies)
    print(f'  degrees of freedom: {sim.dof} '
          f'({6 * free} of {free} free bodies less {6 * free - sim.dof} '
          f'removed by the joints)')
    return EXIT_OK


def _print_flight(scenario: str):
    """Print the flight condition (SPEC section 14) of a scenario that states one."""
    from cfem_ros.core.fileio.textfile import display, read_text
    from cfem_ros.core.fileio.yamlfile import load_yaml
    from cfem_ros.core.scenario.checker import Checker
    from cfem_ros.core.scenario.flight import describe, parse_flight
    source = display(scenario)   # read again: the model keeps the manoeuvre, not the words
    document = load_yaml(read_text(scenario, source), source)
    if isinstance(document, dict) and 'flight' in document:
        print(f'  {describe(parse_flight(Checker(source), document))}')


def _print_bodies(model):
    print(f'  bodies ({len(model.bodies)}):')
    for body in model.bodies:
        if body.fixed:
            detail = 'fixed'
        elif body.motion is not None:
            detail = (f'kinematic, a table of {len(body.motion.times)} rows' if len(
                body.motion.times) else f'kinematic, velocity {vec(body.motion.velocity)} m/s, '
                f'rates {vec(np.degrees(body.motion.rates))} deg/s')
        else:
            detail = (f'{body.mass:g} kg, principal inertia '
                      f'{vec(np.linalg.eigvalsh(body.inertia), "{:.6g}")} kg m^2')
        moved = (f' (cg_offset {vec(body.cg_offset)} m from the nominal CG)'
                 if np.any(body.cg_offset) else '')
        print(f'    {body.name:<16} {detail}; CG {vec(body.position)} m{moved}')


def _print_joints(model):
    print(f'  joints ({len(model.joints)}):')
    for joint in model.joints:
        trans, rot = joint.rows.dof
        print(f'    {joint.name:<16} {joint.kind:<11} '
              f'{model.bodies[joint.parent].name} -> {model.bodies[joint.child].name}; '
              f'frees {trans} translation(s), {rot} rotation(s); '
              f'release: {_describe_release(joint)}'
              + ('' if joint.compliance is None
                 else f'; compliance {vec(joint.compliance, "{:.3g}")}'))
    for group in model.release_groups:
        members = ', '.join(model.joints[k].name for k in group.joints)
        print(f'  release group {group.name}: {members} (one instant)')


def _describe_release(joint) -> str:
    rel = joint.release
    parts = []
    if rel.time is not None:
        parts.append(f'time {rel.time:g} s')
    if rel.angle is not None:
        parts.append(f'angle {math.degrees(rel.angle):g} deg')
    if rel.distance is not None:
        parts.append(f'distance {rel.distance:g} m')
    if rel.force is not None:
        parts.append(f'force {rel.force:g} N')
    return ', '.join(parts) if parts else 'never (or on command)'


def _print_wrenches(model):
    """Print the scheduled loads of a model."""
    print(f'  wrenches ({len(model.wrenches)}):')
    names = [body.name for body in model.bodies]
    for w in model.wrenches:
        axes = model.frame_id if w.frame < 0 else names[w.frame]
        force = (f'{w.table_against} table of {len(w.table)} rows' if len(w.table)
                 else f'{vec(w.force)} N')
        until = ('' if w.end is None else f' to {_when(w.end, w.end_release)}') + (
            '' if w.stroke is None else f' over a stroke of {w.stroke:g} m')
        reacts = '' if w.reacts_on < 0 else f'; reacts on {names[w.reacts_on]}'
        print(f'    {w.name:<16} on {names[w.body]} at {vec(w.point)} m: force {force} '
              f'({axes} axes), from {_when(w.start, w.start_release)}{until}{reacts}')


def _when(time: float, release) -> str:
    """Return a wrench's start or end: a time, or a delay after a release."""
    return f'{time:g} s' if release is None else f'{time:g} s after the release of {release}'


def _print_aero(model):
    names = [b.name for b in model.bodies]
    for aero in model.aero:
        density = (f'density {aero.density:.6g} kg/m^3' if aero.altitude is None else
                   f'ISA from {aero.altitude:g} m (density {aero.density:.6g} kg/m^3 there)')
        print(f'  aero on {names[aero.body]}: S {aero.area:g} m^2, '
              f'L {aero.length:g} m, {density}, '
              f'air {vec(aero.freestream)} m/s, '
              f'table {len(aero.alpha)} alpha x {len(aero.beta)} beta x {len(aero.mach)} Mach')
        more = describe_aero(aero, names)
        if more:
            print(f'    {more}')


def _print_braces_and_contacts(model):
    names = [b.name for b in model.bodies]
    for brace in model.braces:
        damping = f', damping {brace.damping:g} N s/m' if brace.damping else ''
        print(f'  sway brace {brace.name}: {names[brace.carrier]} pushes {names[brace.body]} '
              f'at {vec(brace.point)} m along {vec(brace.direction, "{:.4g}")} '
              f'({names[brace.body]} axes); preload {brace.preload:g} N, '
              f'stiffness {brace.stiffness:g} N/m{damping}')
    for pair in model.contacts:
        a, b = (names[i] for i in pair.bodies)
        print(f'  contact watched: {a} - {b} ({"stop" if pair.stop else "continue"} at contact)')
