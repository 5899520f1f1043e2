# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The joint graph: which bodies a body's joints lead to, built once, read in linear time.

``carriers`` finds every body's carrier (the nearest kinematic body its
joints lead to) in one pass over the joints, so that a scenario of 10,000
bodies is read in about a second rather than hours (issue 46.3: a search
per body that rescanned every joint per step was cubic in the bodies).
"""

from __future__ import annotations

__all__ = ['adjacency', 'carriers']


def adjacency(count: int, joints) -> list:
    """
    Return each body's joints as lists of (joint index, other body), in joint order.

    Parameters
    ----------
    count : int
        The number of bodies.
    joints : sequence of Joint
        Anything with ``parent`` and ``child`` body indices.

    """
    links = [[] for _ in range(count)]
    for k, joint in enumerate(joints):
        links[joint.parent].append((k, joint.child))
        if joint.child != joint.parent:
            links[joint.child].append((k, joint.parent))
    return links


def carriers(bodies, joints) -> list:
    """
    Return, for each body, the kinematic body its joints lead to (-1 if none).

    Through any number of other bodies (a store on a pylon fixed to a
    moving aircraft is carried by the aircraft), never through another
    kinematic body. The nearest one (fewest joints away); when several are
    as near, the one reached by the lowest joint index at the first step,
    then at the second, and so on: what a breadth-first search from the body
    that visits each body's joints in index order finds first.

    O(bodies + joints): one breadth-first search from all kinematic bodies at
    once gives each body its distance d to the nearest; a body's carrier is
    then its lowest-index joint's to a body at d - 1 (every such body is on
    a shortest path, and the lowest index first is the search order).
    A kinematic body's own carrier (another kinematic body) is searched
    from it alone: one search per kinematic body (a scenario has a few).

    Parameters
    ----------
    bodies : sequence of Body
        Anything with ``motion`` (None for a body that is not kinematic).
    joints : sequence of Joint
        Anything with ``parent`` and ``child`` (body indices).

    """
    count = len(bodies)
    links = adjacency(count, joints)
    kinematic = [body.motion is not None for body in bodies]
    far = count + 1
    distance = [0 if moving else far for moving in kinematic]
    front = [i for i in range(count) if kinematic[i]]
    order = []                                 # bodies by increasing distance
    while front:
        after = []
        for here in front:
            for _, other in links[here]:
                if distance[other] == far:
                    distance[other] = distance[here] + 1
                    after.append(other)
        order.extend(after)
        front = after
    found = [-1] * count
    for body in order:                        # a body's next step is nearer, so already found
        step = next(other for _, other in links[body]
                    if distance[other] == distance[body] - 1)
        found[body] = step if kinematic[step] else found[step]
    for body in range(count):
        if kinematic[body]:
            found[body] = _nearest_other(body, links, kinematic)
    return found


def _nearest_other(start: int, links: list, kinematic: list) -> int:
    """Return the kinematic body nearest to the kinematic body start, other than itself."""
    seen, front = {start}, [start]
    while front:
        after = []
        for here in front:
            for _, other in links[here]:
                if other in seen:
                    continue
                if kinematic[other]:
                    return other
                seen.add(other)
                after.append(other)
        front = after
    return -1
