# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What ``cfem-sim check`` tells before a run: can it start, and will RK4 hold.

``start_problems`` runs the computations of a run's first sample (the
state derivative and the joint loads at t = 0) and estimates the products
that overflow (dynamic pressure times area times a coefficient), so that a
scenario the run cannot start is refused with its physical reason (an
anchor far beyond the bodies it joins, aerodynamic loads beyond double
precision) instead of the run failing at t = 0. What only the run can tell
(an explicit step too long for a spin rate or an aerodynamic damping) is
returned as a warning.

Check, run, the node and ``batch.run`` ask before they start. Every other
run (the Python API, sweeps, fits, predictions) asks only when it ends
within its first step (``start_refusal``, which ``Simulator`` calls as it
fails or stops): a run that starts fine pays nothing, and one check refuses
ends with check's line.
"""

from __future__ import annotations

import logging
import math

from cfem_ros.core.engine.events import Failure, Status
from cfem_ros.core.engine.sampling import NumericalFailure, SINGULAR
from cfem_ros.core.errors import CfemError
from cfem_ros.core.native import kernel
import numpy as np

__all__ = ['cannot_analyse', 'cannot_start', 'CannotStart', 'ended_at_start', 'refuse_start',
           'RK4_STABILITY', 'start_problems', 'start_refusal']

#: Explicit RK4 on y' = -k y is stable for k dt up to about 2.785; beyond it
#: the run diverges. A spin of w rad/s asks for w dt well under 1 rad.
RK4_STABILITY = 2.785
#: Turn per step beyond which a spin is resolved too coarsely by RK4, rad.
MAX_TURN_PER_STEP = 1.0
#: An anchor this many body sizes from a body's CG, or more, is named as the
#: likely reason of a singular joint-load solve.
FAR_ANCHOR = 1e4
#: Steps over which the aerodynamic loads' feedback on speed and rates is followed.
FIRST_STEPS = 5
#: A logger that says nothing: the trial simulators' (the scenario's own has said it).
QUIET = logging.getLogger('cfem_ros.startcheck.trial')
QUIET.addHandler(logging.NullHandler())
QUIET.propagate = False


def _size(body) -> float:
    """Return a body's size, m: its largest radius of gyration (1 m if it has none)."""
    if not body.dynamic or not body.mass > 0.0:
        return 1.0
    with np.errstate(all='ignore'):
        radius = math.sqrt(max(float(np.linalg.eigvalsh(body.inertia).max()), 0.0) / body.mass)
    return radius if math.isfinite(radius) and radius > 0.0 else 1.0


def _farthest_anchor(model):
    """Return (ratio, text) of the joint anchor farthest from a body it joins, in body sizes."""
    worst = (0.0, '')
    for joint in model.joints:
        for index in (joint.child, joint.parent):
            body = model.bodies[index]
            if not body.dynamic:
                continue
            with np.errstate(all='ignore'):
                distance = float(np.linalg.norm(np.asarray(joint.anchor) - body.position))
            size = _size(body)
            ratio = distance / size
            if ratio > worst[0]:
                worst = (ratio, f'joint {joint.name!r}: its anchor is {distance:.3g} m from '
                                f'the CG of {body.name}, {ratio:.3g} times its size '
                                f'(radius of gyration {size:.3g} m)')
    return worst


def _aero_products(model) -> tuple:
    """
    Return (errors, warnings) of the aerodynamic loads' magnitudes.

    The products are taken at t = 0 and after one step (the speed and rates
    the t = 0 loads give over dt): one beyond double precision is an error;
    a damping that RK4 cannot integrate with dt is a warning (a run whose
    rates stay zero never meets it).
    """
    errors, warnings = [], []
    for aero in model.aero:
        body = model.bodies[aero.body]
        if not body.dynamic:
            continue
        with np.errstate(all='ignore'):
            speed = float(np.linalg.norm(aero.freestream) + np.linalg.norm(body.velocity_world))
            # the coefficients as the step takes them: table, delta and the largest increment
            table = np.abs(aero.coefficients + aero.delta)
            if aero.proximity is not None:
                table = table + np.abs(aero.proximity.increments).reshape(-1, 6).max(axis=0)
            inertia = np.diag(body.inertia).astype(float)
            damping = np.abs(aero.damping).astype(float)
            moment_max = float(table[..., 3:].max(initial=0.0))
            force_max = float(table[..., :3].max(initial=0.0))

            def loads(v, rates):
                pressure = float(kernel.dynamic_pressure(aero.density, v)) * aero.area
                force = pressure * force_max
                per_rate = pressure * aero.length * aero.length / (2.0 * v) if v > 0 else 0.0
                moment = pressure * aero.length * moment_max + per_rate * damping * rates
                return pressure, force, moment, per_rate

            pressure, force, moment, per_rate = loads(speed, np.abs(body.rates_body))
            v, rates, after = speed, np.abs(body.rates_body), (force, moment)
            for _ in range(FIRST_STEPS):   # magnitudes only: how the loads feed back
                v = v + after[0] / body.mass * model.dt
                rates = rates + np.abs(after[1]) / inertia * model.dt
                after = loads(v, rates)[1:3]
            kick, spin = v, rates
        how = (f'density {aero.density:.3g} kg/m^3, air speed {speed:.3g} m/s, area '
               f'{aero.area:.3g} m^2, length {aero.length:.3g} m, max |CX, CY, CZ| '
               f'{force_max:.3g}, max |Cl, Cm, Cn| {moment_max:.3g}, max |Clp, Cmq, Cnr| '
               f'{float(damping.max(initial=0.0)):.3g}')
        if not (math.isfinite(pressure) and math.isfinite(force) and np.isfinite(moment).all()):
            errors.append(f'aero.{body.name}: the aerodynamic loads at t = 0 overflow ({how}: '
                          'beyond double precision); expected realistic density, speed and '
                          'coefficients')
        elif not (math.isfinite(kick) and np.isfinite(spin).all()
                  and all(np.isfinite(np.asarray(x)).all() for x in after)):
            errors.append(f'aero.{body.name}: the aerodynamic loads overflow within the first '
                          f'{FIRST_STEPS} steps of dt {model.dt:g} s ({how}: the speed and '
                          'rates they give make loads beyond double precision); expected '
                          'realistic coefficients')
        else:
            decay = float((per_rate * damping / inertia).max(initial=0.0))
            if decay * model.dt > RK4_STABILITY:
                warnings.append(
                    f'aero.{body.name}: the damping coefficients (Clp, Cmq, Cnr) damp the '
                    f'rates at up to {decay:.3g} 1/s; RK4 with dt {model.dt:g} s is unstable '
                    f'beyond {RK4_STABILITY / model.dt:.3g} 1/s, so any rate will grow and '
                    f'the run diverge (expected dt below {RK4_STABILITY / decay:.3g} s)')
    return errors, warnings


def _spin_warnings(model) -> list:
    warnings = []
    for body in model.bodies:
        if not body.dynamic:
            continue
        rate = float(np.linalg.norm(body.rates_body))
        if rate * model.dt > MAX_TURN_PER_STEP:
            warnings.append(
                f'bodies.{body.name}: spins at {np.degrees(rate):.3g} deg/s, '
                f'{np.degrees(rate * model.dt):.3g} deg per '
                f'RK4 step of dt {model.dt:g} s; the run will likely diverge (expected dt '
                f'below {MAX_TURN_PER_STEP / rate:.3g} s)')
    return warnings


def start_problems(sim) -> tuple:
    """
    Return (errors, warnings) for a simulator about to start: lists of one-line reasons.

    An error means the run cannot start (or diverges at its first step);
    a warning names what only the run can tell.
    """
    model = sim.model
    errors, warnings = _aero_products(model)
    warnings += _spin_warnings(model)
    if sim.status is Status.AERO_OUTSIDE:   # outside: stop, and outside from t = 0
        return errors + [_stops_at_start(sim.reason)], warnings   # the stop, not check's line
    try:
        with np.errstate(all='ignore'):
            derivative = sim.derivative(sim.y)
            force, moment = sim.joint_wrenches()
    except NumericalFailure as err:
        errors.append(f'the joints cannot be solved at t = 0 ({err}): {_why_singular(model)}')
        return errors, warnings
    if not (np.isfinite(derivative).all() and np.isfinite(force).all()
            and np.isfinite(moment).all()):
        errors.append('the accelerations or joint loads at t = 0 are not finite: masses, '
                      'inertias or loads whose products are beyond double precision')
        return errors, warnings
    trial = _failed_first_step(sim)
    if trial is None:
        pass
    elif trial.status is Status.AERO_OUTSIDE:
        errors.append(_stops_at_start(trial.message))
    elif trial.failure is Failure.SINGULAR:
        errors.append(f'the first step cannot be solved ({SINGULAR}): {_why_singular(model)}')
    else:
        failed = trial.reason if trial.t == 0.0 else f'at t = {trial.t:.3g} s, {trial.reason}'
        errors.append(f'the first step of dt {model.dt:g} s fails ({failed}): loads, masses, '
                      'inertias or rates (a table value, a coefficient) whose products go '
                      'beyond double precision within a step; expected realistic values')
    return errors, warnings


class CannotStart(CfemError):
    """A scenario ``cfem-sim check`` refuses to start; the message is check's line."""


def refuse_start(sim, scenario: str) -> list:
    """
    Raise CannotStart, with check's line, if sim cannot start; else return check's warnings.

    scenario: how the line names the scenario (its file, as check does).
    """
    errors, warnings = start_problems(sim)
    if errors:
        raise CannotStart(cannot_start(scenario, errors))
    return warnings


def ended_at_start(sim) -> bool:
    """
    Tell whether a simulator's run ended within its first step.

    It failed at a time no later than its step dt (the last good state is
    the start, or within the first step, or the first step's end whose
    check failed), or a table's ``outside: stop`` ended it at t = 0: the
    two ends ``start_problems`` looks for.
    """
    if sim.status is Status.FAILED:
        return sim.t <= sim.dt
    return sim.status is Status.AERO_OUTSIDE and sim.t == 0.0


def start_refusal(sim) -> str:
    """
    Return check's line for a run that ended within its first step ('' if check passes).

    Asked only of a run that ``ended_at_start`` (otherwise '' at once): its
    model is checked at its start as ``cfem-sim check`` checks it, on a
    new simulator (the state, loads and inputs given to sim since are not
    the scenario's). The scenario is named as ``batch.run`` names it.
    """
    if not ended_at_start(sim):
        return ''
    scenario = f'scenario {sim.model.name!r}'
    try:
        with np.errstate(all='ignore'):
            errors, _ = start_problems(type(sim)(sim.model, logger=QUIET, check_start=False))
    except (ArithmeticError, np.linalg.LinAlgError) as err:
        return cannot_analyse(scenario, err)
    return cannot_start(scenario, errors) if errors else ''


def cannot_analyse(scenario: str, err: Exception) -> str:
    """Return check's line of a scenario whose start the arithmetic itself refuses (err)."""
    why = ' '.join(str(err).split())[:120]
    return (f'{scenario}: the joints cannot be analysed at t = 0 ({type(err).__name__}: '
            f'{why}); expected a regular configuration')


def cannot_start(scenario: str, errors: list) -> str:
    """Return the one line of a scenario ``start_problems`` refuses (check, run, the node)."""
    more = f' (and {len(errors) - 1} more problem(s))' if len(errors) > 1 else ''
    return f'{scenario}: cannot start: {errors[0]}{more}'


def _stops_at_start(message: str) -> str:
    """Return the error of a run that a table's ``outside: stop`` ends as it starts."""
    return (f'the run would end as it starts: {message}; expected a table whose range covers '
            'the start (the air at t = 0), or outside: hold (the tables held at their edges, '
            'each time outside an aero_outside event)')


def _why_singular(model) -> str:
    """Return the likely reason why the joints' rows cannot be solved."""
    ratio, where = _farthest_anchor(model)
    if ratio >= FAR_ANCHOR:
        return (where + '; the joint rows then span more than double precision can solve; '
                'expected anchors near the bodies they join')
    return 'joint axes parallel or degenerate?'


def _failed_first_step(sim):
    """
    Return the simulator whose first step of dt failed (None if it does not).

    The step is taken by a new simulator of the same model (the one given
    stays at t = 0), with the scenario's own loads and no inputs: a run
    that fails within it never reaches its first step's end, which is the
    scenario's own fault (a coefficient of 1e30 diverges within the step);
    what grows later is the run's to tell. A table's ``outside: stop``
    ending the run at t = 0 (an angle that jumps out of its table as the
    body starts to move through still air) is returned too (its status
    ``AERO_OUTSIDE``); its failure (``Simulator.failure``) says which.
    """
    model = sim.model
    if not model.duration > 0.0:
        return None
    with np.errstate(all='ignore'):
        trial = type(sim)(model, logger=QUIET, check_start=False)
        if trial.advance_to(min(model.dt, model.duration), release_at_end=False):
            return None
    if trial.status is Status.AERO_OUTSIDE and trial.t == 0.0:
        return trial
    return trial if trial.status is Status.FAILED else None
