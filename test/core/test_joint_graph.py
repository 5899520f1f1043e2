# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The joint graph: every body's carrier found in one linear pass as a per-body search finds it."""

from types import SimpleNamespace

from cfem_ros.core.model import graph
import numpy as np
import pytest


def searched_carrier(bodies, joints, body):
    """Return body's carrier by the definition: a breadth-first search, joints in index order."""
    seen, front = {body}, [body]
    while front:
        after = []
        for here in front:
            for joint in joints:
                if here not in (joint.parent, joint.child):
                    continue
                other = joint.child if joint.parent == here else joint.parent
                if other in seen:
                    continue
                if bodies[other].motion is not None:
                    return other
                seen.add(other)
                after.append(other)
        front = after
    return -1


def random_graph(rng, count, joint_count, moving):
    """Return (bodies, joints): random joints (loops, repeats, ties), some bodies kinematic."""
    bodies = [SimpleNamespace(motion=object() if rng.random() < moving else None)
              for _ in range(count)]
    joints = [SimpleNamespace(parent=int(rng.integers(count)), child=int(rng.integers(count)))
              for _ in range(joint_count)]
    return bodies, joints


@pytest.mark.parametrize('seed', range(40))
def test_every_carrier_is_the_searched_one(seed):
    rng = np.random.default_rng(seed)
    count = int(rng.integers(2, 40))
    bodies, joints = random_graph(rng, count, int(rng.integers(0, 3 * count)),
                                  moving=rng.choice([0.05, 0.2, 0.5]))
    found = graph.carriers(bodies, joints)
    assert found == [searched_carrier(bodies, joints, i) for i in range(count)]


def test_ties_go_to_the_lowest_joint_index_at_each_step():
    # 0 - 1 - 3(kinematic) by joints 2, 3; 0 - 2 - 4(kinematic) by joints 0, 1: both two
    # joints away, the search goes through joint 0 first, so body 4
    bodies = [SimpleNamespace(motion=m) for m in (None, None, None, 'k', 'k')]
    joints = [SimpleNamespace(parent=p, child=c) for p, c in ((0, 2), (2, 4), (0, 1), (1, 3))]
    assert graph.carriers(bodies, joints)[0] == 4
    joints[0], joints[2] = joints[2], joints[0]
    assert graph.carriers(bodies, joints)[0] == 3


class Counting(list):
    """A list of joints that counts how many times it is iterated over."""

    passes = 0

    def __iter__(self):
        Counting.passes += 1
        return super().__iter__()


def test_a_chain_s_carriers_read_the_joints_once():
    # issue 46.3: the search per body read every joint at each of its steps (cubic)
    count = 10_000
    bodies = [SimpleNamespace(motion='aircraft')] + [SimpleNamespace(motion=None)] * count
    joints = Counting(SimpleNamespace(parent=i, child=i + 1) for i in range(count))
    Counting.passes = 0
    found = graph.carriers(bodies, joints)
    assert Counting.passes == 1
    assert found[1:] == [0] * count and found[0] == -1
