# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Compound shapes (SPEC section 11): distances against coal, a contact with a part, markers.

A compound's distance is the least over its parts' pairs (coal's distance
of each pair is the reference); a contact names the parts, and happens when
a brute-force bisection of coal's distance along the exact motion says.
"""

import copy
import math

from cfem_ros.core import rotations
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.model.shapes import Shape
from cfem_ros.core.native import contacts
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.recording import visuals
import numpy as np
import pytest
from test_shape_distance import coal_distance, HULL_POINTS

pytest.importorskip('coal')

#: The accuracy asked of the distance (issue 36), m.
TOLERANCE = 1e-9


def part(kind, size, at, rpy=(0.0, 0.0, 0.0), **extra):
    return Shape(kind, size, tuple(at), tuple(rotations.from_rpy_deg(rpy)), **extra)


WING = Shape('compound', (), parts=(
    part('box', (3.0, 10.0, 0.3), (0.0, 0.0, 0.65)),
    part('cylinder', (1.0, 6.0), (1.0, -4.0, 0.3), (0.0, 0.0, 15.0)),
    part('sphere', (0.4,), (-1.0, 2.0, 1.2)),
    part('mesh', (1.0, 1.0, 1.0), (0.5, 3.0, 0.9), (10.0, 20.0, 30.0),
         mesh='file:///hull.stl', hull=tuple(map(tuple, HULL_POINTS))),
))
RACK = Shape('compound', (), parts=(
    part('box', (2.0, 0.3, 0.3), (0.0, 0.0, -0.05)),
    part('capsule', (0.12, 1.2), (0.0, 0.0, 0.2), (0.0, 0.0, 90.0)),
))
STORE = Shape('cylinder', (0.25, 2.5))


def coal_least(a: Shape, b: Shape, pose_a, pose_b):
    """Return coal's least distance over the parts' pairs and the pair, or None if coal fails."""
    best = (math.inf, None)
    for i, pa in enumerate(a.pieces()):
        for j, pb in enumerate(b.pieces()):
            d, _ = coal_distance(pa, pb, pose_a, pose_b)
            if d is None:
                return None
            best = min(best, (d, (i, j)), key=lambda x: x[0])
    return best


@pytest.mark.parametrize('a, b', [(WING, STORE), (STORE, WING), (WING, RACK)],
                         ids=['wing-store', 'store-wing', 'wing-rack'])
def test_compound_distance_is_coal_s_least_over_the_parts(a, b):
    count = 120
    rng = np.random.default_rng([36, len(a.pieces()), len(b.pieces())])   # its own poses
    qa = rng.standard_normal((count, 4))
    qb = rng.standard_normal((count, 4))
    qa /= np.linalg.norm(qa, axis=1, keepdims=True)
    qb /= np.linalg.norm(qb, axis=1, keepdims=True)
    pa = rng.uniform(-3, 3, (count, 3))
    direction = rng.standard_normal((count, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    pb = pa + direction * rng.uniform(2.0, 8.0, (count, 1))
    ours, points, parts = contacts.distances(contacts.pack_shape(a), qa, pa,
                                             contacts.pack_shape(b), qb, pb, parts=True)
    rot_a, rot_b = rotations.matrices(qa), rotations.matrices(qb)
    apart = 0
    seen = set()
    for k in range(count):
        found = coal_least(a, b, (rot_a[k], pa[k]), (rot_b[k], pb[k]))
        if found is None:
            continue
        theirs, pair = found
        if theirs <= 1e-9:
            assert ours[k] <= 1e-9, (k, ours[k], theirs)
            continue
        apart += 1
        assert abs(ours[k] - theirs) <= TOLERANCE, (k, ours[k], theirs)
        assert abs(np.linalg.norm(points[k, :3] - points[k, 3:]) - ours[k]) <= TOLERANCE
        # the closest parts, unless another pair is as close (to the tolerance)
        if tuple(parts[k]) != pair:
            i, j = parts[k]
            other, _ = coal_distance(a.pieces()[i], b.pieces()[j], (rot_a[k], pa[k]),
                                     (rot_b[k], pb[k]))
            assert abs(other - theirs) <= TOLERANCE, (k, parts[k], pair)
        seen.add(tuple(parts[k]))
    assert apart > count // 2
    assert len(seen) >= 3   # the poses reach several parts


def test_the_pair_skip_gives_the_distance_of_a_convex_shape_of_one_part():
    # a compound of one part is that part: the same bits as the convex distance
    single = Shape('compound', (), parts=(STORE,))
    rng = np.random.default_rng(36)
    q = rng.standard_normal((50, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    p = rng.uniform(-4, 4, (50, 3))
    wing = contacts.pack_shape(WING)
    one, _ = contacts.distances(contacts.pack_shape(single), q, p, wing, q[::-1], -p)
    convex, _ = contacts.distances(contacts.pack_shape(STORE), q, p, wing, q[::-1], -p)
    assert np.array_equal(one, convex)
    assert contacts.bounding_radius(contacts.pack_shape(WING)) >= max(
        np.linalg.norm(v) for v in np.array(HULL_POINTS) + [0.5, 3.0, 0.9]) - 1.0


def bar_on_a_rack():
    """Return a capsule moving down at 1 m/s, spinning at 2 rad/s, toward a rack of two boxes."""
    return {
        'gravity': [0, 0, 0], 'dt': 0.001, 'duration': 2.0,
        'bodies': {
            'rack': {'fixed': True, 'position': [0, 0, 0],
                     'shape': {'parts': [
                         {'box': [0.5, 0.5, 0.5], 'at': [-3.0, 0.0, 0.0]},
                         {'box': [0.4, 2.0, 0.3], 'at': [1.0, 0.0, -0.8],
                          'rpy_deg': [0.0, 10.0, 20.0]}]}},
            'bar': {'mass': 10.0, 'inertia': [0.1, 1.0, 1.0], 'position': [0.3, 0.2, 0.0],
                    'velocity': [0.0, 0.0, -1.0], 'angular_velocity': [0.0, 0.0, 2.0],
                    'shape': {'capsule': [0.1, 1.6]}},
        },
        'contacts': [{'bodies': ['bar', 'rack']}],
    }


def test_a_contact_with_the_second_part_comes_when_bisection_says():
    scenario = bar_on_a_rack()
    sim = Simulator(parse_scenario(scenario, source='rack.yaml'))
    assert not sim.advance_to(2.0) and sim.status == 'contact'
    event, = sim.events
    assert event['bodies'] == ['bar', 'rack'] and event['parts'] == [0, 1]
    # the exact motion: constant velocity, a spin about a principal axis; coal's distance
    # to each part along it, bisected where it first reaches zero
    bar = Shape('capsule', (0.1, 1.6))
    rack = parse_scenario(scenario, source='rack.yaml').bodies[0].shape

    def gap(t):
        pose = (rotations.matrices(rotations.from_rpy_deg([0.0, 0.0, math.degrees(2.0 * t)])
                                   [None])[0], np.array([0.3, 0.2, -t]))
        return coal_least(bar, rack, pose, (np.eye(3), np.zeros(3)))

    t0 = 0.0
    while gap(t0 + 0.01)[0] > 0.0:
        t0 += 0.01
    lo, hi = t0, t0 + 0.01
    while hi - lo > 1e-13:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if gap(mid)[0] > 0.0 else (lo, mid)
    assert gap(hi)[1] == (0, 1)
    # the contact is where the shapes are within 1e-10 m, coming at 1 m/s
    assert abs(event['time'] - hi) < 1e-9, (event['time'], hi)
    assert 0.3 < hi < 0.7


def test_markers_draw_each_part():
    model = parse_scenario(bar_on_a_rack(), source='rack.yaml')
    drawn = visuals.markers(model, {'sec': 0, 'nanosec': 0}, 'cfem')['markers']
    rack = [m for m in drawn if m['header']['frame_id'] == 'rack']
    assert [m['ns'] for m in rack] == ['cfem/bodies', 'cfem/bodies/part1']
    assert [m['type'] for m in rack] == [visuals.CUBE, visuals.CUBE]
    assert rack[1]['pose']['position'] == {'x': 1.0, 'y': 0.0, 'z': -0.8}
    turn = rotations.from_rpy_deg([0.0, 10.0, 20.0])
    assert [rack[1]['pose']['orientation'][c] for c in 'xyzw'] == pytest.approx(turn)
    assert rack[0]['text'] == 'rack part 0' and rack[1]['text'] == 'rack part 1'


@pytest.mark.parametrize('shape, key, words', [
    ({'parts': []}, 'bodies.rack.shape.parts', 'a list of 1 to 16'),
    ({'parts': [{'box': [1, 1, 1]}] * 17}, 'bodies.rack.shape.parts', 'a list of 1 to 16'),
    ({'parts': [{'box': [1, 1, 1], 'offset': [0, 0, 1]}]}, 'bodies.rack.shape.parts[0].offset',
     'at: [x, y, z]'),
    ({'parts': [{'parts': [{'box': [1, 1, 1]}]}]}, 'bodies.rack.shape.parts[0].parts', 'nests'),
    ({'parts': [{'box': [1, 1, 1]}, {'cone': 1}]}, 'bodies.rack.shape.parts[1].cone',
     'unknown key'),
    ({'parts': [{'box': [1, -1, 1]}]}, 'bodies.rack.shape.parts[0].box', 'sizes > 0'),
    ({'parts': [{'sphere': 1, 'at': [0, 0]}]}, 'bodies.rack.shape.parts[0].at', '3 numbers'),
    ({'parts': [{'box': [1, 1, 1]}], 'box': [1, 1, 1]}, 'bodies.rack.shape.box',
     'given with parts'),
])
def test_bad_compound_shapes_are_refused_with_the_key_path(shape, key, words):
    scenario = copy.deepcopy(bar_on_a_rack())
    scenario['bodies']['rack']['shape'] = shape
    with pytest.raises(ScenarioError) as err:
        parse_scenario(scenario, source='rack.yaml')
    assert key in str(err.value) and words in str(err.value), str(err.value)
