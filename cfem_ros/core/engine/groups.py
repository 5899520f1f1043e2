# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Release groups, release commands by name, and the stiffness weights of joint rows.

A release group (SPEC section 7) is a set of joints that let go in one
instant: whatever releases one of them (its time, a condition on any of
them, a command naming the group or one of its joints) releases all of its
joints still active at the same step boundary. ``ReleaseGroups`` expands a
release to its group and resolves the names of a release command.

``row_weights`` gives each joint row the scale 1 / sqrt(compliance) that
turns the kernel's least-norm split of redundant loads into the
compliance-weighted one (``Topology.weigh``).
"""

from __future__ import annotations

import re
from typing import Optional

from cfem_ros.core.errors import ArgumentError
import numpy as np

#: A release command may name several joints or groups, separated by spaces or commas.
NAME_SEPARATORS = re.compile(r'[\s,]+')
#: Largest ratio of two joints' compliances that weighs a redundant split (above: as it).
MAX_COMPLIANCE_RATIO = 1e4


def command_names(text: str) -> list:
    """Split a release command into the joint and group names it gives (order kept)."""
    names = []
    for name in NAME_SEPARATORS.split(text.strip()):
        if name and name not in names:
            names.append(name)
    return names


class ReleaseGroups:
    """
    The release groups of a model, for the simulator.

    Parameters
    ----------
    model : Model
        Its ``joints`` and ``release_groups``.

    Attributes
    ----------
    group_of : list of str or None
        Per joint, its group's name (None: in no group).
    members : dict
        Group name -> its joints (indices, in the order written).

    """

    def __init__(self, model):
        self.model = model
        self.group_of: list = [None] * len(model.joints)
        self.members = {}
        for group in getattr(model, 'release_groups', ()):
            self.members[group.name] = tuple(group.joints)
            for k in group.joints:
                self.group_of[k] = group.name

    def expand(self, joints, active: np.ndarray) -> list:
        """
        Return the joints a release of ``joints`` lets go, with their groups.

        Parameters
        ----------
        joints : sequence of int
            Joints released now (active ones).
        active : ndarray of bool
            Joints not yet released.

        Returns
        -------
        list of (int, str or None)
            Each active one once, the given ones first, then the other
            active joints of their groups; with its group's name (None if
            none).

        """
        out, seen = [], set()
        for k in joints:
            group = self.group_of[k]
            for j in (k,) if group is None else (k,) + self.members[group]:
                if j not in seen and active[j]:
                    seen.add(j)
                    out.append((int(j), group))
        return out

    def resolve(self, name: str) -> tuple:
        """Return the joints a release command's name stands for (ValueError if none)."""
        if name in self.members:
            return self.members[name]
        for k, joint in enumerate(self.model.joints):
            if joint.name == name:
                return (k,)
        joints = ', '.join(j.name for j in self.model.joints) or 'none'
        if not self.members:
            raise ArgumentError(f'unknown joint {name!r} (joints: {joints})')
        raise ArgumentError(f'unknown joint or release group {name!r} (joints: {joints}; '
                            f'release groups: {", ".join(self.members)})')

    def check_command(self, text: str, active: np.ndarray) -> list:
        """
        Return the joints a release command releases now, in the order named.

        ValueError if it names nothing, an unknown name, or a joint or group
        already released (nothing is released then).
        """
        names = command_names(text)
        if not names:
            raise ArgumentError('empty release command; expected the name of a joint or of a '
                                'release group')
        joints = []
        for name in names:
            members = self.resolve(name)
            if not any(active[k] for k in members):
                what = 'release group' if name in self.members else 'joint'
                raise ArgumentError(f'{what} {name!r} is already released')
            joints.extend(k for k in members if active[k] and k not in joints)
        return joints


def row_weights(model, row_joint: np.ndarray) -> Optional[np.ndarray]:
    """
    Return each row's scale 1 / sqrt(compliance), normalized; None if no joint has one.

    Scaling a constrained row by s scales its multiplier by 1 / s and
    leaves the joint's wrench J^T lambda and the motion unchanged, so the
    least-norm multipliers of the scaled rows minimize lambda^T C lambda
    over the original ones: the split an elastic support of compliance C
    takes in the stiff limit. The scales are relative to the most
    compliant declared row (a common factor changes nothing; scales >= 1
    make a row's violation, as the run's divergence check sees it, no
    smaller); a row without a declared compliance counts as that one.
    Ratios beyond ``MAX_COMPLIANCE_RATIO`` count as that ratio: the stiffer
    support then takes all but 1e-4 of the redundant load already, and
    larger scales would make the solve drop rows (and the divergence check
    see a violation magnified by their square root), changing the motion.

    Parameters
    ----------
    model : Model
        Its joints' ``compliance``.
    row_joint : ndarray of int, shape (m,)
        Each row's joint; rows grouped by joint in the joint's row order.

    """
    joints = model.joints
    if all(joint.compliance is None for joint in joints):
        return None
    softest = max(float(np.max(j.compliance)) for j in joints if j.compliance is not None)
    scale = np.ones(len(row_joint))
    for k, joint in enumerate(joints):
        if joint.compliance is None:
            continue
        rows = np.flatnonzero(row_joint == k)
        with np.errstate(over='ignore'):   # 1e-8 / 5e-324: inf, held at the largest ratio
            ratio = softest / joint.compliance[:len(rows)]
        scale[rows] = np.sqrt(np.minimum(ratio, MAX_COMPLIANCE_RATIO))
    return scale
