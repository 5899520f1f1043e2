# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The equations of motion of a model's bodies under its active joints.

The loads of the active joints are solved in the Lagrange-multiplier form
(CFEM.md, "Cheaper forms"): each constrained direction k of a joint carries a
multiplier lambda_k, the force (or moment) along it, and

    J M^-1 J^T lambda = -gamma - 2 eta J v - eta^2 g - J M^-1 f

where g are the constraint values (paper eqs. 11-12), J their Jacobian with
respect to the velocities (V, w in world axes), gamma = (dJ/dt) v, and f the
external, gravity and gyroscopic loads. The joint table is data
(``model.JOINT_TABLE``); this module never branches on a joint type.

``Dynamics``, a part that ``engine.Simulator`` holds, keeps what the
compiled kernel evaluates them with: the bodies' table (mass properties,
kinematic trajectories) and the applied loads; on the rows of the active
joints (``Topology``, which the simulator keeps and hands to it) it gives
the state's derivative, the velocity change the joints allow and the
redundant rows. ``Simulator`` runs it in time.
"""

from __future__ import annotations

import logging
import math
from typing import Optional

from cfem_ros.core import rotations
from cfem_ros.core.engine import sampling
from cfem_ros.core.engine.bodies import initial_state, mass_table, state_views
from cfem_ros.core.engine.events import Failure
from cfem_ros.core.engine.loads import ScheduledLoads
from cfem_ros.core.engine.sampling import NumericalFailure
from cfem_ros.core.errors import ArgumentError
from cfem_ros.core.model.model import Model
from cfem_ros.core.native import kernel, motion
from cfem_ros.core.native.kernel import BODIES, LOADS, TWIST
import numpy as np

LOG = logging.getLogger('cfem_ros')
#: The warning (a logging format, its arguments the joints and the count) of redundant
#: joints, which a sweep gives once, not once per run.
REDUNDANT_WARNING = ('the joints %s constrain %d direction(s) more than once (redundant '
                     'joints or a closed loop): the motion is exact, the loads of the '
                     'redundant directions are shared in the least-norm sense (weighted '
                     "by the joints' compliance where given)")
#: The same, as information, when every joint of those rows declares its compliance: the
#: split is then the one the scenario asked for, not a fault.
REDUNDANT_NOTE = ('the joints %s constrain %d direction(s) more than once: the loads of the '
                  "redundant directions are split by the joints' declared compliance")
#: Marks the log record of either (``extra``), which a sweep gives once: a caller
#: tells it by this attribute (``redundant_record``), not by its text.
REDUNDANT_EXTRA = {'cfem_redundant_joints': True}


def redundant_record(record) -> bool:
    """Tell whether a log record is the redundant-joint warning or note."""
    return getattr(record, 'cfem_redundant_joints', False)


#: Velocity corrections smaller than this (m/s, rad/s) are not reported.
PROJECTION_REPORT = 1e-9


def _index(lookup, item, what: str) -> int:
    """Return an index as given, or a name's looked up (ValueError 'unknown <what>')."""
    if isinstance(item, str):
        try:
            return lookup(item)
        except ValueError:
            raise ArgumentError(f'unknown {what} {item!r}') from None
    return int(item)


class Dynamics:
    """
    A model's bodies and loads as the kernel evaluates them.

    Parameters
    ----------
    model : Model
        Built by ``scenario.parse_scenario``.
    logger : logging.Logger, optional
        Where warnings go (velocity projection, redundant joints).

    Attributes
    ----------
    y0 : ndarray, shape (13 n,)
        The state at t = 0 (``engine`` module docstring), before the joints
        correct its velocities (``project_velocities``).
    free : ndarray of bool, shape (n,)
        The bodies that move under loads (neither fixed nor kinematic).
    kinematic : bool
        Whether any body follows a trajectory (``carrier.Carriers``).
    bodies : ndarray
        The bodies' table, as the kernel reads it (``bodies.mass_table``).
    scheduled : ScheduledLoads
        The applied loads (``loads``, ``ties``); ``loads`` is their packed array.

    """

    def __init__(self, model: Model, logger: Optional[logging.Logger] = None):
        self.model = model
        self.log = logger or LOG
        self.eta = float(model.baumgarte)
        n = self.n = len(model.bodies)
        # fixed and kinematic bodies are carried with zero inverse mass and inertia
        self.free, self.bodies = mass_table(model)
        self.mass = self.bodies[:, BODIES.B_MASS].copy()
        self.inv_mass = self.bodies[:, BODIES.B_INV_MASS].copy()
        self.inertia_body = self.bodies[:, BODIES.span('B_INERTIA')].reshape(n, 3, 3).copy()
        self.inv_inertia_body = self.bodies[:, BODIES.span('B_INV_INERTIA')].reshape(
            n, 3, 3).copy()   # kg m^2 and its inverse, body axes
        self.gravity = np.asarray(model.gravity, dtype=float)
        # kinematic bodies' trajectories: extra columns, only if there are any (motion.py)
        trajectories = motion.columns(model)
        self.kinematic = trajectories.shape[1] > 0
        if self.kinematic:
            self.bodies = np.ascontiguousarray(np.hstack([self.bodies, trajectories]))
        # applied loads, packed (loads.py): per body force (3), torque (3), 1.0 when in
        # body axes, point (3); then the scenario's scheduled wrenches
        self.scheduled = ScheduledLoads(model, n)   # starts and ends may wait for releases
        self.loads = self.scheduled.array
        self.y0 = initial_state(model)
        self._warned_redundant = False

    @staticmethod
    def derivative(top, y: np.ndarray) -> np.ndarray:
        """Return dy/dt at state y on the rows of top (external wrenches held constant)."""
        out = np.empty_like(y)
        if kernel.derivative(top.system, y, out) < 0.0:
            raise NumericalFailure(sampling.SINGULAR, Failure.SINGULAR)
        return out

    def check_redundancy(self, top, y: np.ndarray) -> int:
        """Detect the redundant rows of top at state y; warn once; return the remaining DOF."""
        free_dof = 6 * int(self.free.sum())
        null = top.null_space(y, self.n)
        rank = top.m - null.shape[1]
        if rank < top.m:
            if not self._warned_redundant:
                # the joints of the rows that take part in a redundant combination
                joints = [self.model.joints[k]
                          for k in sorted(set(top.joint[np.any(np.abs(null) > 1e-6, axis=1)]))]
                names = ', '.join(sorted(joint.name for joint in joints))
                if all(joint.compliance is not None for joint in joints):
                    self.log.info(REDUNDANT_NOTE, names, top.m - rank, extra=REDUNDANT_EXTRA)
                else:
                    self.log.warning(REDUNDANT_WARNING, names, top.m - rank, extra=REDUNDANT_EXTRA)
                self._warned_redundant = True
            top.dense = 2
        return free_dof - rank

    def project_velocities(self, top, y: np.ndarray):
        """Make the velocities of state y consistent with the rows of top (mass weighted)."""
        if top.m == 0:
            return
        delta = self.joint_projection(top, y)
        if not np.abs(delta).max() > PROJECTION_REPORT:
            return
        _, vel, quat, rates = state_views(y, self.n)
        linear, angular = delta[:, TWIST.span('V_LINEAR')], delta[:, TWIST.span('V_ANGULAR')]
        vel += linear
        rates += np.einsum('nji,nj->ni', rotations.matrices(quat), angular)
        for i in np.flatnonzero(np.abs(delta).max(axis=1) > PROJECTION_REPORT):
            self.log.warning(
                'initial velocities of body %r are inconsistent with its joints; '
                'corrected (mass weighted) by %.3g m/s and %.3g deg/s',
                self.model.bodies[i].name, np.linalg.norm(linear[i]),
                math.degrees(np.linalg.norm(angular[i])))

    def joint_projection(self, top, y: np.ndarray) -> np.ndarray:
        """Return the least (mass weighted) change of y's velocities the rows allow (``TWIST``)."""
        delta = np.zeros((self.n, TWIST.WIDTH))
        kernel.project(top.system, y, delta)
        return delta

    # --------------------------------------------------------------- inputs

    def set_wrench(self, body, force, torque, body_axes: bool = False, point=None):
        """
        Hold an external force and moment on a body until replaced.

        Parameters
        ----------
        body : str or int
            Name or index of a body that is not fixed.
        force : array_like, shape (3,)
            N, world axes, or body axes if body_axes.
        torque : array_like, shape (3,)
            N m, same axes as force.
        body_axes : bool
            True: force and torque are in body axes and turn with the body.
        point : array_like, shape (3,), optional
            Where the force acts, body axes, from the CG, m (default: the CG);
            the moment about the CG is torque + r x F, r turning with the body.

        """
        i = self.body_index(body)
        force, torque, point = held_wrench(self.model.bodies[i], force, torque, point)
        row = self.loads[i]
        row[LOADS.span('H_FORCE')], row[LOADS.span('H_TORQUE')] = force, torque
        row[LOADS.H_AXES] = 1.0 if body_axes else 0.0
        row[LOADS.span('H_POINT')] = point

    def held_wrenches(self) -> np.ndarray:
        """
        Return the wrenches held on the bodies (``set_wrench``), shape (n, 10).

        Per body: force (N) and torque (N m), in world axes, or in body axes
        where column 6 is 1; then the force's point (body axes, from the CG, m).
        """
        rows = self.loads[:self.n]
        return np.hstack([rows[:, LOADS.span('H_FORCE')], rows[:, LOADS.span('H_TORQUE')],
                          rows[:, LOADS.span('H_AXES')], rows[:, LOADS.span('H_POINT')]])

    def body_index(self, body) -> int:
        """Return the index of a body given by name or index."""
        return _index(self.model.body_index, body, 'body')

    def joint_index(self, joint) -> int:
        """Return the index of a joint given by name or index."""
        return _index(self.model.joint_index, joint, 'joint')


def held_wrench(body, force, torque, point=None):
    """
    Check a wrench to hold on a body (``Simulator.set_wrench``); return it as arrays.

    Returns (force, torque, point) as float arrays of 3, point zero (the CG)
    if None; ValueError if a shape or number is wrong or the body is fixed
    or kinematic.
    """
    force = np.asarray(force, dtype=float)
    torque = np.asarray(torque, dtype=float)
    point = np.zeros(3) if point is None else np.asarray(point, dtype=float)
    if force.shape != (3,) or torque.shape != (3,) or point.shape != (3,):
        raise ArgumentError('force, torque and point must have 3 components each')
    if not (np.isfinite(force).all() and np.isfinite(torque).all()
            and np.isfinite(point).all()):
        raise ArgumentError('force, torque and point must be finite')
    if not body.dynamic:
        what = 'fixed' if body.fixed else 'kinematic (it follows its motion)'
        raise ArgumentError(f'body {body.name!r} is {what} and cannot be loaded')
    return force, torque, point
