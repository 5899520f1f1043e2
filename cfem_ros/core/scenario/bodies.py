# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The ``bodies`` section (SPEC sections 1, 5): a body moved by forces, fixed, or kinematic."""

from __future__ import annotations

import logging

from cfem_ros.core import rotations
from cfem_ros.core.fileio.messages import show
from cfem_ros.core.model import shapes
from cfem_ros.core.model.bodies import Body, Motion
from cfem_ros.core.scenario import cgoffset
from cfem_ros.core.scenario.checker import Checker, key_path, source_dir
from cfem_ros.core.scenario.motiontable import motion_start, parse_motion_table
import numpy as np

LOG = logging.getLogger('cfem_ros')

BODY_KEYS = ('fixed', 'mass', 'inertia', 'position', 'orientation_rpy_deg',
             'orientation_xyzw', 'velocity', 'angular_velocity_deg', 'angular_velocity', 'shape',
             'motion', 'reference', 'cg_offset')
MOTION_KEYS = ('velocity', 'angular_velocity_deg', 'angular_velocity', 'table')

#: Mass of a body that is not fixed, kg: a milligram to a small moon.
MASS_RANGE = (1e-6, 1e12)

#: Each principal moment of inertia, kg m^2 (1 mg at 1 mm to 1e12 kg at 1 km).
INERTIA_RANGE = (1e-12, 1e18)
#: Relative slack on the triangle inequality (a thin plate has Izz = Ixx + Iyy).
TRIANGLE_TOLERANCE = 1e-9


def parse_body(check: Checker, name, spec) -> Body:
    key = key_path('bodies', name)
    check.name(name, key)
    spec = check.mapping(spec if spec is not None else {}, key, BODY_KEYS)
    fixed = spec.get('fixed', False)
    if not isinstance(fixed, bool):
        check.fail(f'{key}.fixed', f'is {show(fixed)}', 'true or false')
    if 'cg_offset' in spec and (fixed or 'motion' in spec):
        check.fail(f'{key}.cg_offset', 'given on a fixed or kinematic body',
                   'no cg_offset (it moves the CG of a body moved by forces)')
    if 'motion' in spec:
        return parse_kinematic(check, name, key, spec, fixed)
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
        inertia = parse_inertia(check, spec['inertia'], f'{key}.inertia')
    position, quat = _pose(check, spec, key)
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
            shape_dir(check, spec['shape']))
    cg_offset = check.vector(spec.get('cg_offset', [0, 0, 0]), f'{key}.cg_offset')
    body = Body(name=name, fixed=fixed, mass=mass, inertia=inertia, position=position,
                orientation_xyzw=quat, velocity_world=velocity, rates_body=rates, shape=shape,
                velocity_given=('velocity' in spec or 'angular_velocity_deg' in spec
                                or 'angular_velocity' in spec))
    return cgoffset.moved(body, cg_offset)


#: Quaternions of the attitudes parsed, by the exact bits of their angles (a
#: sweep's runs parse the same few again and again).
_QUATERNIONS = {}


def from_rpy_deg(rpy: np.ndarray) -> np.ndarray:
    """Return the quaternion of roll, pitch, yaw (deg), a new array, computed once per rpy."""
    key = rpy.tobytes()
    quat = _QUATERNIONS.get(key)
    if quat is None:
        quat = rotations.from_rpy_deg(rpy)
        if len(_QUATERNIONS) >= 1024:
            _QUATERNIONS.clear()
        _QUATERNIONS[key] = quat
    return quat.copy()


def shape_dir(check: Checker, shape) -> str:
    """Return the folder a shape's mesh file is relative to (only a mesh needs one)."""
    if isinstance(shape, dict) and 'mesh' in shape:
        return source_dir(check)
    return ''


def parse_kinematic(check: Checker, name, key: str, spec: dict, fixed: bool) -> Body:
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
            shape_dir(check, spec['shape']))
    if 'table' in motion:
        for other in ('velocity', 'angular_velocity_deg', 'angular_velocity'):
            if other in motion:
                check.fail(f'{mkey}.{other}', 'given together with a table',
                           'a table or constant velocities, not both')
        for pose in ('position', 'orientation_rpy_deg', 'orientation_xyzw'):
            if pose in spec:
                check.fail(f'{key}.{pose}', 'given on a body that follows a table',
                           'none (the table gives the pose at t = 0)')
        times, positions, quats = parse_motion_table(check, motion['table'], f'{mkey}.table')
        data = Motion(times=times, positions=positions, quaternions=quats)
        position, quat = motion_start(data)
        return Body(name=name, fixed=False, mass=0.0, inertia=np.zeros((3, 3)),
                    position=position, orientation_xyzw=quat, velocity_world=np.zeros(3),
                    rates_body=np.zeros(3), shape=shape, motion=data)
    velocity = check.vector(motion.get('velocity', [0, 0, 0]), f'{mkey}.velocity')
    if 'angular_velocity' in motion:
        rates = check.vector(motion['angular_velocity'], f'{mkey}.angular_velocity')
    else:
        rates = np.radians(check.vector(motion.get('angular_velocity_deg', [0, 0, 0]),
                                        f'{mkey}.angular_velocity_deg'))
    position, quat = _pose(check, spec, key)
    return Body(name=name, fixed=False, mass=0.0, inertia=np.zeros((3, 3)), position=position,
                orientation_xyzw=quat, velocity_world=velocity, rates_body=rates, shape=shape,
                motion=Motion(velocity=velocity, rates=rates))


def parse_inertia(check: Checker, value, key: str) -> np.ndarray:
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


def _pose(check, spec: dict, key: str):
    """Return a body's position (m) and unit quaternion [x, y, z, w] at t = 0."""
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
        return position, quat / norm
    return position, from_rpy_deg(check.vector(spec.get('orientation_rpy_deg', [0, 0, 0]),
                                               f'{key}.orientation_rpy_deg'))
