# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What viewers draw: a body's shape and each joint's point as markers, bodies as frames.

Every body is a tf frame named after it, child of the world frame: fixed
bodies on ``/tf_static``, the others on ``/tf`` at every sample (the same
numbers as the body's pose). The markers (``visualization_msgs/MarkerArray``
on ``<namespace>/markers``) are frame-locked to those frames, so they are
sent once and move with the frames in RViz and in Foxglove's 3D panel: one
marker per body (its ``shape``, drawn about its CG), one sphere per joint at
the joint's point on the parent, green while the joint holds, red and faded
once released.
"""

from __future__ import annotations

from cfem_ros.core import rotations
from cfem_ros.core.shapes import default_shape, Shape, triangles
import numpy as np

#: visualization_msgs/Marker types.
CUBE, SPHERE, CYLINDER, MESH_RESOURCE, TRIANGLE_LIST = 1, 2, 3, 10, 11
#: A contact point (``contacts``) is drawn in this colour.
CONTACT_COLOR = (1.0, 0.0, 0.0, 1.0)
#: A mesh's collision hull is drawn over the mesh in this colour.
HULL_COLOR = (1.0, 0.85, 0.0, 0.35)
#: Colours (r, g, b, a) of moving bodies, in turn; fixed bodies are grey.
PALETTE = ((0.12, 0.47, 0.71, 1.0), (1.0, 0.5, 0.05, 1.0), (0.17, 0.63, 0.17, 1.0),
           (0.58, 0.4, 0.74, 1.0), (0.55, 0.34, 0.29, 1.0), (0.89, 0.47, 0.76, 1.0))
FIXED_COLOR = (0.6, 0.6, 0.6, 0.6)
HELD_COLOR = (0.1, 0.8, 0.1, 1.0)
RELEASED_COLOR = (0.9, 0.1, 0.1, 0.35)
#: A joint's sphere is this fraction of the largest body's size (at least 2 cm).
JOINT_SIZE = 0.04
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


def _extent(shape: Shape) -> float:
    if shape.kind == 'cylinder':
        return max(2 * shape.size[0], shape.size[1])
    if shape.kind == 'sphere':
        return 2 * shape.size[0]
    return max(shape.size)


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
    for i, (body, shape) in enumerate(zip(model.bodies, shapes)):
        marker = _shape_marker(shape)
        marker.update(header={'stamp': stamp, 'frame_id': body.name},
                      ns=f'{namespace}/bodies', id=i, action=0, frame_locked=True,
                      color=_color(FIXED_COLOR if body.fixed else next(colors)), text=body.name)
        out.append(marker)
        if shape.kind == 'mesh' and shape.hull:   # what contacts use: the hull
            hull = _triangle_marker(shape)
            hull.update(header={'stamp': stamp, 'frame_id': body.name}, action=0,
                        ns=f'{namespace}/collision', id=i, frame_locked=True,
                        color=_color(HULL_COLOR), text=f'{body.name} hull')
            out.append(hull)
    size = max(0.02, JOINT_SIZE * max((_extent(s) for s in shapes), default=1.0))
    for k, event in enumerate(contacts):
        out.append({'header': {'stamp': stamp, 'frame_id': model.frame_id},
                    'ns': f'{namespace}/contacts', 'id': k, 'type': SPHERE, 'action': 0,
                    'pose': {'position': _xyz(event['point']),
                             'orientation': _quat((0, 0, 0, 1))},
                    'scale': _xyz((size, size, size)), 'frame_locked': False,
                    'color': _color(CONTACT_COLOR),
                    'text': f'contact {" ".join(event["bodies"])} t={event["time"]:.6f} s'})
    for k, (joint, point) in enumerate(zip(model.joints, joint_points_on_parents(model))):
        out.append({'header': {'stamp': stamp, 'frame_id': model.bodies[joint.parent].name},
                    'ns': f'{namespace}/joints', 'id': k, 'type': SPHERE, 'action': 0,
                    'pose': {'position': _xyz(point), 'orientation': _quat((0, 0, 0, 1))},
                    'scale': _xyz((size, size, size)), 'frame_locked': True,
                    'color': _color(RELEASED_COLOR if joint.name in released else HELD_COLOR),
                    'text': joint.name})
    return {'markers': out}


def static_transforms(model, stamp: dict) -> dict:
    """Return the TFMessage of the fixed bodies: world frame to each, at its pose."""
    return {'transforms': [
        {'header': {'stamp': stamp, 'frame_id': model.frame_id}, 'child_frame_id': body.name,
         'transform': {'translation': _xyz(body.position),
                       'rotation': _quat(body.orientation_xyzw)}}
        for body in model.bodies if body.fixed]}
