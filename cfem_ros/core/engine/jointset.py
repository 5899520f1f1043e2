# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A run's joints: their rows, their releases and groups, and the rows of the active ones.

``JointSet`` is the part of ``Simulator`` that releases joints and that a
release changes: which joints are active (``Releases``, with the groups
that release together, ``ReleaseGroups``), the rows the kernel solves for
them (``Topology``, rebuilt at each release and bound to the bodies' table
and loads of ``Dynamics``, and to what a sample shows, ``Sampling``) and the
applied loads tied to a release (``ScheduledLoads.released``).
"""

from __future__ import annotations

from cfem_ros.core.engine.groups import ReleaseGroups, row_weights
from cfem_ros.core.engine.releases import Releases
from cfem_ros.core.engine.sampling import Sampling
from cfem_ros.core.engine.topology import JointTables, Topology
from cfem_ros.core.errors import ArgumentError
import numpy as np


class JointSet:
    """
    The joints of a run, active or released, and the active ones' rows.

    Parameters
    ----------
    model : Model
        The run's model.
    pos0, quat0 : ndarray, shapes (n, 3) and (n, 4)
        The bodies' CG positions (world, m) and attitudes at t = 0, in which
        the joints' rows are written in body axes.
    dynamics : Dynamics
        The bodies' table and loads the rows are bound to.

    Attributes
    ----------
    tables : JointTables
        Every joint as rows in body axes.
    groups : ReleaseGroups
        The joints that release together.
    releases : Releases
        Which joints are active, their triggers and the events so far.
    sampling : Sampling
        What a sample shows, on the rows of the active joints.
    topology : Topology or None
        The rows of the active joints (``rebuild``).
    dof : int
        Degrees of freedom left by the active joints.

    """

    def __init__(self, model, pos0: np.ndarray, quat0: np.ndarray, dynamics):
        self.model, self.dynamics = model, dynamics
        self.tables = JointTables(model, pos0, quat0)
        self.sampling = Sampling(model, self.tables, dynamics.scheduled)
        self.groups = ReleaseGroups(model)
        self.releases = Releases(self.tables, [joint.name for joint in model.joints],
                                 self.groups.group_of)
        self.topology = None
        self.dof = 0

    def rebuild(self, y: np.ndarray) -> Topology:
        """Rebuild the rows, solve plan and workspace of the active joints at y; return them."""
        dynamics, sampling = self.dynamics, self.sampling
        active = self.releases.active
        top = self.topology = Topology(self.tables.rows, active, dynamics.free)
        self.releases.update(active, top.line)
        indices = np.flatnonzero(active)
        sampling.bind(top, tuple(indices.tolist()))
        order = np.ascontiguousarray(top.line[indices], dtype=np.int64)
        top.bind(dynamics.bodies, dynamics.gravity, dynamics.loads, dynamics.eta,
                 self.releases.watched(), order)
        self.dof = dynamics.check_redundancy(top, y)
        if top.dense == 2:   # redundant rows: split by the joints' compliance, if given
            top.weigh(row_weights(self.model, top.joint))
        return top

    def commanded(self, names, joint_index) -> list:
        """
        Return the joints a release command names (``Simulator.release_all``).

        names: a string of names (spaces or commas apart, ``groups.command_names``)
        or a joint's index or name; ValueError if one is unknown or nothing
        named is still active.
        """
        active = self.releases.active
        if isinstance(names, str):
            return self.groups.check_command(names, active)
        k = joint_index(names)
        if not active[k]:
            raise ArgumentError(f'joint {self.model.joints[k].name!r} is already released')
        return [k]

    def release(self, joints, t: float, y: np.ndarray, cause: str) -> list:
        """
        Release joints and the rest of their groups at t, state y; return the events.

        The rows are rebuilt (``rebuild``), and the applied loads tied to
        these releases are switched on (or off) now or timed for later.
        """
        released = [k for k, _ in self.groups.expand(joints, self.releases.active)]
        events = self.releases.release(released, t, cause)
        self.rebuild(y)
        scheduled = self.dynamics.scheduled
        if scheduled.released(released, t):
            scheduled.switch(t, y)
        return events
