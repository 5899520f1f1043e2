# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What viewers draw: the frames of the bodies and joints (tf), and markers on them.

The frames (SPEC section 4), each with the axes viewers expect:

- ``map``, the root, z up (REP-103/105). Its child is the scenario's frame
  (``frame_id``) by a fixed rotation that turns the scenario's gravity to
  -z, so that viewers with default settings show things falling down.
  When the scenario's gravity already points along -z (or there is none),
  the scenario's frame is the root and there is no ``map``.
- one frame per body, named after it, at its CG in its axes, child of the
  scenario's frame: fixed bodies on ``/tf_static``, the others on ``/tf``
  at every sample (the same numbers as the body's pose).
- one frame per joint, named after it, at the joint point fixed on the
  child, in the child's axes, child of the child's frame (``/tf_static``):
  a joint's wrench is stamped with it, so viewers draw it at the joint.

The markers (``visualization_msgs/MarkerArray`` on ``<namespace>/markers``,
transient local, sent again every ``schema.MARKERS.period``) are frame-locked to
those frames, so they move with the frames in RViz and in Foxglove's 3D
panel: one marker per body (its ``shape``, drawn about its CG; one per part of
a compound, each part's ``ns`` ending in ``/part<k>`` from the second on), one sphere
per joint at the joint's point on the parent, green while the joint holds,
red and faded once released.
"""

from __future__ import annotations

import math

from cfem_ros.core import rotations
from cfem_ros.core.engine.events import contact_label
from cfem_ros.core.model.shapes import default_shape, Shape, triangles
import numpy as np

#: visualization_msgs/Marker types.
CUBE, SPHERE, CYLINDER, MESH_RESOURCE, TRIANGLE_LIST = 1, 2, 3, 10, 11
#: A contact point (``contacts``) is drawn in this colour.
CONTACT_COLOR = (1.0, 0.0, 0.0, 1.0)
#: A mesh's collision hull is drawn over the mesh in this colour.
HULL_COLOR = (1.0, 0.85, 0.0, 0.35)
#: Colours (r, g, b, a) of moving bodies, in turn; fixed bodies are grey. A little
#: transparent: the load arrows that start inside a body (aero, at its CG) show.
PALETTE = ((0.12, 0.47, 0.71, 0.75), (1.0, 0.5, 0.05, 0.75), (0.17, 0.63, 0.17, 0.75),
           (0.58, 0.4, 0.74, 0.75), (0.55, 0.34, 0.29, 0.75), (0.89, 0.47, 0.76, 0.75))
FIXED_COLOR = (0.6, 0.6, 0.6, 0.3)
#: The opacity of a carrier's shape (``carriers``), so that what hangs under it shows.
CARRIER_ALPHA = 0.3
#: The z-up root frame (REP-105's ``map``) above a scenario frame that is not z up.
ROOT_FRAME = 'map'
HELD_COLOR = (1.0, 0.8, 0.0, 1.0)
RELEASED_COLOR = (0.9, 0.1, 0.1, 0.35)
#: A joint's sphere is this fraction of the thinner of the two bodies it joins (at least 1 cm).
JOINT_SIZE = 0.4
#: A cylinder marker stands along z; ours lie along the body's x axis.
_Z_TO_X = np.array([0.0, np.sqrt(0.5), 0.0, np.sqrt(0.5)])   # +90 deg about y


def body_shape(body) -> Shape:
    """Return a body's shape: as given, or made up from its mass and inertia."""
    return body.shape if body.shape is not None else default_shape(
        not body.dynamic, body.mass, body.inertia)   # a kinematic body has no mass either


def _xyz(v) -> dict:
    return {'x': float(v[0]), 'y': float(v[1]), 'z': float(v[2])}


def _quat(q) -> dict:
    return {'x': float(q[0]), 'y': float(q[1]), 'z': float(q[2]), 'w': float(q[3])}


def _color(c) -> dict:
    return dict(zip('rgba', (float(v) for v in c)))


def _shape_marker(shape: Shape) -> dict:
    """Return a marker's type, pose and scale (and mesh) for a shape, in its body's frame."""
    orientation = np.array(shape.orientation_xyzw, dtype=float)
    if shape.kind == 'box':
        kind, scale = CUBE, shape.size
    elif shape.kind == 'sphere':
        kind, scale = SPHERE, (2 * shape.size[0],) * 3
    elif shape.kind == 'cylinder':
        radius, length = shape.size
        kind, scale = CYLINDER, (2 * radius, 2 * radius, length)
        orientation = rotations.multiply(orientation, _Z_TO_X)
    elif shape.kind == 'capsule':
        return _triangle_marker(shape)
    else:
        kind, scale = MESH_RESOURCE, shape.size
    marker = {'type': kind, 'pose': {'position': _xyz(shape.offset),
                                     'orientation': _quat(orientation)},
              'scale': _xyz(scale)}
    if kind == MESH_RESOURCE:
        marker['mesh_resource'] = shape.mesh
    return marker


def _triangle_marker(shape: Shape) -> dict:
    """Return a TRIANGLE_LIST marker of a capsule or a mesh's hull, in its body's frame."""
    return {'type': TRIANGLE_LIST, 'pose': {'position': _xyz(shape.offset),
                                            'orientation': _quat(shape.orientation_xyzw)},
            'scale': _xyz((1.0, 1.0, 1.0)),
            'points': [_xyz(p) for p in triangles(shape).reshape(-1, 3)]}


def extent(shape: Shape) -> float:
    """Return a shape's largest dimension, m (a mesh's: its scale's largest)."""
    if shape.kind == 'compound':
        return max(extent(part) + 2 * float(np.linalg.norm(part.offset))
                   for part in shape.parts)
    if shape.kind == 'cylinder':
        return max(2 * shape.size[0], shape.size[1])
    if shape.kind == 'sphere':
        return 2 * shape.size[0]
    return max(shape.size)


def thickness(shape: Shape) -> float:
    """Return a shape's smallest dimension, m (a cylinder's, a capsule's: the diameter)."""
    if shape.kind == 'compound':
        return min(thickness(part) for part in shape.parts)
    if shape.kind in ('cylinder', 'sphere', 'capsule'):
        return 2 * shape.size[0]
    if shape.kind == 'box':
        return min(shape.size)
    return JOINT_SIZE * extent(shape)   # a mesh: its scale says little of its size


def carriers(model) -> set:
    """
    Return the names of the bodies that carry others.

    Those not moved by forces (fixed, kinematic), and a body that holds
    another by a joint while a fixed joint holds it to a carrier (a pylon on
    an aircraft; not a store on fixed hooks, which holds nothing).
    """
    out = {b.name for b in model.bodies if not b.dynamic}
    parents = {joint.parent for joint in model.joints}
    for joint in model.joints:
        if joint.kind == 'fixed' and model.bodies[joint.parent].name in out \
                and joint.child in parents:
            out.add(model.bodies[joint.child].name)
    return out


def _part_ns(namespace: str, kind: str, part: int) -> str:
    """Return the ``ns`` of a body's marker: part k > 0 of a compound has its own."""
    return f'{namespace}/{kind}' if part == 0 else f'{namespace}/{kind}/part{part}'


def _part_text(name: str, shape: Shape, part: int) -> str:
    return f'{name} part {part}' if shape.kind == 'compound' else name


def joint_points_on_parents(model) -> np.ndarray:
    """Each joint's point in its parent's body axes (from t = 0), m, shape (n_joints, 3)."""
    out = np.zeros((len(model.joints), 3))
    for k, joint in enumerate(model.joints):
        parent = model.bodies[joint.parent]
        rot = rotations.matrices(np.asarray(parent.orientation_xyzw)[None])[0]
        out[k] = rot.T @ (np.asarray(joint.anchor) - np.asarray(parent.position))
    return out


def markers(model, stamp: dict, namespace: str, released=(), contacts=()) -> dict:
    """
    Return the MarkerArray of a model: its bodies' shapes and its joints' points.

    Parameters
    ----------
    model : Model
        The bodies (with their shapes) and joints.
    stamp : dict
        builtin_interfaces/Time of the message.
    namespace : str
        The markers' ``ns`` prefix (the node's namespace).
    released : collection of str
        Joints already released (drawn red and faded).
    contacts : sequence of dict
        Contact events so far: a red sphere at each point (world frame).

    """
    out = []
    colors = iter(PALETTE * (1 + len(model.bodies) // len(PALETTE)))
    shapes = [body_shape(body) for body in model.bodies]
    carried = carriers(model)
    for i, (body, shape) in enumerate(zip(model.bodies, shapes)):
        color = FIXED_COLOR if body.fixed else next(colors)
        if body.name in carried:
            color = color[:3] + (min(color[3], CARRIER_ALPHA),)
        for k, piece in enumerate(shape.pieces()):   # a compound: a marker per part
            marker = _shape_marker(piece)
            marker.update(header={'stamp': stamp, 'frame_id': body.name},
                          ns=_part_ns(namespace, 'bodies', k), id=i, action=0,
                          frame_locked=True, color=_color(color),
                          text=_part_text(body.name, shape, k))
            out.append(marker)
            if piece.kind == 'mesh' and piece.hull:   # what contacts use: the hull
                hull = _triangle_marker(piece)
                hull.update(header={'stamp': stamp, 'frame_id': body.name}, action=0,
                            ns=_part_ns(namespace, 'collision', k), id=i, frame_locked=True,
                            color=_color(HULL_COLOR),
                            text=f'{_part_text(body.name, shape, k)} hull')
                out.append(hull)
    size = max(0.01, JOINT_SIZE * min((thickness(s) for s in shapes), default=0.05))
    for k, event in enumerate(contacts):
        out.append({'header': {'stamp': stamp, 'frame_id': model.frame_id},
                    'ns': f'{namespace}/contacts', 'id': k, 'type': SPHERE, 'action': 0,
                    'pose': {'position': _xyz(event['point']),
                             'orientation': _quat((0, 0, 0, 1))},
                    'scale': _xyz((size, size, size)), 'frame_locked': False,
                    'color': _color(CONTACT_COLOR),
                    'text': contact_label(event)})
    for k, (joint, point) in enumerate(zip(model.joints, joint_points_on_parents(model))):
        size = max(0.01, JOINT_SIZE * min(thickness(shapes[joint.parent]),
                                          thickness(shapes[joint.child])))
        out.append({'header': {'stamp': stamp, 'frame_id': model.bodies[joint.parent].name},
                    'ns': f'{namespace}/joints', 'id': k, 'type': SPHERE, 'action': 0,
                    'pose': {'position': _xyz(point), 'orientation': _quat((0, 0, 0, 1))},
                    'scale': _xyz((size, size, size)), 'frame_locked': True,
                    'color': _color(RELEASED_COLOR if joint.name in released else HELD_COLOR),
                    'text': joint.name})
    return {'markers': out}


def up_rotation(gravity) -> tuple:
    """
    Return the rotation (x, y, z, w) from a scenario's axes to z-up axes, or None.

    The smallest rotation that turns gravity to -z; half a turn about x when
    gravity points along +z (a z-down frame, x forward, y right, z down,
    becomes x forward, y left, z up, as REP-103 has it). None when gravity
    is zero or already points along -z: the scenario's axes are z up.
    """
    g = np.asarray(gravity, dtype=float)
    norm = float(np.linalg.norm(g))
    if norm == 0.0:
        return None
    down = g / norm
    cos = -down[2]   # the cosine of the angle from gravity to -z
    if cos >= 1.0 - 1e-15:
        return None
    if cos <= -1.0 + 1e-15:
        return (1.0, 0.0, 0.0, 0.0)
    axis = np.cross(down, [0.0, 0.0, -1.0])
    half = 0.5 * math.atan2(float(np.linalg.norm(axis)), cos)
    axis = axis / np.linalg.norm(axis) * math.sin(half)
    return (float(axis[0]), float(axis[1]), float(axis[2]), math.cos(half))


def root_frame(model) -> str:
    """Return the root of a model's tf tree: ``map`` above a scenario frame not z up, or it."""
    if up_rotation(model.gravity) is None:
        return model.frame_id
    taken = {model.frame_id} | {b.name for b in model.bodies} | {j.name for j in model.joints}
    root = ROOT_FRAME
    while root in taken:   # a body or joint named map: the root takes another name
        root += '_z_up'
    return root


def joint_points_on_children(model) -> np.ndarray:
    """Each joint's point in its child's body axes (from t = 0), m, shape (n_joints, 3)."""
    out = np.zeros((len(model.joints), 3))
    for k, joint in enumerate(model.joints):
        child = model.bodies[joint.child]
        rot = rotations.matrices(np.asarray(child.orientation_xyzw, dtype=float)[None])[0]
        out[k] = rot.T @ (np.asarray(joint.anchor) - np.asarray(child.position))
    return out


def _transform(parent: str, child: str, stamp: dict, translation, rotation) -> dict:
    return {'header': {'stamp': stamp, 'frame_id': parent}, 'child_frame_id': child,
            'transform': {'translation': _xyz(translation), 'rotation': _quat(rotation)}}


def static_transforms(model, stamp: dict) -> dict:
    """
    Return the TFMessage of the frames that never move relative to their parent.

    The root ``map`` to the scenario's frame (if that is not z up), the
    scenario's frame to each fixed body (at its pose), and each joint's
    child to the joint's frame (at the joint point, in the child's axes).
    """
    transforms = []
    up = up_rotation(model.gravity)
    if up is not None:
        transforms.append(_transform(root_frame(model), model.frame_id, stamp, (0, 0, 0), up))
    transforms += [_transform(model.frame_id, body.name, stamp, body.position,
                              body.orientation_xyzw) for body in model.bodies if body.fixed]
    transforms += [_transform(model.bodies[joint.child].name, joint.name, stamp, point,
                              (0, 0, 0, 1))
                   for joint, point in zip(model.joints, joint_points_on_children(model))]
    return {'transforms': transforms}
