# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The benchmark models, built once in MuJoCo and turned into cfem_ros scenarios.

A chain or tree is written as a MuJoCo spec (generalized coordinates,
hinges); its forward kinematics then gives each body's CG, attitude and
each joint's world anchor and axis, from which the cfem_ros scenario is
written. Both engines therefore start from the very same bodies and joints.
"""

import math

import mujoco
import numpy as np

HINGE = mujoco.mjtJoint.mjJNT_HINGE
LINK = 1.0                       # m
LINK_MASS = 1.0                  # kg
LINK_INERTIA = [LINK_MASS * LINK ** 2 / 12, LINK_MASS * LINK ** 2 / 12, 0.002]


def _spec(dt, gravity=(0.0, 0.0, -9.80665)):
    spec = mujoco.MjSpec()
    spec.option.timestep = dt
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    spec.option.gravity = list(gravity)
    return spec


def _link(parent, pos, axis):
    body = parent.add_body(pos=list(pos))
    body.mass = LINK_MASS
    body.ipos = [0.0, 0.0, -LINK / 2]
    body.inertia = LINK_INERTIA
    body.explicitinertial = True
    body.add_joint(type=HINGE, axis=list(axis))
    return body


def _hang(parent, pos, count, spatial, first=0):
    body = parent
    for i in range(count):
        axis = (1.0, 0.0, 0.0) if spatial and (first + i) % 2 else (0.0, 1.0, 0.0)
        body = _link(body, pos if i == 0 else (0.0, 0.0, -LINK), axis)


def chain(n, spatial=False, dt=0.001):
    """N hinged links hanging from the ground, tilted; hinge axes all y, or y and x in turn."""
    spec = _spec(dt)
    _hang(spec.worldbody, (0.0, 0.0, 0.0), n, spatial)
    tilt = [0.4, 0.3] if spatial and n > 1 else [0.4]
    return spec, tilt


def tree(branches=4, links=25, dt=0.001):
    """Build a hub on a hinge with several spatial chains hanging from it."""
    spec = _spec(dt)
    hub = spec.worldbody.add_body(pos=[0.0, 0.0, 0.0])
    hub.mass = 4.0
    hub.ipos = [0.0, 0.0, 0.0]
    hub.inertia = [0.5, 3.0, 3.0]
    hub.explicitinertial = True
    hub.add_joint(type=HINGE, axis=[1.0, 0.0, 0.0])
    for k in range(branches):
        x = (k - (branches - 1) / 2) * 1.0
        _hang(hub, (x, 0.0, 0.0), links, True, first=k)
    return spec, [0.3] + [0.2] * (branches)


def double_pendulum(dt=0.001):
    """Build the paper's double pendulum (config/double_pendulum.yaml) in MuJoCo."""
    spec = _spec(dt)
    a = spec.worldbody.add_body(pos=[0.0, 0.0, 0.0])
    a.mass, a.ipos, a.inertia = 3900.0, [1.0, 0.0, 0.0], [162.5, 1381.25, 1381.25]
    a.explicitinertial = True
    a.add_joint(type=HINGE, axis=[1.0, 0.0, 0.0])
    a.add_joint(type=HINGE, axis=[0.0, 1.0, 0.0])
    b = a.add_body(pos=[2.0, 0.0, -0.25])
    b.mass, b.ipos, b.inertia = 1950.0, [0.5, 0.0, 0.25], [81.25, 203.125, 203.125]
    b.explicitinertial = True
    b.add_joint(type=HINGE, axis=[0.0, 1.0, 0.0])
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qvel[0] = math.radians(45.0)
    return model, data


def store(dt=0.001, free=False):
    """Build the store on its aft pivot (a hinge), or free after the release."""
    spec = _spec(dt, gravity=(0.0, 0.0, 9.80665))
    body = spec.worldbody.add_body(pos=[0.0, 0.0, 0.0])
    body.mass, body.ipos, body.inertia = 907.1848, [0.0, 0.0, 0.0], [27.1164, 488.0944, 488.0944]
    body.explicitinertial = True
    if free:
        body.add_freejoint()
    else:
        body.add_joint(type=HINGE, axis=[0.0, 1.0, 0.0], pos=[-0.3292, 0.0, -0.25])
    return spec.compile()


def compile_tilted(spec, tilt):
    """Compile a spec and set its first joints' angles (rad); return model and data."""
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qpos[:len(tilt)] = tilt
    mujoco.mj_forward(model, data)
    return model, data


def scenario(model, data, name, duration):
    """Write the cfem_ros scenario of a MuJoCo model of bodies on hinges, at data's state."""
    bodies = {'ground': {'fixed': True}}
    names = ['ground'] + [f'b{i}' for i in range(1, model.nbody)]
    for i in range(1, model.nbody):
        quat = data.xquat[i]
        bodies[names[i]] = {
            'mass': float(model.body_mass[i]),
            'inertia': [float(v) for v in model.body_inertia[i]],
            'position': [float(v) for v in data.xipos[i]],
            'orientation_xyzw': [float(quat[1]), float(quat[2]), float(quat[3]),
                                 float(quat[0])]}
    joints = {}
    for j in range(model.njnt):
        body = model.jnt_bodyid[j]
        joints[f'j{j}'] = {
            'type': 'hinge', 'parent': names[model.body_parentid[body]], 'child': names[body],
            'anchor': [float(v) for v in data.xanchor[j]],
            'axis': [float(v) for v in data.xaxis[j]]}
    return {'name': name, 'duration': duration, 'dt': float(model.opt.timestep),
            'gravity': [float(v) for v in model.opt.gravity], 'bodies': bodies,
            'joints': joints}


def cg_positions(model, data):
    """CG of every body but the world, (nbody - 1, 3)."""
    return np.array(data.xipos[1:])
