# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What a sample shows: the sample grid, and a state's outputs and joint loads.

``SampleGrid`` lets the kernel take samples on k / rate_hz on its way;
``Sampling``, a part that ``Simulator`` holds, computes the numbers a
sample publishes at a state: each joint's load on its child, its points and
its angle, the applied loads, the air and the states relative to a
reference, on the rows of the joints active now (``bind``).
"""

from __future__ import annotations

from cfem_ros.core import rotations
from cfem_ros.core.engine.bodies import state_views
from cfem_ros.core.engine.events import Failure
from cfem_ros.core.errors import ArgumentError, CfemError
from cfem_ros.core.native import kernel
from cfem_ros.core.native.kernel import PLAN, SAMPLE
import numpy as np


#: Why a solve failed, as the messages of a failed run say it.
SINGULAR = 'the constraint system is singular or too ill-conditioned to solve'

#: Why a sample failed while the state is finite.
LOADS_NOT_FINITE = ('the joint loads are not finite (masses, inertias or loads beyond '
                    'what double precision holds)')


class NumericalFailure(CfemError):
    """
    Raised inside a step or a sample; turned into ``status`` ``Status.FAILED``.

    ``failure`` says which (``events.Failure``), for a caller that tells
    failures apart; the message says it to a user.
    """

    def __init__(self, message: str, failure: Failure = Failure.OTHER):
        super().__init__(message)
        self.failure = failure


def _apply(matrices, vectors):
    """Row-wise matrix-vector products, (m, 3, 3) @ (m, 3)."""
    return np.einsum('mij,mj->mi', matrices, vectors)


class SampleGrid:
    """
    Samples on the grid k / rate_hz, taken by the kernel inside ``Simulator.advance_to``.

    Steps are cut at the grid's times (as they are when each sample time is
    a target of its own), and at each the sample's outputs
    (``Simulator.outputs``) go to the next of ``rows``; rows with no columns
    only count the samples. Before each call, ``reset`` says where the next
    rows go.

    Parameters
    ----------
    rate_hz : float
        Samples per second.

    """

    def __init__(self, rate_hz: float):
        #: rate (Hz), index of the next sample, samples taken in the last call.
        self.state = np.array([float(rate_hz), 0.0, 0.0])
        self.rows = np.empty((0, 0))

    def reset(self, next_index: int, rows: np.ndarray):
        """Take samples from index next_index on, into rows (C-contiguous float64)."""
        if rows.ndim != 2 or rows.dtype != np.float64 or not rows.flags.c_contiguous:
            raise ArgumentError('sample rows must be a C-contiguous 2-d float64 array')
        self.state[1:] = (next_index, 0)
        self.rows = rows

    @property
    def taken(self) -> int:
        """Return the number of samples taken since ``reset``."""
        return int(self.state[2])

    @property
    def next_time(self) -> float:
        """Return the time of the next sample to take, s."""
        return self.state[1] / self.state[0]


class Sampling:
    """
    What a sample shows of a simulator's state, on the rows of its active joints.

    Parameters
    ----------
    model : Model
        The simulator's model.
    joints : JointTables
        Every joint as rows in body axes (``topology.JointTables``).
    scheduled : ScheduledLoads
        The applied loads (``loads``): their sources are part of a sample.

    Attributes
    ----------
    active_joints : tuple
        The active joints (model indices, ascending), as a sample lists their loads.

    """

    def __init__(self, model, joints, scheduled):
        self.model, self.joints, self.scheduled = model, joints, scheduled
        self.n = len(model.bodies)
        self.topology = None
        self.active_joints = ()

    def bind(self, topology, active_joints: tuple):
        """Sample on these rows from now on (the joints active after a release)."""
        self.topology, self.active_joints = topology, active_joints

    def joint_loads(self, y):
        """
        Each joint's load on its child at a state, and the constraint values.

        Returns
        -------
        force, moment : ndarray, shape (n_joints, 3)
            World axes, N and N m about the joint point; zero for released joints.
        value : ndarray, shape (m,)
            Constraint values of the active rows (m, or rad).

        Raises
        ------
        NumericalFailure
            If the solve is singular or ill-conditioned, or a load is not finite.

        """
        top = self.topology
        n_j = len(self.model.joints)
        force, moment = np.zeros((n_j, 3)), np.zeros((n_j, 3))
        lines = len(top.plan)
        f_line, m_line = np.empty((lines, 3)), np.empty((lines, 3))
        if not kernel.joint_loads(top.system, np.ascontiguousarray(y), f_line, m_line):
            raise NumericalFailure(SINGULAR, Failure.SINGULAR)
        if not (np.isfinite(f_line).all() and np.isfinite(m_line).all()):
            raise NumericalFailure(LOADS_NOT_FINITE, Failure.LOADS_NOT_FINITE)
        force[top.plan[:, PLAN.P_JOINT]] = f_line
        moment[top.plan[:, PLAN.P_JOINT]] = m_line
        value = kernel.constraint_values(top.system).copy()
        return force, moment, value

    def outputs_size(self) -> int:
        """
        Return the numbers of a sample (``Simulator.outputs``, one kernel call).

        Per body its pose (CG position, m; quaternion x y z w, body to
        world) and twist (CG velocity, m/s, and angular velocity, rad/s,
        both in body axes); then per active joint its force and moment on
        the child (world axes, N and N m about the joint point); then per
        scheduled wrench source (``applied_sources``) its force and moment
        about the CG of the body it acts on (world axes); then per body
        with aero tables the air it sees (``air``); then per
        ``model.references`` pair, the body's pose and twist in its
        reference's frame (``motion.sample_relative``).
        """
        return (SAMPLE.BODY * self.n + SAMPLE.JOINT * len(self.active_joints)
                + self.scheduled.outputs_size + SAMPLE.BODY * len(self.model.references))

    def outputs(self, y, out: np.ndarray) -> np.ndarray:
        """
        Fill out with what a sample publishes at state y (``outputs_size``), in one kernel call.

        Raises
        ------
        NumericalFailure
            If the solve is singular or ill-conditioned, or a load is not finite.

        """
        code = kernel.sample_outputs(self.topology.system, y, out)
        if code == kernel.SINGULAR or code == kernel.LOADS_NOT_FINITE:   # else a finite row
            raise (NumericalFailure(SINGULAR, Failure.SINGULAR) if code == kernel.SINGULAR
                   else NumericalFailure(LOADS_NOT_FINITE, Failure.LOADS_NOT_FINITE))
        return out

    @property
    def applied_sources(self) -> list:
        """Return (body, source) of each scheduled load a sample shows (``outputs``)."""
        return self.scheduled.sources()

    def applied_loads(self, outputs: np.ndarray) -> np.ndarray:
        """Return each applied source's force and moment about its body's CG, world, (k, 6)."""
        first = SAMPLE.BODY * self.n + SAMPLE.JOINT * len(self.active_joints)
        return outputs[first:first + SAMPLE.WRENCH * len(self.applied_sources)].reshape(
            -1, SAMPLE.WRENCH)

    def air(self, outputs: np.ndarray) -> np.ndarray:
        """
        Return the air each body with aero tables sees, (len(model.aero), ``SAMPLE.AIR``).

        Per body: alpha, beta (deg), Mach, dynamic pressure (Pa), density
        (kg/m^3), airspeed (m/s), CX, CY, CZ, and Cl, Cm, Cn about the
        actual CG (``aero.AIR_TOPICS``).
        """
        first = (SAMPLE.BODY * self.n + SAMPLE.JOINT * len(self.active_joints)
                 + SAMPLE.WRENCH * len(self.applied_sources))
        return outputs[first:first + SAMPLE.AIR * len(self.model.aero)].reshape(-1, SAMPLE.AIR)

    def relative_states(self, y) -> np.ndarray:
        """
        Return each ``model.references`` body's state in its reference's frame, (k, 13).

        Per pair: CG position relative to the reference's CG (3) and attitude
        (x y z w, body to reference), then the CG velocity seen from the
        reference and the relative angular velocity (3 + 3); all in the
        reference's axes (``kernel.relative_states``: the sample's own formula).
        """
        pairs = self.model.references
        if not pairs:
            return np.empty((0, SAMPLE.BODY))
        body, ref = (np.array(p, dtype=int) for p in zip(*pairs))
        pos, vel, quat, rates = state_views(y, self.n)
        return kernel.relative_states(pos[body], vel[body], quat[body], rates[body], pos[ref],
                                      vel[ref], quat[ref], rates[ref])

    def joint_points(self, y):
        """
        Each joint's point as carried by its parent and by its child, at state y.

        Returns
        -------
        on_parent, on_child : ndarray, shape (n_joints, 3)
            World, m.

        """
        pos, _, quat, _ = state_views(y, self.n)
        rot = rotations.matrices(quat)
        joints = self.joints
        pa, pb = joints.parent, joints.child
        return (pos[pa] + _apply(rot[pa], joints.anchor_a),
                pos[pb] + _apply(rot[pb], joints.anchor_b))

    def joint_angles(self, y) -> np.ndarray:
        """Rotation of each child relative to its parent since t = 0 at state y, rad."""
        joints = self.joints
        quat = state_views(y, self.n)[2]
        quat = quat / np.linalg.norm(quat, axis=1)[:, None]
        relative = rotations.multiply(
            rotations.conjugate(quat[joints.parent]), quat[joints.child])
        return rotations.rotation_angle(
            rotations.multiply(rotations.conjugate(joints.relative0), relative))

    def constraint_violation(self, y) -> float:
        """Largest |g| of the active rows at state y (m, or rad for rotation rows)."""
        if self.topology.m == 0:
            return 0.0
        return float(np.abs(self.joint_loads(y)[2]).max())
