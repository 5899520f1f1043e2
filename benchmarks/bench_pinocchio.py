# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
One RK4 step of a hinge chain in cfem_ros against 4 calls of Pinocchio's ``aba``.

An RK4 step evaluates the dynamics 4 times; Pinocchio's articulated-body
algorithm (reduced coordinates, O(N)) gives the joint accelerations of one
evaluation. The chain is the suite's spatial one (``models.chain``: N
links of 1 m and 1 kg on hinges, axes y and x in turn, hanging from the
ground, tilted), built here in Pinocchio from ``models``' constants (MuJoCo
is not needed); the cfem_ros scenario is written from Pinocchio's forward
kinematics, as ``models.scenario`` writes it from MuJoCo's. Before timing,
the two are checked to be the same physics: at a state with every joint
angle and rate set, ``aba``'s joint accelerations against
cfem_ros's (the difference of a link's and its parent's angular
accelerations along the hinge axis, from ``Simulator.derivative``) to 1e-9
relative.

Timing: CPU time (this process), the two taking turns; per turn, K steps of
ours (``Simulator.advance_to``, a fresh simulator prepared untimed) and K x 4
``aba`` calls, each per step; printed: medians and the median of the turns'
ratios ours / Pinocchio. Usage:
.venv/bin/python benchmarks/bench_pinocchio.py [--sizes 30 100 300] [--turns 15]

Measured 2026-12-02 (helper E; pinocchio 4.1.0; load average 14 to 16 on the 2 cores;
CPU time; 4 runs of --sizes 300 --turns 7 each, the kernel before and after the tree
solve's row terms left out a translation row's unread rotation columns, alternating):
ours 197.3 to 209.5 us a step before, 197.5 to 202.2 after; 4 aba 303 to 312 us; ratio
ours / aba 0.67 (x1.49) before, 0.655 (x1.53) after, where issue 46 asks 0.5 (x2.0):
not met. Of ours at N = 300 (perf, the kernel's own functions): the tree solve's passes
45 %, the row terms 32 %, the body terms 13 %, dy/dt and the RK4 sums 6 %; per
advance_to call the engine adds about 140 us of CPU (the end's violation check, a
solve of the joint loads) and 75 us of Python, 11 us a step over this script's 20 steps.
"""

import argparse
import os
import statistics
import time

from cfem_ros import parse_scenario, Simulator
from cfem_ros.core.engine.bodies import state_views
import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation

DT = 0.001
#: The links of the suite's chains (``models.py``'s LINK, LINK_MASS and LINK_INERTIA,
#: written again here: that module needs MuJoCo).
LINK, LINK_MASS = 1.0, 1.0                  # m, kg
LINK_INERTIA = [LINK_MASS * LINK ** 2 / 12, LINK_MASS * LINK ** 2 / 12, 0.002]
#: The relative agreement of the accelerations asked of the two models.
AGREEMENT = 1e-9


def pinocchio_chain(n):
    """
    Return the Pinocchio model of ``models.chain(n, spatial=True)`` and its tilted start.

    The same links as there: 1 m apart, 1 kg each with its CG 0.5 m below its
    hinge and inertia ``LINK_INERTIA``, hinge axes y and x in turn.
    """
    model = pin.Model()
    model.gravity = pin.Motion(np.array([0.0, 0.0, -9.80665, 0.0, 0.0, 0.0]))
    parent = 0
    for i in range(n):
        joint = pin.JointModelRX() if i % 2 else pin.JointModelRY()   # aba's fastest hinges
        offset = np.zeros(3) if i == 0 else np.array([0.0, 0.0, -LINK])
        parent = model.addJoint(parent, joint, pin.SE3(np.eye(3), offset), f'j{i}')
        model.appendBodyToJoint(parent, pin.Inertia(LINK_MASS,
                                                    np.array([0.0, 0.0, -LINK / 2]),
                                                    np.diag(LINK_INERTIA)),
                                pin.SE3.Identity())
    q0 = np.zeros(n)
    q0[:2] = [0.4, 0.3] if n > 1 else [0.4]                  # models.chain's tilt
    return model, q0


def scenario(model, data, q, name):
    """Write the cfem_ros scenario of a Pinocchio chain of hinges at angles q (at rest)."""
    pin.forwardKinematics(model, data, q)
    bodies, joints = {'ground': {'fixed': True}}, {}
    for jid, (placement, inertia, axis) in enumerate(zip(*_parts(model, data)), start=1):
        bodies[f'b{jid}'] = {
            'mass': float(inertia.mass), 'inertia': [float(v) for v in
                                                     np.diag(inertia.inertia)],
            'position': [float(v) for v in placement.act(inertia.lever)],
            'orientation_xyzw': [float(v) for v in
                                 Rotation.from_matrix(placement.rotation).as_quat()]}
        joints[f'j{jid - 1}'] = {
            'type': 'hinge', 'parent': 'ground' if jid == 1 else f'b{jid - 1}',
            'child': f'b{jid}', 'anchor': [float(v) for v in placement.translation],
            'axis': [float(v) for v in placement.rotation @ axis]}
    return {'name': name, 'duration': 1.0, 'dt': DT,
            'gravity': [float(v) for v in model.gravity.linear], 'bodies': bodies,
            'joints': joints}


#: The unit axis of each of Pinocchio's hinges about an axis of its joint frame.
AXES = {'JointModelRX': np.array([1.0, 0.0, 0.0]), 'JointModelRY': np.array([0.0, 1.0, 0.0]),
        'JointModelRZ': np.array([0.0, 0.0, 1.0])}


def _parts(model, data):
    """Return the joints' placements, inertias and axes (joint frame), from joint 1 on."""
    # one copy of each vector: indexing Pinocchio's vectors from Python copies them whole
    return (list(data.oMi)[1:], list(model.inertias)[1:],
            [AXES[joint.shortname()] for joint in list(model.joints)[1:]])


def chain(n):
    """Return (cfem_ros model, Pinocchio model and data, the tilted start's joint angles)."""
    model, q0 = pinocchio_chain(n)
    data = model.createData()   # once: Pinocchio's Data of 300 links takes about 1 s
    return parse_scenario(scenario(model, data, q0, f'chain{n}')), model, data, q0


def cfem_state(sim, model, data, q, v):
    """Return cfem_ros's state y of the Pinocchio configuration (q, v), and the hinge axes."""
    pin.forwardKinematics(model, data, q, v)
    y = sim.y.copy()
    position, velocity, quaternion, rates = state_views(y, sim.n)
    axes = np.zeros((model.njoints - 1, 3))
    motions = list(data.v)[1:]
    for jid, (placement, inertia, axis) in enumerate(zip(*_parts(model, data)), start=1):
        body = sim.body_index(f'b{jid}')
        turn, motion = placement.rotation, motions[jid - 1]
        spin = motion.angular                                    # joint frame
        position[body] = placement.act(inertia.lever)
        velocity[body] = turn @ (motion.linear + np.cross(spin, inertia.lever))
        quaternion[body] = Rotation.from_matrix(turn).as_quat()  # x, y, z, w
        rates[body] = spin                                       # body axes = joint axes here
        axes[jid - 1] = turn @ axis
    return y, axes


def check_same_physics(cfem, model, data, q0, seed=1):
    """
    Return the largest relative difference of ``aba``'s and cfem_ros's joint accelerations.

    At the tilted start's angles moved by up to 0.3 rad and rates up to 1 rad/s
    (seeded), so that the velocity terms count too.
    """
    rng = np.random.default_rng(seed)
    q = q0 + rng.uniform(-0.3, 0.3, model.nq)
    v = rng.uniform(-1.0, 1.0, model.nv)
    theirs = pin.aba(model, data, q, v, np.zeros(model.nv)).copy()
    sim = Simulator(cfem)
    y, axes = cfem_state(sim, model, data, q, v)
    dy = sim.derivative(y)
    _, _, quaternion, _ = state_views(y, sim.n)
    _, _, _, spin_rate = state_views(dy, sim.n)                  # body axes
    world = Rotation.from_quat(quaternion).apply(spin_rate)     # d(R w)/dt = R dw/dt
    parents = [sim.body_index('ground')] + [sim.body_index(f'b{j}')
                                            for j in range(1, model.njoints - 1)]
    bodies = [sim.body_index(f'b{j}') for j in range(1, model.njoints)]
    ours = np.einsum('ij,ij->i', axes, world[bodies] - world[parents])
    return float(np.max(np.abs(ours - theirs)) / np.max(np.abs(theirs)))


def steps_for(n):
    return max(10, min(200, 6000 // n))


def timed(cfem, model, data, q0, turns):
    """Return per-step CPU s of ours and of 4 aba calls (medians), and the turns' median ratio."""
    steps = steps_for(model.nv)
    v, tau = np.zeros(model.nv), np.zeros(model.nv)
    ours, theirs = [], []
    for _ in range(turns):
        sim = Simulator(cfem)
        start = time.process_time()
        assert sim.advance_to(steps * cfem.dt)
        ours.append((time.process_time() - start) / steps)
        start = time.process_time()
        for _ in range(steps):
            for _ in range(4):
                pin.aba(model, data, q0, v, tau)
        theirs.append((time.process_time() - start) / steps)
    ratios = np.array(ours) / np.array(theirs)
    return statistics.median(ours), statistics.median(theirs), float(np.median(ratios))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--sizes', type=int, nargs='+', default=[30, 100, 300])
    parser.add_argument('--turns', type=int, default=15)
    args = parser.parse_args()
    print(f'pinocchio {pin.__version__}, spatial hinge chains (axes y and x in turn), '
          f'dt = {DT * 1e3:g} ms, CPU time, median of {args.turns} turns, load '
          + ' '.join(f'{v:.2f}' for v in os.getloadavg()), flush=True)
    print(f'{"N":>5} {"ddq rel diff":>13} {"ours us/step":>13} {"4 aba us":>9} '
          f'{"ours/aba":>9}')
    for n in args.sizes:
        cfem, model, data, q0 = chain(n)
        difference = check_same_physics(cfem, model, data, q0)
        ours, theirs, ratio = timed(cfem, model, data, q0, args.turns)
        flag = '' if difference <= AGREEMENT else f'  NOT THE SAME PHYSICS (> {AGREEMENT:g})'
        print(f'{n:5d} {difference:13.2e} {ours * 1e6:13.1f} {theirs * 1e6:9.1f} '
              f'{ratio:9.2f}{flag}', flush=True)


if __name__ == '__main__':
    main()
