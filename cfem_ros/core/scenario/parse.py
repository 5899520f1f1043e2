# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Scenario files (SPEC section 1): YAML in, a validated ``Model`` out.

Every mistake is refused before anything runs, with a ``ScenarioError`` that
names the file, the key path, the value and what would be right, on one line.
Hostile files (huge, binary, devices, alias bombs, deep nesting) are refused
within fixed bounds of time and memory, and values outside the ranges a run
can represent (see the constants below) are refused by ``check`` already.
"""

from __future__ import annotations

from dataclasses import replace
import math
import os
from typing import Any, Optional

from cfem_ros.core.fileio.instants import instant_ns, MAX_SECONDS
from cfem_ros.core.fileio.messages import clip, show
from cfem_ros.core.fileio.textfile import display, read_text
from cfem_ros.core.fileio.yamlfile import load_yaml
from cfem_ros.core.model.graph import carriers
from cfem_ros.core.model.model import (
    BAUMGARTE_DT_LIMIT, default_baumgarte, Model, STANDARD_GRAVITY)
from cfem_ros.core.scenario import aeroparse, aeroscale, braces, flight
from cfem_ros.core.scenario.bodies import parse_body
from cfem_ros.core.scenario.checker import (
    body_of, Checker, key_path, MAX_STEPS, MIN_DT, source_dir)
from cfem_ros.core.scenario.contacts import parse_contacts
from cfem_ros.core.scenario.joints import (
    parse_joint, parse_release_groups, release_names, with_group_releases)
from cfem_ros.core.scenario.wrenches import parse_wrenches
import numpy as np


TOP_KEYS = ('name', 'frame_id', 'gravity', 'duration', 'dt', 'baumgarte', 'bodies', 'joints',
            'wrenches', 'aero', 'release_groups', 'contacts', 'sway_braces', 'flight',
            'start_time', 'load_scale')

#: Longest scenario ``name`` (it goes into recordings, not topics).
MAX_TITLE_LENGTH = 200
#: The load arrows' scales a scenario may state (``load_scale``), N per m of arrow.
LOAD_SCALE_RANGE = (1e-9, 1e12)


def load_scenario(path: str, *, duration: Optional[float] = None,
                  dt: Optional[float] = None) -> Model:
    """
    Read and validate a scenario file.

    Parameters
    ----------
    path : str
        The YAML file: a regular file of at most ``MAX_FILE_BYTES``, UTF-8.
    duration, dt : float, optional
        Overrides of the file's values (s), as ``cfem-sim run`` takes them.

    Raises
    ------
    ScenarioError
        For anything wrong, unreadable file and YAML syntax included.

    """
    source = display(path)
    document = load_yaml(read_text(path, source), source)
    return parse_scenario(document, source=source, duration=duration, dt=dt)


def parse_scenario(document: Any, *, source: str = '<scenario>',
                   duration: Optional[float] = None, dt: Optional[float] = None) -> Model:
    """
    Validate a scenario already loaded from YAML and build the model.

    Parameters
    ----------
    document : dict
        The scenario mapping (SPEC section 1).
    source : str
        Named in error messages (the file name).
    duration, dt : float, optional
        Overrides of the document's values, s.

    Raises
    ------
    ScenarioError
        For anything wrong, on one line of at most a few hundred characters.

    """
    check = Checker(clip(source, 400))
    top = check.mapping(document, '', TOP_KEYS, required=('bodies',))
    default_name = os.path.splitext(os.path.basename(source))[0]
    name = top.get('name', default_name)
    if not isinstance(name, str):
        check.fail('name', f'is {show(name)}', 'a string')
    if 'name' in top and (not name.isprintable() or len(name) > MAX_TITLE_LENGTH):
        check.fail('name', f'is {show(name)}',
                   f'one line of at most {MAX_TITLE_LENGTH} printable characters')
    frame_id = check.name(top.get('frame_id', 'world'), 'frame_id')
    gravity = (check.vector(top['gravity'], 'gravity') if 'gravity' in top
               else np.array([0.0, 0.0, -STANDARD_GRAVITY]))
    run_duration = check.number(top.get('duration', 10.0), 'duration', positive=True)
    step = check.number(top.get('dt', 0.001), 'dt', positive=True)
    step_key, duration_key = 'dt', 'duration'
    if duration is not None:
        run_duration = check.number(duration, '--duration', positive=True)
        duration_key = '--duration'
    if dt is not None:
        step = check.number(dt, '--dt', positive=True)
        step_key = '--dt'
    if step < MIN_DT:
        check.fail(step_key, f'is {step:g} s', f'a step of at least {MIN_DT:g} s')
    if run_duration / step > MAX_STEPS:
        check.fail(duration_key, f'is {run_duration:g} s, {run_duration / step:.3g} steps of '
                   f'{step:g} s', f'at most {MAX_STEPS:.0e} steps (duration / dt)')
    if 'baumgarte' in top:
        eta = check.number(top['baumgarte'], 'baumgarte', minimum=0.0)
    else:
        eta = default_baumgarte(step)
    if eta * step >= BAUMGARTE_DT_LIMIT:
        check.fail('baumgarte', f'is {eta:g} 1/s, so baumgarte * dt = {eta * step:g} leaves '
                   "RK4's stability region", f'baumgarte < {BAUMGARTE_DT_LIMIT / step:g} 1/s '
                   f'at dt = {step:g} s (0.02-0.2 divided by dt is accurate)')

    bodies_doc = top['bodies']
    if not isinstance(bodies_doc, dict) or not bodies_doc:
        check.fail('bodies', f'is {show(bodies_doc)}', 'a non-empty mapping of body names')
    flown = flight.parse_flight(check, top) if 'flight' in top else None
    if flown is not None:
        gravity = flight.gravity_vector(flown)
    else:
        _gravity_with_aero(check, top, gravity)
    bodies = [flight.carrier_body(check, flown, spec) if flown and body_name == flown.carrier
              else parse_body(check, body_name, spec) for body_name, spec in bodies_doc.items()]
    aero_doc = top.get('aero')
    if flown is not None:
        aero_doc = flight.flown_aero(check, flown, aero_doc, bodies[list(bodies_doc).index(
            flown.carrier)])
    if all(b.fixed for b in bodies):
        check.fail('bodies', 'every body is fixed, so nothing can move',
                   'at least one body without fixed: true')
    if not any(b.dynamic for b in bodies):
        check.fail('bodies', 'every body is fixed or kinematic, so no body is moved by forces',
                   'at least one body without fixed: true or motion')
    index = {b.name: i for i, b in enumerate(bodies)}
    if frame_id in index:
        check.fail(f'bodies.{frame_id}', 'has the name of the world frame (frame_id), so a '
                   "wrench's frame_id would be ambiguous", 'a body name other than '
                   f'{frame_id!r}, or another frame_id')

    joints_doc = top.get('joints', {}) or {}
    if not isinstance(joints_doc, dict):
        check.fail('joints', f'is {show(joints_doc)}', 'a mapping of joint names')
    joints = [parse_joint(check, joint_name, spec, index, bodies)
              for joint_name, spec in joints_doc.items()]
    for joint in joints:   # each joint point is a tf frame of its own name (SPEC section 4)
        if joint.name in index or joint.name == frame_id:
            check.fail(key_path('joints', joint.name), 'has the name of a body or of the world '
                       'frame; each is a tf frame, so the frames would clash',
                       'a joint name that is no body name and not ' + repr(frame_id))
    groups = parse_release_groups(check, top.get('release_groups'), joints, joints_doc)
    joints = with_group_releases(joints, groups)
    wrenches = parse_wrenches(check, top.get('wrenches'), index, bodies, frame_id,
                              releases=release_names(joints, groups))
    model = Model(name=name, frame_id=frame_id, gravity=gravity, duration=run_duration,
                  dt=step, baumgarte=eta, bodies=tuple(bodies), joints=tuple(joints),
                  wrenches=wrenches, contacts=parse_contacts(check, top.get('contacts'),
                                                             index, bodies),
                  aero=aeroparse.parse_aero(check, aero_doc, index, bodies, source_dir(check),
                                            gravity),
                  release_groups=groups,
                  braces=braces.parse_braces(check, top.get('sway_braces'), index, bodies,
                                             wrenches, dt=step),
                  start_ns=_start_ns(check, top, run_duration),
                  load_scale=_load_scale(check, top))
    references = _parse_references(check, bodies_doc, index, model)
    if not references:
        return model
    return Model(**{**model.__dict__, 'references': references})


def _gravity_with_aero(check: Checker, top: dict, gravity: np.ndarray):
    """
    Refuse aero tables in a world whose z is up (SPEC section 14).

    The aero conventions are z-down (alpha from w along body z down, CZ
    positive down): a store placed level in a z-up world would fly its
    tables upside down, so a gravity along -z, the default's included, is
    refused with aero rather than taken silently.
    """
    aero = top.get('aero')
    if not isinstance(aero, dict) or not aero or not gravity[2] < 0.0:
        return
    given = 'gravity' in top
    check.fail('gravity', (f'is {show(top["gravity"])}' if given else
                           f'missing, so the default [0, 0, {-STANDARD_GRAVITY:g}] (z up)')
               + ' with aero, and the aero conventions are z-down',
               f'gravity: [0, 0, {STANDARD_GRAVITY:g}] (z down, the bodies placed and turned '
               'in that world) or flight: (z down)')


def _start_ns(check: Checker, top: dict, run_duration: float) -> int:
    """Return the stamp of simulated time 0 of ``start_time`` (ns since 1970, UTC; 0 if none)."""
    if 'start_time' not in top:
        return 0
    try:
        start = instant_ns(top['start_time'])
    except ValueError as err:
        problem, expected = str(err).split('; expected ', 1)
        check.fail('start_time', problem, expected)
    if start + run_duration * 1e9 > MAX_SECONDS * 1e9:
        check.fail('start_time', f'is {show(top["start_time"])}, and the run ends '
                   f'{run_duration:g} s later, past 2038-01-19T03:14:07Z (the last second '
                   'a ROS stamp holds)', 'an earlier start_time or a shorter duration')
    return start


def _load_scale(check: Checker, top: dict) -> Optional[float]:
    """
    Return the load arrows' stated scale, N per m (None if not stated).

    1, 2 or 5 times a power of ten, as the scale found when none is stated:
    every arrow's text states it in one digit (``recording.loadarrows``),
    so another value would be shown rounded.
    """
    if 'load_scale' not in top:
        return None
    value = check.number(top['load_scale'], 'load_scale', positive=True)
    if not LOAD_SCALE_RANGE[0] <= value <= LOAD_SCALE_RANGE[1]:
        check.fail('load_scale', f'is {value:g} N per m', 'from {:g} to {:g} N per m'.format(
            *LOAD_SCALE_RANGE))
    power = 10.0 ** math.floor(math.log10(value))
    for step in (1.0, 2.0, 5.0, 10.0):
        if abs(value - step * power) <= 1e-9 * value:
            return step * power
    below = max(s * power for s in (1.0, 2.0, 5.0) if s * power < value)
    above = min(s * power for s in (2.0, 5.0, 10.0) if s * power > value)
    check.fail('load_scale', f'is {value:g} N per m',
               f'1, 2 or 5 times a power of ten (e.g. {below:g} or {above:g}), the '
               'one digit each arrow states')


def _parse_references(check: Checker, bodies_doc: dict, index: dict, model: Model) -> tuple:
    """Pair each body with its ``reference`` body, or the kinematic body it is joined to."""
    pairs = []
    carried = carriers(model.bodies, model.joints)     # all at once: linear, not per body
    for name, spec in bodies_doc.items():
        i = index[name]
        if isinstance(spec, dict) and 'reference' in spec:
            key = f'{key_path("bodies", name)}.reference'
            ref = body_of(check, spec['reference'], key, index)
            if ref == i:
                check.fail(key, f'is {show(spec["reference"])}, the body itself',
                           'another body')
            pairs.append((i, ref))
        elif model.bodies[i].dynamic and carried[i] >= 0:
            pairs.append((i, carried[i]))
    return tuple(pairs)


def reparse(model: Model, document: Any, *, bodies=(), joints=(), wrenches: bool = False,
            aero=(), unscaled=(), source: str = '<scenario>') -> Model:
    """
    Return a model with some bodies and joints, and the wrenches, parsed again from a document.

    For sweeps: ``parse_scenario(document)`` where document differs from
    the one ``model`` was parsed from only inside the named bodies (not in
    their ``fixed``) and joints, and inside the wrenches if ``wrenches``,
    without parsing the rest again. A body's parse reads nothing else, a
    joint's and a wrench's only the bodies' names and ``fixed`` (and the
    frame's name), and the rest reads of a body only its name and ``fixed``:
    so the result is the whole parse's, number for number, when it does
    not raise (a body's ``cg_offset`` changed raises: its wrenches' points
    move too). ``aero`` names the aero entries whose ``scale`` and ``delta``
    alone differ: they are set on ``unscaled`` (``unscaled_aero`` of the
    document ``model`` was parsed from). An aero entry on a body parsed again
    has its altitude checked again. A ``ScenarioError`` here may not
    be the first one the whole parse would name: parse the whole document
    for the message.
    """
    check = Checker(clip(source, 400))
    top = check.mapping(document, '', TOP_KEYS, required=('bodies',))
    new_bodies = list(model.bodies)
    flown = flight.parse_flight(check, top) if 'flight' in top else None
    for name in bodies:
        i = model.body_index(name)
        if flown is not None and name == flown.carrier:
            raise ValueError('the carrier of flight: sets the aero atmosphere, a whole parse')
        new_bodies[i] = parse_body(check, name, top['bodies'][name])
        if new_bodies[i].fixed != model.bodies[i].fixed:
            check.fail(key_path('bodies', name) + '.fixed', 'changed', 'a whole parse')
        if not np.array_equal(getattr(new_bodies[i], 'cg_offset', 0.0),
                              getattr(model.bodies[i], 'cg_offset', 0.0)):
            raise ValueError('a CG offset moves wrench points too, a whole parse')
    index = {b.name: i for i, b in enumerate(new_bodies)}
    new_joints = list(model.joints)
    for name in joints:
        new_joints[model.joint_index(name)] = parse_joint(
            check, name, top['joints'][name], index, new_bodies)
    new_joints = with_group_releases(new_joints, model.release_groups)
    new_wrenches = model.wrenches
    if wrenches:
        new_wrenches = parse_wrenches(check, top.get('wrenches'), index, new_bodies,
                                      model.frame_id,
                                      releases=release_names(model.joints, model.release_groups))
    new_aero = list(model.aero)
    if aero and flown is not None:
        raise ValueError('flight: sets the aero air, a whole parse')
    for name in aero:
        i = list(top['aero']).index(name)
        new_aero[i] = aeroscale.rescaled(check, unscaled[i], top['aero'][name], f'aero.{name}')
    moved = {model.body_index(n) for n in bodies}
    for i, entry in enumerate(new_aero):
        if entry.body in moved:
            new_aero[i] = _aero_on(check, entry, new_bodies[entry.body], model,
                                   top['aero'][new_bodies[entry.body].name])
    name = top['name'] if 'name' in top else os.path.splitext(os.path.basename(source))[0]
    return Model(**{**model.__dict__, 'name': name, 'bodies': tuple(new_bodies),
                    'joints': tuple(new_joints), 'wrenches': new_wrenches,
                    'aero': tuple(new_aero)})


def _aero_on(check: Checker, aero, body, model: Model, spec: dict):
    """Return an aero entry on its body parsed again: its altitude checked, its CG followed."""
    if body.dynamic != model.bodies[aero.body].dynamic:
        raise ValueError('a body moved by forces or not, a whole parse')
    key = f'aero.{body.name}'   # as aeroparse names it
    if aero.altitude is not None:
        aeroparse.body_altitude(check, model.gravity, body, aero.altitude,
                                aeroparse.altitude_key(spec, key))
    cg_offset = np.asarray(getattr(body, 'cg_offset', np.zeros(3)), float)
    return replace(aero, reference_from_cg=aero.reference_point - cg_offset)


def unscaled_aero(model: Model, document: Any, source: str = '<scenario>') -> tuple:
    """
    Return the aero entries of the document ``model`` was parsed from, unscaled.

    Their ``scale`` and ``delta`` are checked and not applied: what
    ``reparse`` sets a run's on. A document with ``flight:`` has none here.
    """
    if 'flight' in document or not document.get('aero'):
        return ()
    check = Checker(clip(source, 400))
    index = {b.name: i for i, b in enumerate(model.bodies)}
    return aeroparse.parse_aero(check, document['aero'], index, model.bodies,
                                source_dir(check), model.gravity, unscaled=True)
