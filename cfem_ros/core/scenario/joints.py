# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The ``joints`` and ``release_groups`` sections (SPEC sections 3, 7): joints, triggers."""

from __future__ import annotations

import math

from cfem_ros.core.fileio.messages import show
from cfem_ros.core.model.joints import (
    AXIS_REQUIRED, Joint, JOINT_TABLE, Release, ReleaseGroup, triad_from_axes)
from cfem_ros.core.scenario.checker import Checker, key_path, one_of
import numpy as np

JOINT_KEYS = ('type', 'parent', 'child', 'anchor', 'axis', 'axis2', 'release', 'compliance')
GROUP_KEYS = ('joints', 'release')
RELEASE_KEYS = ('time', 'angle_deg', 'distance', 'force')

#: |cos| between a universal joint's axes above which they are not perpendicular.
PERPENDICULAR_TOLERANCE = 1e-6


def parse_joint(check: Checker, name, spec, index: dict, bodies) -> Joint:
    key = key_path('joints', name)
    check.name(name, key)
    spec = check.mapping(spec, key, JOINT_KEYS, required=('type', 'parent', 'child', 'anchor'))
    kind = spec['type']
    if not isinstance(kind, str) or kind not in JOINT_TABLE:
        check.fail(f'{key}.type', f'is {show(kind)}', one_of(JOINT_TABLE))
    ends = []
    for end in ('parent', 'child'):
        body = spec[end]
        if not isinstance(body, str) or body not in index:
            check.fail(f'{key}.{end}', f'{show(body)} is not a body', one_of(index))
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
    release = parse_release(check, spec.get('release'), f'{key}.release')
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


def parse_release_groups(check: Checker, doc, joints, joints_doc) -> tuple:
    """Parse ``release_groups`` (SPEC section 7): name -> joints and triggers."""
    if doc is None:
        return ()
    if not isinstance(doc, dict):
        check.fail('release_groups', f'is {show(doc)}', 'a mapping of group names')
    names = {joint.name: k for k, joint in enumerate(joints)}
    owner, groups = {}, []
    for name, spec in doc.items():
        key = key_path('release_groups', name)
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
                check.fail(where, f'{show(joint)} is not a joint', one_of(names))
            if joint in owner:
                check.fail(where, f'{joint!r} is already in group {owner[joint]!r}',
                           'a joint in one group at most')
            if isinstance(joints_doc[joint], dict) and 'release' in joints_doc[joint]:
                check.fail(key_path('joints', joint) + '.release', 'given for a joint of '
                           f'release group {name!r}', f'the triggers under {key}.release')
            owner[joint] = name
            indices.append(names[joint])
        release = parse_release(check, spec.get('release'), f'{key}.release')
        groups.append(ReleaseGroup(name=name, joints=tuple(indices), release=release))
    return tuple(groups)


def with_group_releases(joints, groups) -> list:
    """Give each joint of a group the group's triggers."""
    joints = list(joints)
    for group in groups:
        for k in group.joints:
            joints[k] = Joint(**{**joints[k].__dict__, 'release': group.release})
    return joints


def release_names(joints, groups) -> tuple:
    """Return the names a wrench's start or end may be tied to: joints and groups."""
    return tuple(joint.name for joint in joints) + tuple(group.name for group in groups)


def parse_release(check: Checker, spec, key: str) -> Release:
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
