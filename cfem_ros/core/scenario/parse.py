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

import logging
import math
import os
import re
from typing import Any, Optional

from cfem_ros.core import rotations
from cfem_ros.core.engine import braces
from cfem_ros.core.engine.atmosphere import isa_density  # noqa: F401 - where it has always been
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.fileio.messages import clip, show
from cfem_ros.core.fileio.textfile import display, read_text
from cfem_ros.core.fileio.yamlfile import load_yaml, Yaml11Number
from cfem_ros.core.model import shapes
from cfem_ros.core.model.model import (
    AXIS_REQUIRED, BAUMGARTE_DT_LIMIT, Body, Contact, default_baumgarte, Joint,
    JOINT_TABLE, Model, Motion, Release, ReleaseGroup, STANDARD_GRAVITY, triad_from_axes, Wrench)
from cfem_ros.core.scenario import aeroparse, cgoffset
import numpy as np


LOG = logging.getLogger('cfem_ros')

TOP_KEYS = ('name', 'frame_id', 'gravity', 'duration', 'dt', 'baumgarte', 'bodies', 'joints',
            'wrenches', 'aero', 'release_groups', 'contacts', 'sway_braces')
BODY_KEYS = ('fixed', 'mass', 'inertia', 'position', 'orientation_rpy_deg',
             'orientation_xyzw', 'velocity', 'angular_velocity_deg', 'angular_velocity', 'shape',
             'motion', 'reference', 'cg_offset')
MOTION_KEYS = ('velocity', 'angular_velocity_deg', 'angular_velocity', 'table')
#: Columns of a motion table (a CSV file's header may name them in any order).
MOTION_COLUMNS = ('t', 'x', 'y', 'z', 'qx', 'qy', 'qz', 'qw')
#: How far a motion table's quaternion may be from unit length (it is normalized).
MOTION_QUATERNION_TOLERANCE = 1e-3
JOINT_KEYS = ('type', 'parent', 'child', 'anchor', 'axis', 'axis2', 'release', 'compliance')
GROUP_KEYS = ('joints', 'release')
#: A wrench's start or end tied to a release (SPEC section 7).
TIED_KEYS = ('release', 'delay')
RELEASE_KEYS = ('time', 'angle_deg', 'distance', 'force')
WRENCH_KEYS = ('name', 'body', 'point', 'force', 'moment', 'frame', 'start', 'end', 'stroke',
               'reacts_on')
TABLE_KEYS = ('against', 'table')


#: Names become ROS topic tokens (bodies/<body>/pose), so they must be valid ones.
NAME_PATTERN = re.compile(r'[A-Za-z][A-Za-z0-9_]*')

#: Longest name, so that the longest topic the node makes,
#: /cfem/bodies/<body>/applied/<source> (150 characters), stays far below
#: ROS's limit of 247 characters for a topic name, with room for a namespace.
MAX_NAME_LENGTH = 64

#: Longest scenario ``name`` (it goes into recordings, not topics).
MAX_TITLE_LENGTH = 200

#: Mass of a body that is not fixed, kg: a milligram to a small moon.
MASS_RANGE = (1e-6, 1e12)

#: Each principal moment of inertia, kg m^2 (1 mg at 1 mm to 1e12 kg at 1 km).
INERTIA_RANGE = (1e-12, 1e18)

#: Largest magnitude of any position, anchor, velocity, gravity, orientation
#: or angular velocity component, in the unit of its key.
MAX_MAGNITUDE = 1e9

#: Smallest RK4 step, s.
MIN_DT = 1e-9

#: Most RK4 steps in a run, duration / dt.
MAX_STEPS = 1e9

#: |cos| between a universal joint's axes above which they are not perpendicular.
PERPENDICULAR_TOLERANCE = 1e-6

#: Relative slack on the triangle inequality (a thin plate has Izz = Ixx + Iyy).
TRIANGLE_TOLERANCE = 1e-9

#: Axis vectors with a component larger than this are scaled down before use.
_AXIS_RESCALE = 1e100


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


def _key(parent: str, name: Any) -> str:
    """Return the key path of entry name under parent, safe to show."""
    if isinstance(name, str) and name.isprintable() and len(name) <= 80:
        shown = name
    else:
        shown = f'[{show(name)}]'
    return f'{parent}.{shown}' if parent else shown


def _one_of(names) -> str:
    names = [str(n) for n in names]
    shown = ', '.join(names[:8]) + (f' (and {len(names) - 8} more)' if len(names) > 8 else '')
    return 'one of ' + clip(shown, 200)


class _Checker:
    """Typed accessors that raise ScenarioError with the key path."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, key: str, problem: str, expected: str = ''):
        raise ScenarioError(self.source, clip(key, 120), clip(problem, 240),
                            clip(expected, 240))

    def mapping(self, value, key: str, allowed, required=()) -> dict:
        if not isinstance(value, dict):
            self.fail(key, f'is {show(value)}', 'a mapping')
        for name in value:
            if name not in allowed:
                self.fail(_key(key, name), 'unknown key', _one_of(allowed))
        for name in required:
            if name not in value:
                self.fail(_key(key, name), 'missing', 'it to be given')
        return value

    def number(self, value, key: str, *, minimum=None, positive=False,
               limit: Optional[float] = None) -> float:
        if isinstance(value, Yaml11Number):
            reading = '' if value.reading is None else f' ({value.reading!r})'
            self.fail(key, f'is {value} as written, a YAML 1.1 {value.kind} number{reading}',
                      'a decimal number (write what you mean, e.g. 90 or 16.0)')
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, f'is {show(value)}', 'a number')
        try:
            value = float(value)
        except OverflowError:
            self.fail(key, f'is {show(value)}, too large for a double', 'a finite number')
        if not math.isfinite(value):
            self.fail(key, f'is {value}', 'a finite number')
        if positive and value <= 0:
            self.fail(key, f'is {value:g}', 'a number > 0')
        if minimum is not None and value < minimum:
            self.fail(key, f'is {value:g}', f'a number >= {minimum:g}')
        if limit is not None and abs(value) > limit:
            self.fail(key, f'is {value:g}', f'a magnitude of at most {limit:g}')
        return value

    def vector(self, value, key: str, length: int = 3, lengths=None,
               limit: Optional[float] = MAX_MAGNITUDE) -> np.ndarray:
        lengths = lengths or (length,)
        if isinstance(value, (list, tuple)) and len(value) in lengths:
            numbers = _plain_numbers(value, limit)
            if numbers is not None:     # what the checks below give, without their calls
                return np.array(numbers)
        if not isinstance(value, (list, tuple)) or len(value) not in lengths:
            want = ' or '.join(str(n) for n in lengths)
            self.fail(key, f'is {show(value)}', f'a list of {want} numbers')
        return np.array([self.number(v, f'{key}[{i}]', limit=limit)
                         for i, v in enumerate(value)])

    def direction(self, value, key: str) -> np.ndarray:
        """Return a direction of any finite length, scaled so that norms cannot overflow."""
        vector = self.vector(value, key, limit=None)
        x, y, z = vector.tolist()
        scale = max(abs(x), abs(y), abs(z))
        if 1e-12 <= scale <= _AXIS_RESCALE:
            # kept as it is; its norm, scale * |vector / scale| >= scale * 1, is not < 1e-12
            return vector
        if scale > _AXIS_RESCALE:
            vector = vector / scale
            scale = 1.0
        if scale == 0.0 or scale * np.linalg.norm(vector / scale) < 1e-12:
            self.fail(key, f'has zero length {show(value)}', 'a non-zero direction')
        return vector

    def name(self, value, key: str) -> str:
        if not isinstance(value, str) or not NAME_PATTERN.fullmatch(value):
            self.fail(key, f'{show(value)} is not a usable name',
                      'a letter then letters, digits or _ (it becomes a ROS topic name)')
        if len(value) > MAX_NAME_LENGTH:
            self.fail(key, f'{show(value)} has {len(value)} characters',
                      f'a name of at most {MAX_NAME_LENGTH} characters (it becomes part of '
                      'ROS topic names)')
        return value


def _plain_numbers(value, limit: Optional[float]) -> Optional[list]:
    """
    Return value's items as floats if each is an int or float that ``_Checker.number`` takes.

    Only items of type exactly int or float, finite and of magnitude at most
    limit (if given); None for anything else, which the checks then name.
    """
    numbers = []
    for item in value:
        kind = type(item)
        if kind is float:
            number = item
        elif kind is int:
            try:
                number = float(item)
            except OverflowError:
                return None
        else:
            return None
        if limit is None:
            if not math.isfinite(number):
                return None
        elif not -limit <= number <= limit:    # NaN and infinities fail too
            return None
        numbers.append(number)
    return numbers


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
    check = _Checker(clip(source, 400))
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
    bodies = [_parse_body(check, body_name, spec)
              for body_name, spec in bodies_doc.items()]
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
    joints = [_parse_joint(check, joint_name, spec, index, bodies)
              for joint_name, spec in joints_doc.items()]
    for joint in joints:   # each joint point is a tf frame of its own name (SPEC section 4)
        if joint.name in index or joint.name == frame_id:
            check.fail(_key('joints', joint.name), 'has the name of a body or of the world '
                       'frame; each is a tf frame, so the frames would clash',
                       'a joint name that is no body name and not ' + repr(frame_id))
    groups = _parse_release_groups(check, top.get('release_groups'), joints, joints_doc)
    joints = _with_group_releases(joints, groups)
    wrenches = _parse_wrenches(check, top.get('wrenches'), index, bodies, frame_id,
                               releases=_release_names(joints, groups))
    model = Model(name=name, frame_id=frame_id, gravity=gravity, duration=run_duration,
                  dt=step, baumgarte=eta, bodies=tuple(bodies), joints=tuple(joints),
                  wrenches=wrenches, contacts=_parse_contacts(check, top.get('contacts'),
                                                              index, bodies),
                  aero=aeroparse.parse_aero(check, top.get('aero'), index, bodies,
                                            _source_dir(check)),
                  release_groups=groups,
                  braces=braces.parse_braces(check, top.get('sway_braces'), index, bodies,
                                             wrenches))
    references = _parse_references(check, bodies_doc, index, model)
    if not references:
        return model
    return Model(**{**model.__dict__, 'references': references})


def _parse_references(check: _Checker, bodies_doc: dict, index: dict, model: Model) -> tuple:
    """Pair each body with its ``reference`` body, or the kinematic body it is joined to."""
    pairs = []
    for name, spec in bodies_doc.items():
        i = index[name]
        if isinstance(spec, dict) and 'reference' in spec:
            key = f'{_key("bodies", name)}.reference'
            ref = _body_of(check, spec['reference'], key, index)
            if ref == i:
                check.fail(key, f'is {show(spec["reference"])}, the body itself',
                           'another body')
            pairs.append((i, ref))
        elif model.bodies[i].dynamic and model.carrier(i) >= 0:
            pairs.append((i, model.carrier(i)))
    return tuple(pairs)


def _parse_body(check: _Checker, name, spec) -> Body:
    key = _key('bodies', name)
    check.name(name, key)
    spec = check.mapping(spec if spec is not None else {}, key, BODY_KEYS)
    fixed = spec.get('fixed', False)
    if not isinstance(fixed, bool):
        check.fail(f'{key}.fixed', f'is {show(fixed)}', 'true or false')
    if 'cg_offset' in spec and (fixed or 'motion' in spec):
        check.fail(f'{key}.cg_offset', 'given on a fixed or kinematic body',
                   'no cg_offset (it moves the CG of a body moved by forces)')
    if 'motion' in spec:
        return _parse_kinematic(check, name, key, spec, fixed)
    if fixed:
        mass, inertia = 0.0, np.zeros((3, 3))
        for moving in ('velocity', 'angular_velocity_deg', 'angular_velocity'):
            if moving in spec and np.any(check.vector(spec[moving], f'{key}.{moving}')):
                check.fail(f'{key}.{moving}', f'is {show(spec[moving])} on a fixed body',
                           'no velocity (a fixed body never moves)')
        ignored = [k for k in ('mass', 'inertia') if k in spec]
        if ignored:
            LOG.warning('%s: %s: %s ignored: a fixed body never moves', check.source, key,
                        ' and '.join(ignored))
    else:
        for required in ('mass', 'inertia'):
            if required not in spec:
                check.fail(f'{key}.{required}', 'missing',
                           'it to be given for a body that is not fixed')
        mass = check.number(spec['mass'], f'{key}.mass', positive=True)
        if not MASS_RANGE[0] <= mass <= MASS_RANGE[1]:
            check.fail(f'{key}.mass', f'is {mass:g} kg',
                       f'a mass from {MASS_RANGE[0]:g} to {MASS_RANGE[1]:g} kg')
        inertia = _parse_inertia(check, spec['inertia'], f'{key}.inertia')
    position = check.vector(spec.get('position', [0, 0, 0]), f'{key}.position')
    if 'orientation_rpy_deg' in spec and 'orientation_xyzw' in spec:
        check.fail(f'{key}.orientation_xyzw', 'given together with orientation_rpy_deg',
                   'one of the two')
    if 'orientation_xyzw' in spec:
        quat = check.vector(spec['orientation_xyzw'], f'{key}.orientation_xyzw', 4)
        norm = np.linalg.norm(quat)
        if abs(norm - 1.0) > 1e-6:
            check.fail(f'{key}.orientation_xyzw', f'has norm {norm:.9g}',
                       'a unit quaternion [x, y, z, w]')
        quat = quat / norm
    else:
        rpy = check.vector(spec.get('orientation_rpy_deg', [0, 0, 0]),
                           f'{key}.orientation_rpy_deg')
        quat = _from_rpy_deg(rpy)
    velocity = check.vector(spec.get('velocity', [0, 0, 0]), f'{key}.velocity')
    if 'angular_velocity_deg' in spec and 'angular_velocity' in spec:
        check.fail(f'{key}.angular_velocity', 'given together with angular_velocity_deg',
                   'one of the two')
    if 'angular_velocity' in spec:
        rates = check.vector(spec['angular_velocity'], f'{key}.angular_velocity')
    else:
        rates = np.radians(check.vector(spec.get('angular_velocity_deg', [0, 0, 0]),
                                        f'{key}.angular_velocity_deg'))
    shape = None
    if 'shape' in spec:
        shape = shapes.parse_shape(
            spec['shape'], f'{key}.shape', check.fail, check.number, check.vector,
            _shape_dir(check, spec['shape']))
    cg_offset = check.vector(spec.get('cg_offset', [0, 0, 0]), f'{key}.cg_offset')
    body = Body(name=name, fixed=fixed, mass=mass, inertia=inertia, position=position,
                orientation_xyzw=quat, velocity_world=velocity, rates_body=rates, shape=shape,
                velocity_given=('velocity' in spec or 'angular_velocity_deg' in spec
                                or 'angular_velocity' in spec))
    return cgoffset.moved(body, cg_offset)


#: Quaternions of the attitudes parsed, by the exact bits of their angles (a
#: sweep's runs parse the same few again and again).
_QUATERNIONS = {}


def _from_rpy_deg(rpy: np.ndarray) -> np.ndarray:
    """Return ``rotations.from_rpy_deg(rpy)`` (a new array), computed once per distinct rpy."""
    key = rpy.tobytes()
    quat = _QUATERNIONS.get(key)
    if quat is None:
        quat = rotations.from_rpy_deg(rpy)
        if len(_QUATERNIONS) >= 1024:
            _QUATERNIONS.clear()
        _QUATERNIONS[key] = quat
    return quat.copy()


def _source_dir(check: _Checker) -> str:
    """
    Return the folder of the scenario file, which files it names are relative to.

    A sweep names its runs' sources ``<file> (run k)``: the file is what counts.
    """
    source = check.source
    if not os.path.isfile(source):
        source = re.sub(r' \(run \d+\)$', '', source)
    return os.path.dirname(os.path.abspath(source)) if os.path.isfile(source) else ''


def _shape_dir(check: _Checker, shape) -> str:
    """Return the folder a shape's mesh file is relative to (only a mesh needs one)."""
    if isinstance(shape, dict) and 'mesh' in shape:
        return _source_dir(check)
    return ''


def _parse_kinematic(check: _Checker, name, key: str, spec: dict, fixed: bool) -> Body:
    """Parse a body with ``motion``: it follows it, forces ignored (SPEC section 5)."""
    if fixed:
        check.fail(f'{key}.motion', 'given on a fixed body', 'fixed: true or motion, not both')
    for moving in ('velocity', 'angular_velocity_deg', 'angular_velocity'):
        if moving in spec:
            check.fail(f'{key}.{moving}', 'given on a kinematic body',
                       f'{key}.motion.{moving} (the motion gives its velocities)')
    ignored = [k for k in ('mass', 'inertia') if k in spec]
    if ignored:
        LOG.warning('%s: %s: %s ignored: a kinematic body follows its motion', check.source,
                    key, ' and '.join(ignored))
    mkey = f'{key}.motion'
    motion = check.mapping(spec['motion'], mkey, MOTION_KEYS)
    if not motion:
        check.fail(mkey, 'is empty', 'velocity and/or angular_velocity_deg, or a table')
    if 'angular_velocity_deg' in motion and 'angular_velocity' in motion:
        check.fail(f'{mkey}.angular_velocity', 'given together with angular_velocity_deg',
                   'one of the two')
    shape = None
    if 'shape' in spec:
        shape = shapes.parse_shape(
            spec['shape'], f'{key}.shape', check.fail, check.number, check.vector,
            _shape_dir(check, spec['shape']))
    if 'table' in motion:
        for other in ('velocity', 'angular_velocity_deg', 'angular_velocity'):
            if other in motion:
                check.fail(f'{mkey}.{other}', 'given together with a table',
                           'a table or constant velocities, not both')
        for pose in ('position', 'orientation_rpy_deg', 'orientation_xyzw'):
            if pose in spec:
                check.fail(f'{key}.{pose}', 'given on a body that follows a table',
                           'none (the table gives the pose at t = 0)')
        times, positions, quats = _parse_motion_table(check, motion['table'], f'{mkey}.table')
        data = Motion(times=times, positions=positions, quaternions=quats)
        position, quat = _motion_start(data)
        return Body(name=name, fixed=False, mass=0.0, inertia=np.zeros((3, 3)),
                    position=position, orientation_xyzw=quat, velocity_world=np.zeros(3),
                    rates_body=np.zeros(3), shape=shape, motion=data)
    velocity = check.vector(motion.get('velocity', [0, 0, 0]), f'{mkey}.velocity')
    if 'angular_velocity' in motion:
        rates = check.vector(motion['angular_velocity'], f'{mkey}.angular_velocity')
    else:
        rates = np.radians(check.vector(motion.get('angular_velocity_deg', [0, 0, 0]),
                                        f'{mkey}.angular_velocity_deg'))
    position = check.vector(spec.get('position', [0, 0, 0]), f'{key}.position')
    if 'orientation_rpy_deg' in spec and 'orientation_xyzw' in spec:
        check.fail(f'{key}.orientation_xyzw', 'given together with orientation_rpy_deg',
                   'one of the two')
    if 'orientation_xyzw' in spec:
        quat = check.vector(spec['orientation_xyzw'], f'{key}.orientation_xyzw', 4)
        norm = np.linalg.norm(quat)
        if abs(norm - 1.0) > 1e-6:
            check.fail(f'{key}.orientation_xyzw', f'has norm {norm:.9g}',
                       'a unit quaternion [x, y, z, w]')
        quat = quat / norm
    else:
        quat = _from_rpy_deg(check.vector(spec.get('orientation_rpy_deg', [0, 0, 0]),
                                          f'{key}.orientation_rpy_deg'))
    return Body(name=name, fixed=False, mass=0.0, inertia=np.zeros((3, 3)), position=position,
                orientation_xyzw=quat, velocity_world=velocity, rates_body=rates, shape=shape,
                motion=Motion(velocity=velocity, rates=rates))


def _motion_start(data: Motion):
    """Return a table motion's CG position and attitude at t = 0."""
    from cfem_ros.core.engine import kernel, motion as trajectories  # noqa: F401 - kernel first
    probe = Model(name='', frame_id='', gravity=np.zeros(3), duration=1.0, dt=1.0,
                  baumgarte=0.0, bodies=(Body(
                      name='', fixed=False, mass=0.0, inertia=np.zeros((3, 3)),
                      position=np.zeros(3), orientation_xyzw=np.array([0.0, 0, 0, 1]),
                      velocity_world=np.zeros(3), rates_body=np.zeros(3), motion=data),),
                  joints=())
    position, _, quat, _, _, _ = trajectories.state_at(probe, 0.0)[0]
    return position, quat


def _parse_motion_table(check: _Checker, value, key: str):
    """Return the times, positions and unit quaternions of a motion table."""
    if isinstance(value, str):
        rows = _read_motion_csv(check, value, key)
    elif isinstance(value, list):
        rows = []
        for k, row in enumerate(value):
            rows.append(check.vector(row, f'{key}[{k}]', length=8))
        rows = np.array(rows, dtype=float).reshape(-1, 8)
    else:
        check.fail(key, f'is {show(value)}', 'a CSV file name or a list of rows '
                   '[t, x, y, z, qx, qy, qz, qw]')
    if len(rows) < 2:
        check.fail(key, f'has {len(rows)} row(s)', 'at least 2 rows')
    times = rows[:, 0]
    steps = np.diff(times)
    if not (steps >= MIN_DT).all():
        k = int(np.flatnonzero(~(steps >= MIN_DT))[0]) + 1
        check.fail(f'{key}[{k}]', f'has time {times[k]!r} s after {times[k - 1]!r} s',
                   f'strictly increasing times, at least {MIN_DT:g} s apart')
    if times[0] > 0.0:
        check.fail(f'{key}[0]', f'starts at {times[0]:g} s', 'a table that starts at or '
                   'before t = 0')
    norms = np.linalg.norm(rows[:, 4:8], axis=1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > MOTION_QUATERNION_TOLERANCE)
    if bad.size:
        k = int(bad[0])
        check.fail(f'{key}[{k}]', f'has a quaternion of norm {norms[k]:.9g}',
                   f'unit quaternions [qx, qy, qz, qw] (within {MOTION_QUATERNION_TOLERANCE:g})')
    return (times.copy(), rows[:, 1:4].copy(), rows[:, 4:8] / norms[:, None])


def _read_motion_csv(check: _Checker, name: str, key: str) -> np.ndarray:
    """Read a motion table's CSV file, relative to the scenario's folder."""
    base = os.path.dirname(check.source) if os.path.isfile(check.source) else ''
    path = name if os.path.isabs(name) else os.path.join(base, name)
    try:
        text = read_text(path, path)
    except ScenarioError as err:
        check.fail(key, f'{show(name)} cannot be read ({err})', 'a readable CSV file')
    text = text.removeprefix('\ufeff')   # a byte order mark, as a scenario file may have
    lines = [line for line in text.splitlines() if line.strip() and not line.startswith('#')]
    order = list(range(8))
    if lines and not _numeric(lines[0].split(',')[0]):
        header = [h.strip() for h in lines[0].split(',')]
        missing = [c for c in MOTION_COLUMNS if c not in header]
        if missing:
            check.fail(key, f'{path}: the header lacks {", ".join(missing)}',
                       f'columns {", ".join(MOTION_COLUMNS)}')
        order = [header.index(c) for c in MOTION_COLUMNS]
        lines = lines[1:]
    rows = np.empty((len(lines), 8))
    for k, line in enumerate(lines):
        cells = [c.strip() for c in line.split(',')]
        try:
            values = [float(cells[i]) for i in order]
        except (IndexError, ValueError):
            check.fail(f'{key}[{k}]', f'{path}: row {show(line)}',
                       f'{len(order)} numbers {", ".join(MOTION_COLUMNS)}')
        if not np.isfinite(values).all():
            check.fail(f'{key}[{k}]', f'{path}: row {show(line)} is not finite',
                       'finite numbers')
        if max(abs(v) for v in values) > MAX_MAGNITUDE:
            check.fail(f'{key}[{k}]', f'{path}: row {show(line)} holds a magnitude beyond '
                       f'{MAX_MAGNITUDE:g}', f'times (s) and positions (m) of magnitude at most '
                       f'{MAX_MAGNITUDE:g}, as everywhere in a scenario')
        rows[k] = values
    return rows


def _numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _parse_inertia(check: _Checker, value, key: str) -> np.ndarray:
    """
    Inertia tensor from [Ixx, Iyy, Izz] or [Ixx, Iyy, Izz, Ixy, Ixz, Iyz].

    The products are the tensor's off-diagonal elements (as in URDF and
    MuJoCo's fullinertia), not the integrals of x y dm.
    """
    v = check.vector(value, key, lengths=(3, 6), limit=INERTIA_RANGE[1])
    if len(v) == 3:
        # a diagonal tensor's principal moments are its diagonal (LAPACK's eigvalsh
        # gives it exactly): checked here, with margins, without it
        ixx, iyy, izz = v.tolist()
        low, middle, high = sorted((ixx, iyy, izz))
        if (low >= INERTIA_RANGE[0] * (1 + 1e-12) and high * (1 + 1e-12) <= INERTIA_RANGE[1]
                and high * (1 + 1e-12) <= (low + middle) * (1 + TRIANGLE_TOLERANCE)):
            return np.array([[ixx, 0.0, 0.0], [0.0, iyy, 0.0], [0.0, 0.0, izz]])
    tensor = np.diag(v[:3])
    if len(v) == 6:
        ixy, ixz, iyz = v[3:]
        tensor[0, 1] = tensor[1, 0] = ixy
        tensor[0, 2] = tensor[2, 0] = ixz
        tensor[1, 2] = tensor[2, 1] = iyz
    principal = np.linalg.eigvalsh(tensor)
    if principal[0] <= 0:
        check.fail(key, f'{show(value)} is not positive definite (principal moments '
                   f'{", ".join(f"{p:.6g}" for p in principal)})',
                   'a tensor whose principal moments are all > 0')
    largest = principal[2]
    if largest > (principal[0] + principal[1]) * (1 + TRIANGLE_TOLERANCE):
        check.fail(key, f'{show(value)} breaks the triangle inequality: principal moment '
                   f'{largest:.6g} > {principal[0]:.6g} + {principal[1]:.6g}',
                   'each principal moment at most the sum of the other two '
                   '(no real body has such an inertia)')
    if principal[0] < INERTIA_RANGE[0] or largest > INERTIA_RANGE[1]:
        check.fail(key, f'{show(value)} has principal moments from {principal[0]:.6g} to '
                   f'{largest:.6g} kg m^2', f'principal moments from {INERTIA_RANGE[0]:g} '
                   f'to {INERTIA_RANGE[1]:g} kg m^2')
    return tensor


def _parse_joint(check: _Checker, name, spec, index: dict, bodies) -> Joint:
    key = _key('joints', name)
    check.name(name, key)
    spec = check.mapping(spec, key, JOINT_KEYS, required=('type', 'parent', 'child', 'anchor'))
    kind = spec['type']
    if not isinstance(kind, str) or kind not in JOINT_TABLE:
        check.fail(f'{key}.type', f'is {show(kind)}', _one_of(JOINT_TABLE))
    ends = []
    for end in ('parent', 'child'):
        body = spec[end]
        if not isinstance(body, str) or body not in index:
            check.fail(f'{key}.{end}', f'{show(body)} is not a body', _one_of(index))
        ends.append(index[body])
    parent, child = ends
    if parent == child:
        check.fail(f'{key}.child', f'is {show(spec["child"])}, the same body as the parent',
                   'two different bodies')
    if bodies[parent].fixed and bodies[child].fixed:
        check.fail(f'{key}.child', f'{show(spec["child"])} and the parent are both fixed',
                   'at least one body that can move')
    if not bodies[parent].dynamic and not bodies[child].dynamic:
        check.fail(f'{key}.child', f'{show(spec["child"])} and the parent are both fixed '
                   'or kinematic', 'at least one body moved by forces')
    anchor = check.vector(spec['anchor'], f'{key}.anchor')
    if kind in AXIS_REQUIRED and 'axis' not in spec:
        check.fail(f'{key}.axis', 'missing', f'the axis of the {kind} joint')
    axis = check.direction(spec.get('axis', [1, 0, 0]), f'{key}.axis')
    axis2 = None
    if kind == 'universal':
        if 'axis2' not in spec:
            check.fail(f'{key}.axis2', 'missing', "the child's axis of the universal joint")
        axis2 = check.direction(spec['axis2'], f'{key}.axis2')
        cosine = abs(axis @ axis2) / (np.linalg.norm(axis) * np.linalg.norm(axis2))
        if cosine > PERPENDICULAR_TOLERANCE:
            check.fail(f'{key}.axis2', f'{show(spec["axis2"])} is at '
                       f'{math.degrees(math.acos(min(cosine, 1.0))):.6g} deg to axis',
                       'a direction perpendicular to axis')
    elif 'axis2' in spec:
        check.fail(f'{key}.axis2', f'given for a {kind} joint', 'axis2 only on universal joints')
    release = _parse_release(check, spec.get('release'), f'{key}.release')
    compliance = None
    if spec.get('compliance') is not None:
        rows = JOINT_TABLE[kind]
        count = len(rows.translation) + len(rows.rotation)
        compliance = check.vector(spec['compliance'], f'{key}.compliance', length=count,
                                  limit=None)
        if not (compliance > 0.0).all():
            check.fail(f'{key}.compliance', f'is {show(spec["compliance"])}',
                       f'{count} numbers > 0 (m/N per constrained translation, rad/(N m) '
                       'per rotation)')
    return Joint(name=name, kind=kind, parent=parent, child=child, anchor=anchor,
                 triad=triad_from_axes(axis, axis2), release=release, compliance=compliance)


def _parse_release_groups(check: _Checker, doc, joints, joints_doc) -> tuple:
    """Parse ``release_groups`` (SPEC section 7): name -> joints and triggers."""
    if doc is None:
        return ()
    if not isinstance(doc, dict):
        check.fail('release_groups', f'is {show(doc)}', 'a mapping of group names')
    names = {joint.name: k for k, joint in enumerate(joints)}
    owner, groups = {}, []
    for name, spec in doc.items():
        key = _key('release_groups', name)
        check.name(name, key)
        if name in names:
            check.fail(key, f'{name!r} is also a joint, so a release command would be '
                       'ambiguous', 'a name no joint has')
        spec = check.mapping(spec, key, GROUP_KEYS, required=('joints',))
        members = spec['joints']
        if not isinstance(members, list) or not members:
            check.fail(f'{key}.joints', f'is {show(members)}', 'a non-empty list of joints')
        indices = []
        for i, joint in enumerate(members):
            where = f'{key}.joints[{i}]'
            if not isinstance(joint, str) or joint not in names:
                check.fail(where, f'{show(joint)} is not a joint', _one_of(names))
            if joint in owner:
                check.fail(where, f'{joint!r} is already in group {owner[joint]!r}',
                           'a joint in one group at most')
            if isinstance(joints_doc[joint], dict) and 'release' in joints_doc[joint]:
                check.fail(_key('joints', joint) + '.release', 'given for a joint of '
                           f'release group {name!r}', f'the triggers under {key}.release')
            owner[joint] = name
            indices.append(names[joint])
        release = _parse_release(check, spec.get('release'), f'{key}.release')
        groups.append(ReleaseGroup(name=name, joints=tuple(indices), release=release))
    return tuple(groups)


def _with_group_releases(joints, groups) -> list:
    """Give each joint of a group the group's triggers."""
    joints = list(joints)
    for group in groups:
        for k in group.joints:
            joints[k] = Joint(**{**joints[k].__dict__, 'release': group.release})
    return joints


def _release_names(joints, groups) -> tuple:
    """Return the names a wrench's start or end may be tied to: joints and groups."""
    return tuple(joint.name for joint in joints) + tuple(group.name for group in groups)


def _parse_time_or_release(check: _Checker, value, key: str, releases):
    """Return (s, None) for a time, (delay, name) for ``{release: name, delay: s}``."""
    if not isinstance(value, dict):
        return check.number(value, key, minimum=0.0), None
    value = check.mapping(value, key, TIED_KEYS, required=('release',))
    name = value['release']
    if not isinstance(name, str) or name not in releases:
        check.fail(f'{key}.release', f'{show(name)} is not a joint or a release group',
                   _one_of(releases) if releases else 'a joint or a release group (there '
                   'are none)')
    return check.number(value.get('delay', 0.0), f'{key}.delay', minimum=0.0), name


def _parse_release(check: _Checker, spec, key: str) -> Release:
    if spec is None:
        return Release()
    spec = check.mapping(spec, key, RELEASE_KEYS)
    if not spec:
        check.fail(key, 'has no trigger', 'at least one of ' + ', '.join(RELEASE_KEYS))
    time = spec.get('time')
    angle = spec.get('angle_deg')
    return Release(
        time=None if time is None else check.number(time, f'{key}.time', minimum=0.0),
        angle=None if angle is None else math.radians(
            check.number(angle, f'{key}.angle_deg', positive=True)),
        distance=(None if 'distance' not in spec
                  else check.number(spec['distance'], f'{key}.distance', positive=True)),
        force=(None if 'force' not in spec
               else check.number(spec['force'], f'{key}.force', positive=True)),
    )


def _parse_wrenches(check: _Checker, doc, index: dict, bodies, frame_id: str, *,
                    releases=()) -> tuple:
    """Parse the scheduled loads (SPEC sections 5, 7); ``releases``: joints and groups."""
    if doc is None:
        return ()
    if not isinstance(doc, list):
        check.fail('wrenches', f'is {show(doc)}', 'a list of wrench mappings')
    wrenches = [_parse_wrench(check, k, spec, index, bodies, frame_id, releases)
                for k, spec in enumerate(doc)]
    seen = {}
    for k, wrench in enumerate(wrenches):
        if (wrench.body, wrench.name) in seen:
            check.fail(f'wrenches[{k}].name', f'{wrench.name!r} already names '
                       f'wrenches[{seen[wrench.body, wrench.name]}] on the same body',
                       'a name of its own (it becomes a topic name)')
        seen[wrench.body, wrench.name] = k
    return tuple(wrenches)


def _body_of(check: _Checker, value, key: str, index: dict) -> int:
    if not isinstance(value, str) or value not in index:   # a list is no name (nor hashable)
        check.fail(key, f'{show(value)} is not a body', 'one of ' + ', '.join(index))
    return index[value]


def _parse_wrench(check: _Checker, k: int, spec, index: dict, bodies, frame_id: str,
                  releases=()) -> Wrench:
    key = f'wrenches[{k}]'
    spec = check.mapping(spec, key, WRENCH_KEYS, required=('body',))
    body = _body_of(check, spec['body'], f'{key}.body', index)
    if bodies[body].fixed:
        check.fail(f'{key}.body', f'{show(spec["body"])} is fixed', 'a body that can move')
    if not bodies[body].dynamic:
        check.fail(f'{key}.body', f'{show(spec["body"])} is kinematic',
                   'a body moved by forces')
    name = check.name(spec.get('name', f'wrench{k}'), f'{key}.name')
    if name == 'wrench':
        check.fail(f'{key}.name', "'wrench' is the source of the wrench topic",
                   'another name')
    frame = spec.get('frame', bodies[body].name)
    if not isinstance(frame, str):   # a list or a mapping is no name (nor hashable)
        check.fail(f'{key}.frame', f'is {show(frame)}, not a name',
                   f'{frame_id} or one of ' + ', '.join(index))
    if frame == frame_id:
        frame_index = -1
    elif frame in index:
        frame_index = index[frame]
    else:
        check.fail(f'{key}.frame', f'{show(frame)} is neither the world frame nor a body',
                   f'{frame_id} or one of ' + ', '.join(index))
    point = cgoffset.from_cg(bodies[body], check.vector(spec.get('point', [0, 0, 0]),
                                                        f'{key}.point'))
    moment = check.vector(spec.get('moment', [0, 0, 0]), f'{key}.moment')
    if 'force' not in spec and 'moment' not in spec:
        check.fail(f'{key}.force', 'missing', 'a force or a moment')
    force_doc = spec.get('force', [0, 0, 0])
    table, against = np.zeros((0, 7)), None
    if isinstance(force_doc, dict):
        against, table = _parse_force_table(check, force_doc, f'{key}.force', moment)
        force, moment = np.zeros(3), np.zeros(3)
    else:
        force = check.vector(force_doc, f'{key}.force')
    start, start_release = _parse_time_or_release(check, spec.get('start', 0.0),
                                                  f'{key}.start', releases)
    end = end_release = None
    if isinstance(spec.get('end'), dict):
        end, end_release = _parse_time_or_release(check, spec['end'], f'{key}.end', releases)
        if end_release == start_release and end <= start:
            check.fail(f'{key}.end.delay', f'is {end:g}, not after the start delay {start:g}',
                       'a delay after the start, s')
    elif spec.get('end') is not None:
        end = check.number(spec['end'], f'{key}.end')
        if start_release is None and end <= start:
            check.fail(f'{key}.end', f'is {end:g}, not after start {start:g}',
                       'a time after start, s')
    stroke = None
    if spec.get('stroke') is not None:
        stroke = check.number(spec['stroke'], f'{key}.stroke', positive=True)
    reacts_on = -1
    if spec.get('reacts_on') is not None:
        reacts_on = _body_of(check, spec['reacts_on'], f'{key}.reacts_on', index)
        if reacts_on == body:
            check.fail(f'{key}.reacts_on', f'is {show(spec["reacts_on"])}, the loaded body',
                       'another body (a load on itself cancels)')
    return Wrench(name=name, body=body, point=point, force=force, moment=moment,
                  frame=frame_index, start=start, end=end, stroke=stroke, reacts_on=reacts_on,
                  table=table, table_against=against, start_release=start_release,
                  end_release=end_release)


def _parse_force_table(check: _Checker, doc, key: str, moment: np.ndarray):
    """Parse ``{against: time|stroke, table: [[x, fx, fy, fz], ...]}`` into (k, 7) rows."""
    doc = check.mapping(doc, key, TABLE_KEYS, required=TABLE_KEYS)
    against = doc['against']
    if against not in ('time', 'stroke'):
        check.fail(f'{key}.against', f'is {show(against)}',
                   'time (s from start) or stroke (m)')
    rows = doc['table']
    if not isinstance(rows, list) or len(rows) < 2:
        check.fail(f'{key}.table', f'is {show(rows)}',
                   'a list of at least 2 rows [x, fx, fy, fz]')
    table = np.zeros((len(rows), 7))
    for i, row in enumerate(rows):
        table[i, :4] = check.vector(row, f'{key}.table[{i}]', 4)
        table[i, 4:] = moment
        if against == 'stroke' and table[i, 0] < 0.0:
            check.fail(f'{key}.table[{i}][0]', f'is {table[i, 0]:g}', 'a stroke >= 0, m')
        if i and not table[i, 0] > table[i - 1, 0]:
            check.fail(f'{key}.table[{i}][0]', f'is {table[i, 0]:g}, not after the row '
                       f'before ({table[i - 1, 0]:g})', 'strictly increasing abscissae')
    return against, table


CONTACT_KEYS = ('bodies', 'on_contact')


def _parse_contacts(check: _Checker, doc, index: dict, bodies) -> tuple:
    """Parse ``contacts``: the pairs of bodies whose shapes are watched (SPEC section 8)."""
    if doc is None:
        return ()
    if not isinstance(doc, list):
        check.fail('contacts', f'is {show(doc)}', 'a list of {bodies: [a, b]} entries')
    out, seen = [], set()
    for k, spec in enumerate(doc):
        key = f'contacts[{k}]'
        spec = check.mapping(spec, key, CONTACT_KEYS, required=('bodies',))
        pair = spec['bodies']
        if not isinstance(pair, list) or len(pair) != 2:
            check.fail(f'{key}.bodies', f'is {show(pair)}', 'two body names [a, b]')
        a, b = (_body_of(check, name, f'{key}.bodies[{i}]', index) for i, name in enumerate(pair))
        if a == b:
            check.fail(f'{key}.bodies', f'names {show(pair[0])} twice', 'two different bodies')
        if frozenset((a, b)) in seen:
            check.fail(f'{key}.bodies', f'repeats the pair {show(pair)}', 'each pair once')
        seen.add(frozenset((a, b)))
        if bodies[a].fixed and bodies[b].fixed:
            check.fail(f'{key}.bodies', 'are both fixed, so they never move',
                       'a pair with a body that moves')
        for i, name in zip((a, b), pair):
            shape = bodies[i].shape
            if shape is None:
                check.fail(_key('bodies', name) + '.shape', 'missing, and the body is watched '
                           f'for contact ({key})', 'a shape: box, cylinder, sphere, capsule '
                           'or mesh')
            for k, piece in enumerate(shape.pieces()):
                if piece.kind == 'mesh' and not piece.hull:
                    where = '.shape' + (f'.parts[{k}]' if shape.kind == 'compound' else '')
                    check.fail(_key('bodies', name) + where + '.mesh',
                               f'is {show(piece.mesh)}, not a local file, so it has no hull '
                               'to watch', 'a local STL or OBJ file (its convex hull is the '
                               'collision shape)')
        stop = spec.get('on_contact', 'stop')
        if stop not in ('stop', 'continue'):
            check.fail(f'{key}.on_contact', f'is {show(stop)}', 'stop or continue')
        out.append(Contact(bodies=(a, b), stop=stop == 'stop'))
    return tuple(out)


def reparse(model: Model, document: Any, *, bodies=(), joints=(), wrenches: bool = False,
            source: str = '<scenario>') -> Model:
    """
    Return a model with some bodies and joints, and the wrenches, parsed again from a document.

    For sweeps: ``parse_scenario(document)`` where document differs from
    the one ``model`` was parsed from only inside the named bodies (not in
    their ``fixed``) and joints, and inside the wrenches if ``wrenches``,
    without parsing the rest again. A body's parse reads nothing else, a
    joint's and a wrench's only the bodies' names and ``fixed`` (and the
    frame's name), and the rest reads of a body only its name and ``fixed``:
    so the result is the whole parse's, number for number, when it does
    not raise. A ``ScenarioError`` here may not be the first one the whole
    parse would name: parse the whole document for the message.
    """
    check = _Checker(clip(source, 400))
    top = check.mapping(document, '', TOP_KEYS, required=('bodies',))
    new_bodies = list(model.bodies)
    for name in bodies:
        i = model.body_index(name)
        new_bodies[i] = _parse_body(check, name, top['bodies'][name])
        if new_bodies[i].fixed != model.bodies[i].fixed:
            check.fail(_key('bodies', name) + '.fixed', 'changed', 'a whole parse')
    index = {b.name: i for i, b in enumerate(new_bodies)}
    new_joints = list(model.joints)
    for name in joints:
        new_joints[model.joint_index(name)] = _parse_joint(
            check, name, top['joints'][name], index, new_bodies)
    new_joints = _with_group_releases(new_joints, model.release_groups)
    new_wrenches = model.wrenches
    if wrenches:
        new_wrenches = _parse_wrenches(check, top.get('wrenches'), index, new_bodies,
                                       model.frame_id,
                                       releases=_release_names(model.joints,
                                                               model.release_groups))
    name = top['name'] if 'name' in top else os.path.splitext(os.path.basename(source))[0]
    return Model(**{**model.__dict__, 'name': name, 'bodies': tuple(new_bodies),
                    'joints': tuple(new_joints), 'wrenches': new_wrenches})
