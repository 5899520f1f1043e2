# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The joints of a model as constraint rows, and the rows of the active ones.

``JointTables`` turns the model's joints into row tables in body axes, once
per run; ``Topology`` keeps the rows of the joints still active and how the
kernel solves them (a leaves-first tree plan, or the dense form for closed
loops), and finds redundant rows.
"""

from __future__ import annotations

import os
import resource

from cfem_ros.core import rotations
from cfem_ros.core.errors import CfemError
from cfem_ros.core.native import kernel
from cfem_ros.core.native.kernel import JOINTS_F, JOINTS_I, PLAN, ROWS_F, ROWS_I
import numpy as np


class ModelTooLarge(CfemError):
    """A model whose joint solve needs more memory than the process may have."""


def memory_limit() -> float:
    """Return the bytes this process may allocate: physical memory, or a lower RLIMIT_AS."""
    limit = float(os.sysconf('SC_PAGE_SIZE') * os.sysconf('SC_PHYS_PAGES'))
    soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    return min(limit, float(soft)) if soft != resource.RLIM_INFINITY else limit


def check_memory(n: int, m: int, nj: int, dense: int):
    """
    Check that the solve workspace of n bodies, m rows and nj joints fits in memory.

    A tree's is linear in the bodies; closed loops (dense) add the m x m
    complement and its eigenvectors, and the dense Jacobians (m, 6 n) the
    redundancy check makes. Raises ModelTooLarge, before the System
    allocates anything, if that is more than half the memory the process
    may have.
    """
    size = kernel.workspace_size(n, m, nj, dense)
    need = 8.0 * size + (8.0 * m * (12.0 * n + 2.0 * m) if dense else 0.0)
    limit = memory_limit()
    if need > 0.5 * limit:
        form = ('closed loops: a dense m x m solve' if dense
                else 'a tree: linear in the bodies')
        raise ModelTooLarge(
            f'the model is too large for this memory: {n} bodies, {m} constraint rows '
            f'({form}) need {need / 2**30:.3g} GiB for the joint solve, more than half of '
            f'the {limit / 2**30:.3g} GiB this process may use; expected a smaller model'
            + (' (or a tree: cut the closed loops)' if dense else ''))


class JointTables:
    """
    Every joint of a model as rows in body axes, built once from the state at t = 0.

    Attributes
    ----------
    parent, child : ndarray of int, shape (n_joints,)
        Body indices of each joint's ends.
    anchor_a, anchor_b : ndarray, shape (n_joints, 3)
        The joint point in the parent's and in the child's body axes, m.
    triggers : ndarray, shape (n_joints, 4)
        Release time (s), angle (rad), distance (m) and force (N); NaN: none.
    relative0 : ndarray, shape (n_joints, 4)
        Attitude of each child relative to its parent at t = 0.
    rows : dict
        Row tables of all joints (``Topology`` keeps the active ones).
    joints_i, joints_f : ndarray
        Ends, anchors and relative attitude per joint, for the kernel's
        release conditions.

    """

    def __init__(self, model, pos0: np.ndarray, quat0: np.ndarray):
        rot0 = rotations.matrices(quat0)
        t_rows, r_rows = [], []
        n_j = len(model.joints)
        self.parent = np.array([j.parent for j in model.joints], dtype=int)
        self.child = np.array([j.child for j in model.joints], dtype=int)
        self.anchor_a = np.zeros((n_j, 3))
        self.anchor_b = np.zeros((n_j, 3))
        self.triggers = np.full((n_j, 4), np.nan)
        for k, joint in enumerate(model.joints):
            a, b = joint.parent, joint.child
            anchor_a = rot0[a].T @ (joint.anchor - pos0[a])
            anchor_b = rot0[b].T @ (joint.anchor - pos0[b])
            self.anchor_a[k] = anchor_a
            self.anchor_b[k] = anchor_b
            triad_a = joint.triad @ rot0[a]   # rows: u_i in A's body axes
            triad_b = joint.triad @ rot0[b]
            for i in joint.rows.translation:
                t_rows.append((k, a, b, triad_a[i], anchor_a, anchor_b))
            for i, j in joint.rows.rotation:
                r_rows.append((k, a, b, triad_a[i], triad_b[j]))
            rel = joint.release
            self.triggers[k] = [np.nan if v is None else v
                                for v in (rel.time, rel.angle, rel.distance, rel.force)]
        self.relative0 = rotations.multiply(
            rotations.conjugate(quat0[self.parent]), quat0[self.child])

        rows = sorted(t_rows + [(k, a, b, u, v, None) for k, a, b, u, v in r_rows],
                      key=lambda row: (row[0], row[5] is None))
        rows_i = np.zeros((len(rows), ROWS_I.WIDTH), dtype=np.int64)
        vectors = np.zeros((len(rows), ROWS_F.WIDTH))
        for r, (_, a, b, u, v, anchor_b) in enumerate(rows):
            rows_i[r, ROWS_I.R_PARENT], rows_i[r, ROWS_I.R_CHILD] = a, b
            if anchor_b is None:
                rows_i[r, ROWS_I.R_KIND] = ROWS_I.KIND_ROTATION
                vectors[r, ROWS_F.span('R_VECTOR_A')] = u
                vectors[r, ROWS_F.span('R_VECTOR_B')] = v
            else:
                rows_i[r, ROWS_I.R_KIND] = ROWS_I.KIND_TRANSLATION
                vectors[r, ROWS_F.span('R_AXIS')] = u
                vectors[r, ROWS_F.span('R_ANCHOR_A')] = v
                vectors[r, ROWS_F.span('R_ANCHOR_B')] = anchor_b
        self.rows = {
            'joint': np.array([r[0] for r in rows], dtype=np.int64),
            'rows_i': rows_i,
            'vectors': vectors,
            'ends': np.column_stack([self.parent, self.child]).reshape(-1, 2),
        }
        # for the release conditions: ends, anchors and relative attitude at t = 0
        self.joints_i = np.zeros((n_j, JOINTS_I.WIDTH), dtype=np.int64)
        self.joints_i[:, JOINTS_I.J_PARENT], self.joints_i[:, JOINTS_I.J_CHILD] = (
            self.parent, self.child)
        self.joints_f = np.zeros((n_j, JOINTS_F.WIDTH))
        self.joints_f[:, JOINTS_F.span('J_ANCHOR_A')] = self.anchor_a
        self.joints_f[:, JOINTS_F.span('J_ANCHOR_B')] = self.anchor_b
        self.joints_f[:, JOINTS_F.span('J_RELATIVE')] = self.relative0


class Topology:
    """
    The constraint rows of the active joints and how to solve them, for ``kernel``.

    Rows come grouped by joint, translation rows (primitive 1) before
    rotation rows (primitive 2 with perpendicular vectors); vectors are in
    the body axes of the body that carries them. When the joints form a
    forest (all fixed bodies counted as one ground), ``plan`` lists them
    leaves first for the kernel's linear-time tree solve; otherwise (closed
    loops, two joints on one pair) the dense form is used.
    """

    def __init__(self, tables: dict, active: np.ndarray, free: np.ndarray):
        keep = active[tables['joint']]
        self.joint = tables['joint'][keep]
        self.rows_i = np.array(tables['rows_i'][keep])
        self.rows_f = np.ascontiguousarray(tables['vectors'][keep])
        kind = self.rows_i[:, ROWS_I.R_KIND]
        self.translation = kind != ROWS_I.KIND_ROTATION
        # a translation row at the same joint point as the row before (the kernel computes
        # the point's terms once per joint)
        points = slice(ROWS_F.R_ANCHOR_A, ROWS_F.span('R_ANCHOR_B').stop)
        kind[1:][self.translation[1:] & self.translation[:-1]
                 & (self.joint[1:] == self.joint[:-1])
                 & (self.rows_f[1:, points] == self.rows_f[:-1, points]).all(axis=1)] = (
            ROWS_I.KIND_SAME_POINT)
        self.m = len(self.joint)
        joints = np.flatnonzero(active)
        first = np.searchsorted(self.joint, joints)
        size = len(active)
        counts = np.column_stack([
            np.bincount(self.joint[self.translation], minlength=size)[joints],
            np.bincount(self.joint[~self.translation], minlength=size)[joints]]).astype(np.int64)
        ends = tables['ends'][joints]
        lines = self._forest(joints, ends, free)
        #: The solve until ``bind`` (then the System's): 0 tree, 1 dense, 2 least squares.
        self._dense = 0 if lines is not None else 1
        if lines is None:   # closed loops: every joint as written, no tree
            lines = [(i, ends[i, 1], ends[i, 0], 1) for i in range(len(joints))]
        self.plan = _plan(lines, first, counts, joints)
        self.roots = np.where(free, 0, -1).astype(np.int64)
        held = set(self.plan[:, PLAN.P_CHILD].tolist())
        touched = held | set(self.plan[:, PLAN.P_PARENT].tolist())
        for i in np.flatnonzero(free):
            if i not in held:
                self.roots[i] = 1 if i in touched else 2
        # plan line of each model joint (-1 if released)
        self.line = np.full(len(active), -1, dtype=np.int64)
        self.line[self.plan[:, PLAN.P_JOINT]] = np.arange(len(self.plan))
        check_memory(len(free), self.m, len(self.plan), self._dense)
        #: The kernel's System of these rows (``bind``).
        self.system = None

    def bind(self, bodies, gravity, loads, eta: float, watched: tuple, order: np.ndarray):
        """
        Make the kernel's System of these rows with a simulator's arrays, once.

        ``watched``: the watched joints (``Releases.watched``); ``order``:
        the plan lines of the joints a sample shows. The System keeps the
        arrays and points into them: the simulator writes into them, never
        replaces them.
        """
        self.system = kernel.System(bodies, gravity, loads, self.rows_i, self.rows_f, self.plan,
                                    self.roots, float(eta), self._dense, *watched, order)
        return self.system

    @property
    def dense(self) -> int:
        """Return how the rows are solved: 0 tree, 1 dense, 2 least squares (redundant)."""
        return self._dense if self.system is None else self.system.dense

    @dense.setter
    def dense(self, value: int):
        self._dense = int(value)
        if self.system is not None:
            self.system.dense = self._dense

    @staticmethod
    def _forest(joints, ends, free):
        """
        Orient the joints as a forest, leaves first; None if they close a loop.

        Returns lines (index into joints, tree child, tree parent, +1 if the
        tree child is the joint's child else -1). Trees hang from the ground
        first, then from the lowest-numbered body of each floating group.
        """
        ground = -1
        free = free.tolist()   # Python numbers: this loop reads them one by one
        ends = ends.tolist()
        node = [i if free[i] else ground for i in range(len(free))]
        edges = {}
        for i, (a, b) in enumerate(ends):
            edges.setdefault(node[a], []).append(i)
            edges.setdefault(node[b], []).append(i)
        seen, used, lines = set(), set(), []
        starts = [ground] + [i for i in range(len(free)) if free[i]]
        for start in starts:
            if start in seen or start not in edges:
                continue
            seen.add(start)
            queue = [start]
            while queue:
                here = queue.pop(0)
                for i in edges[here]:
                    if i in used:
                        continue
                    used.add(i)
                    a, b = ends[i]
                    child = b if node[a] == here else a
                    if node[a] == here and node[b] == here:
                        return None
                    if node[child] in seen:
                        return None
                    seen.add(node[child])
                    queue.append(node[child])
                    parent = a if child == b else b
                    lines.append((i, child, parent, 1 if child == b else -1))
        return lines[::-1]

    def weigh(self, scale):
        """
        Scale each row's parent vector (``groups.row_weights``; None: leave them).

        The rows' values, Jacobians and multipliers scale with it, the
        joints' wrenches and the motion do not: only the least-norm split
        of redundant rows changes, to the compliance-weighted one.
        """
        if scale is not None:
            scale = np.asarray(scale, dtype=float)[:, None]
            rotation = ~self.translation
            self.rows_f[self.translation, ROWS_F.span('R_AXIS')] *= scale[self.translation]
            self.rows_f[rotation, ROWS_F.span('R_VECTOR_A')] *= scale[rotation]

    def null_space(self, y: np.ndarray, n: int) -> np.ndarray:
        """
        Return (m, k) the combinations of the active rows at y that constrain nothing new.

        A forest's rows are independent (k = 0); otherwise the null space of the
        mass-weighted Schur complement J M^-1 J^T scaled to a unit diagonal
        (eigenvalues below 1e-9).
        """
        if self.m == 0 or not self.dense:
            return np.zeros((self.m, 0))
        jac, weighted = self.jacobian(y, n)
        schur = weighted @ jac.T
        scale = 1.0 / np.sqrt(np.maximum(np.diag(schur), 1e-300))
        values, vectors = np.linalg.eigh(schur * scale[:, None] * scale[None, :])
        return vectors[:, np.abs(values) <= 1e-9]

    def jacobian(self, y: np.ndarray, n: int):
        """Return the dense Jacobian J and J M^-1, (m, 6 n), of the active rows at y."""
        kernel.row_jacobian(self.system, y)
        views = kernel.views(self.system)
        return self._scatter(views['jac'], n), self._scatter(views['weighted'], n)

    def _scatter(self, blocks, n):
        """Scatter per-row (parent, child) 6-blocks into a dense (m, 6 n) matrix."""
        out = np.zeros((self.m, 6 * n))
        rows = np.arange(self.m)[:, None]
        six = np.arange(6)
        out[rows, 6 * self.rows_i[:, ROWS_I.R_PARENT, None] + six] = blocks[:, :6]
        out[rows, 6 * self.rows_i[:, ROWS_I.R_CHILD, None] + six] = blocks[:, 6:]
        return out


def _plan(lines, first, counts, joints) -> np.ndarray:
    """Return the kernel's plan (J, PLAN.WIDTH) of the forest's lines (``Topology._forest``)."""
    plan = np.zeros((len(lines), PLAN.WIDTH), dtype=np.int64)
    for k, (i, child, parent, sign) in enumerate(lines):
        plan[k, PLAN.P_ROW], plan[k, PLAN.P_NT], plan[k, PLAN.P_NR] = first[i], *counts[i]
        plan[k, PLAN.P_CHILD], plan[k, PLAN.P_PARENT] = child, parent
        plan[k, PLAN.P_SIGN], plan[k, PLAN.P_JOINT] = sign, joints[i]
    return plan
