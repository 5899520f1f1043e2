# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Scenario files (SPEC section 1): YAML in, a validated ``Model`` out.

Every mistake is refused before anything runs, with a ``ScenarioError`` that
names the file, the key path, the value and what would be right.
"""

from __future__ import annotations

import math
import os
import re
from typing import Any, Optional

from cfem_ros.core import rotations, shapes
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.model import (
    AXIS_REQUIRED, BAUMGARTE_DT_LIMIT, Body, default_baumgarte, Joint, JOINT_TABLE,
    Model, Release, STANDARD_GRAVITY, triad_from_axes)
import numpy as np
import yaml

TOP_KEYS = ('name', 'frame_id', 'gravity', 'duration', 'dt', 'baumgarte', 'bodies', 'joints')
BODY_KEYS = ('fixed', 'mass', 'inertia', 'position', 'orientation_rpy_deg',
             'orientation_xyzw', 'velocity', 'angular_velocity_deg', 'angular_velocity', 'shape')
JOINT_KEYS = ('type', 'parent', 'child', 'anchor', 'axis', 'axis2', 'release')
RELEASE_KEYS = ('time', 'angle_deg', 'distance', 'force')

#: Names become ROS topic tokens (bodies/<body>/pose), so they must be valid ones.
NAME_PATTERN = re.compile(r'^[A-Za-z][A-Za-z0-9_]*$')

#: |cos| between a universal joint's axes above which they are not perpendicular.
PERPENDICULAR_TOLERANCE = 1e-6

#: Relative slack on the triangle inequality (a thin plate has Izz = Ixx + Iyy).
TRIANGLE_TOLERANCE = 1e-9


class _UniqueKeyLoader(yaml.SafeLoader):
    """A safe YAML loader that refuses duplicate keys instead of keeping the last."""


def _construct_mapping(loader, node, deep=False):
    seen = {}
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f'duplicate key {key!r} (first at line {seen[key] + 1})',
                key_node.start_mark)
        seen[key] = key_node.start_mark.line
    return yaml.SafeLoader.construct_mapping(loader, node, deep)


_UniqueKeyLoader.add_constructor(
    yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


def load_scenario(path: str, *, duration: Optional[float] = None,
                  dt: Optional[float] = None) -> Model:
    """
    Read and validate a scenario file.

    Parameters
    ----------
    path : str
        The YAML file.
    duration, dt : float, optional
        Overrides of the file's values (s), as ``cfem-sim run`` takes them.

    Raises
    ------
    ScenarioError
        For anything wrong, unreadable file and YAML syntax included.

    """
    try:
        with open(path, encoding='utf-8') as stream:
            text = stream.read()
    except OSError as err:
        raise ScenarioError(path, '', f'cannot read the file ({err.strerror})',
                            'a readable YAML scenario file') from err
    try:
        document = yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 (safe loader)
    except yaml.YAMLError as err:
        mark = getattr(err, 'problem_mark', None)
        where = f'line {mark.line + 1}, column {mark.column + 1}: ' if mark else ''
        problem = getattr(err, 'problem', None) or str(err)
        raise ScenarioError(path, '', f'{where}not valid YAML: {problem}',
                            'a YAML mapping as in SPEC section 1') from err
    return parse_scenario(document, source=path, duration=duration, dt=dt)


class _Checker:
    """Typed accessors that raise ScenarioError with the key path."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, key: str, problem: str, expected: str = ''):
        raise ScenarioError(self.source, key, problem, expected)

    def mapping(self, value, key: str, allowed, required=()) -> dict:
        if not isinstance(value, dict):
            self.fail(key, f'is {_show(value)}', 'a mapping')
        for name in value:
            if name not in allowed:
                path = f'{key}.{name}' if key else str(name)
                self.fail(path, 'unknown key', 'one of ' + ', '.join(allowed))
        for name in required:
            if name not in value:
                self.fail(f'{key}.{name}' if key else name, 'missing', 'it to be given')
        return value

    def number(self, value, key: str, *, minimum=None, positive=False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, f'is {_show(value)}', 'a number')
        value = float(value)
        if not math.isfinite(value):
            self.fail(key, f'is {value}', 'a finite number')
        if positive and value <= 0:
            self.fail(key, f'is {value:g}', 'a number > 0')
        if minimum is not None and value < minimum:
            self.fail(key, f'is {value:g}', f'a number >= {minimum:g}')
        return value

    def vector(self, value, key: str, length: int = 3, lengths=None) -> np.ndarray:
        lengths = lengths or (length,)
        if not isinstance(value, (list, tuple)) or len(value) not in lengths:
            want = ' or '.join(str(n) for n in lengths)
            self.fail(key, f'is {_show(value)}', f'a list of {want} numbers')
        return np.array([self.number(v, f'{key}[{i}]') for i, v in enumerate(value)])

    def direction(self, value, key: str) -> np.ndarray:
        vector = self.vector(value, key)
        if np.linalg.norm(vector) < 1e-12:
            self.fail(key, f'has zero length {_show(value)}', 'a non-zero direction')
        return vector

    def name(self, value, key: str) -> str:
        if not isinstance(value, str) or not NAME_PATTERN.match(value):
            self.fail(key, f'{_show(value)} is not a usable name',
                      'a letter then letters, digits or _ (it becomes a ROS topic name)')
        return value


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + '...'


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

    """
    check = _Checker(source)
    top = check.mapping(document, '', TOP_KEYS, required=('bodies',))
    default_name = os.path.splitext(os.path.basename(source))[0]
    name = top.get('name', default_name)
    if not isinstance(name, str):
        check.fail('name', f'is {_show(name)}', 'a string')
    frame_id = check.name(top.get('frame_id', 'world'), 'frame_id')
    gravity = (check.vector(top['gravity'], 'gravity') if 'gravity' in top
               else np.array([0.0, 0.0, -STANDARD_GRAVITY]))
    run_duration = check.number(top.get('duration', 10.0), 'duration', positive=True)
    step = check.number(top.get('dt', 0.001), 'dt', positive=True)
    if duration is not None:
        run_duration = check.number(duration, '--duration', positive=True)
    if dt is not None:
        step = check.number(dt, '--dt', positive=True)
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
        check.fail('bodies', f'is {_show(bodies_doc)}', 'a non-empty mapping of body names')
    bodies = [_parse_body(check, body_name, spec)
              for body_name, spec in bodies_doc.items()]
    if all(b.fixed for b in bodies):
        check.fail('bodies', 'every body is fixed, so nothing can move',
                   'at least one body without fixed: true')
    index = {b.name: i for i, b in enumerate(bodies)}

    joints_doc = top.get('joints', {}) or {}
    if not isinstance(joints_doc, dict):
        check.fail('joints', f'is {_show(joints_doc)}', 'a mapping of joint names')
    joints = [_parse_joint(check, joint_name, spec, index, bodies)
              for joint_name, spec in joints_doc.items()]
    return Model(name=name, frame_id=frame_id, gravity=gravity, duration=run_duration,
                 dt=step, baumgarte=eta, bodies=tuple(bodies), joints=tuple(joints))


def _parse_body(check: _Checker, name, spec) -> Body:
    key = f'bodies.{name}'
    check.name(name, key)
    spec = check.mapping(spec if spec is not None else {}, key, BODY_KEYS)
    fixed = spec.get('fixed', False)
    if not isinstance(fixed, bool):
        check.fail(f'{key}.fixed', f'is {_show(fixed)}', 'true or false')
    if fixed:
        mass, inertia = 0.0, np.zeros((3, 3))
        for moving in ('velocity', 'angular_velocity_deg', 'angular_velocity'):
            if moving in spec and np.any(check.vector(spec[moving], f'{key}.{moving}')):
                check.fail(f'{key}.{moving}', f'is {_show(spec[moving])} on a fixed body',
                           'no velocity (a fixed body never moves)')
    else:
        for required in ('mass', 'inertia'):
            if required not in spec:
                check.fail(f'{key}.{required}', 'missing',
                           'it to be given for a body that is not fixed')
        mass = check.number(spec['mass'], f'{key}.mass', positive=True)
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
        quat = rotations.from_rpy_deg(rpy)
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
            os.path.dirname(check.source) if os.path.isfile(check.source) else '')
    return Body(name=name, fixed=fixed, mass=mass, inertia=inertia, position=position,
                orientation_xyzw=quat, velocity_world=velocity, rates_body=rates, shape=shape)


def _parse_inertia(check: _Checker, value, key: str) -> np.ndarray:
    """
    Inertia tensor from [Ixx, Iyy, Izz] or [Ixx, Iyy, Izz, Ixy, Ixz, Iyz].

    The products are the tensor's off-diagonal elements (as in URDF and
    MuJoCo's fullinertia), not the integrals of x y dm.
    """
    v = check.vector(value, key, lengths=(3, 6))
    tensor = np.diag(v[:3])
    if len(v) == 6:
        ixy, ixz, iyz = v[3:]
        tensor[0, 1] = tensor[1, 0] = ixy
        tensor[0, 2] = tensor[2, 0] = ixz
        tensor[1, 2] = tensor[2, 1] = iyz
    principal = np.linalg.eigvalsh(tensor)
    if principal[0] <= 0:
        check.fail(key, f'{_show(value)} is not positive definite (principal moments '
                   f'{", ".join(f"{p:.6g}" for p in principal)})',
                   'a tensor whose principal moments are all > 0')
    largest = principal[2]
    if largest > (principal[0] + principal[1]) * (1 + TRIANGLE_TOLERANCE):
        check.fail(key, f'{_show(value)} breaks the triangle inequality: principal moment '
                   f'{largest:.6g} > {principal[0]:.6g} + {principal[1]:.6g}',
                   'each principal moment at most the sum of the other two '
                   '(no real body has such an inertia)')
    return tensor


def _parse_joint(check: _Checker, name, spec, index: dict, bodies) -> Joint:
    key = f'joints.{name}'
    check.name(name, key)
    spec = check.mapping(spec, key, JOINT_KEYS, required=('type', 'parent', 'child', 'anchor'))
    kind = spec['type']
    if kind not in JOINT_TABLE:
        check.fail(f'{key}.type', f'is {_show(kind)}', 'one of ' + ', '.join(JOINT_TABLE))
    ends = []
    for end in ('parent', 'child'):
        body = spec[end]
        if body not in index:
            check.fail(f'{key}.{end}', f'{_show(body)} is not a body',
                       'one of ' + ', '.join(index))
        ends.append(index[body])
    parent, child = ends
    if parent == child:
        check.fail(f'{key}.child', f'is {_show(spec["child"])}, the same body as the parent',
                   'two different bodies')
    if bodies[parent].fixed and bodies[child].fixed:
        check.fail(f'{key}.child', f'{_show(spec["child"])} and the parent are both fixed',
                   'at least one body that can move')
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
            check.fail(f'{key}.axis2', f'{_show(spec["axis2"])} is at '
                       f'{math.degrees(math.acos(min(cosine, 1.0))):.6g} deg to axis',
                       'a direction perpendicular to axis')
    elif 'axis2' in spec:
        check.fail(f'{key}.axis2', f'given for a {kind} joint', 'axis2 only on universal joints')
    release = _parse_release(check, spec.get('release'), f'{key}.release')
    return Joint(name=name, kind=kind, parent=parent, child=child, anchor=anchor,
                 triad=triad_from_axes(axis, axis2), release=release)


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
