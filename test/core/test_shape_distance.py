# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The compiled shape distance (cpp/distance.hpp) against coal at thousands of random poses."""

import math

from cfem_ros.core import rotations
from cfem_ros.core.model.shapes import Shape
from cfem_ros.core.native import contacts
import numpy as np
import pytest

coal = pytest.importorskip('coal')

#: z (coal's cylinder and capsule axis) to x (cfem_ros's): a quarter turn about y.
Z_TO_X = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
#: The accuracy asked of the distance (issue 25), m.
TOLERANCE = 1e-9

rng = np.random.default_rng(25)
HULL_POINTS = rng.standard_normal((40, 3)) * [0.8, 0.3, 0.2]

SHAPES = {
    'sphere': Shape('sphere', (0.35,), offset=(0.1, -0.05, 0.02)),
    'capsule': Shape('capsule', (0.25, 2.1), offset=(0.0, 0.1, 0.0)),
    'box': Shape('box', (1.2, 0.5, 0.3), offset=(0.05, 0.0, -0.1),
                 orientation_xyzw=tuple(rotations.from_rpy_deg([10.0, -20.0, 30.0]))),
    'cylinder': Shape('cylinder', (0.254, 2.0)),
    'mesh': Shape('mesh', (1.0, 1.0, 1.0), offset=(0.2, 0.0, 0.0), mesh='file:///hull.stl',
                  hull=tuple(map(tuple, HULL_POINTS))),
}


def coal_geometry(shape: Shape):
    """Return shape as coal sees it and the transform from coal's shape axes to the body's."""
    rot = rotations.matrices(np.array(shape.orientation_xyzw)[None])[0]
    if shape.kind == 'sphere':
        geometry = coal.Sphere(shape.size[0])
    elif shape.kind == 'box':
        geometry = coal.Box(*shape.size)
    elif shape.kind == 'cylinder':
        geometry, rot = coal.Cylinder(shape.size[0], shape.size[1]), rot @ Z_TO_X
    elif shape.kind == 'capsule':
        radius, length = shape.size
        geometry, rot = coal.Capsule(radius, length - 2 * radius), rot @ Z_TO_X
    else:
        from scipy.spatial import ConvexHull
        points = np.array(shape.hull)
        hull = ConvexHull(points)
        vertices = coal.StdVec_Vec3s()
        for point in points[hull.vertices]:
            vertices.append(point)
        geometry = coal.Convex.convexHull(vertices, False, None)
    return geometry, rot, np.array(shape.offset)


def coal_distance(a, b, pose_a, pose_b):
    """
    Return coal's distance between two shapes on bodies at poses (rot, position), and its result.

    At this tolerance coal's GJK/EPA now and then fails: it says -DBL_MAX
    (or, unsigned, 0 for shapes 0.14 m apart, checked by sampling the
    surfaces; or 0.163 m for shapes 0.684 m apart, checked the same way,
    where a tolerance of 1e-9 m gives 0.684 m): such a pose, or one where
    the two tolerances disagree by more than a micrometre, gives
    (None, None), and a test allows few.
    """
    ga, ra, oa = coal_geometry(a)
    gb, rb, ob = coal_geometry(b)
    ta = coal.Transform3s(pose_a[0] @ ra, pose_a[1] + pose_a[0] @ oa)
    tb = coal.Transform3s(pose_b[0] @ rb, pose_b[1] + pose_b[0] @ ob)
    found = []
    for tolerance in (1e-13, 1e-9):
        request = coal.DistanceRequest()
        request.gjk_tolerance = tolerance
        request.gjk_max_iterations = 1000
        request.enable_signed_distance = True
        result = coal.DistanceResult()
        found.append((coal.distance(ga, ta, gb, tb, request, result), result))
    (distance, result), (rough, _) = found
    if not (distance > -1e300 and abs(distance - rough) <= 1e-6):
        return None, None
    return distance, result


def on_surface(shape: Shape, pose, point) -> float:
    """Return coal's distance from a point to a shape on a body at pose (rot, position)."""
    dot = Shape('sphere', (1e-300,), offset=tuple(point))
    return coal_distance(dot, shape, (np.eye(3), np.zeros(3)), pose)[0]


def random_quaternions(count, rng):
    q = rng.standard_normal((count, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


PAIRS = [(a, b) for i, a in enumerate(SHAPES) for b in list(SHAPES)[i:]]


def own_rng(*names):
    """Return a test's own random generator: its poses whatever ran before it, where."""
    return np.random.default_rng([25] + [sum(map(ord, name)) for name in names])


@pytest.mark.parametrize('a, b', PAIRS)
def test_distance_matches_coal_at_random_poses(a, b):
    count = 400   # 15 pairs: 6000 poses
    rng = own_rng(a, b)
    qa, qb = random_quaternions(count, rng), random_quaternions(count, rng)
    # b's CG at 0.5 to 4 m from a's in a random direction: near and far, a few overlapping
    direction = rng.standard_normal((count, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    pa = rng.uniform(-5, 5, (count, 3))
    pb = pa + direction * rng.uniform(0.5, 4.0, (count, 1))
    shape_a, shape_b = contacts.pack_shape(SHAPES[a]), contacts.pack_shape(SHAPES[b])
    ours, points = contacts.distances(shape_a, qa, pa, shape_b, qb, pb)
    rot_a, rot_b = rotations.matrices(qa), rotations.matrices(qb)
    apart = unknown = 0
    for k in range(count):
        pose_a, pose_b = (rot_a[k], pa[k]), (rot_b[k], pb[k])
        theirs, _ = coal_distance(SHAPES[a], SHAPES[b], pose_a, pose_b)
        if theirs is None:
            unknown += 1
            continue
        if theirs <= 1e-9:
            assert ours[k] <= 1e-9, (k, ours[k], theirs)
            continue
        apart += 1
        assert abs(ours[k] - theirs) <= TOLERANCE, (k, ours[k], theirs)
        # the closest points lie that far apart, each on its own shape's surface
        assert abs(np.linalg.norm(points[k, :3] - points[k, 3:]) - ours[k]) <= TOLERANCE
        if k % 10 == 0:   # coal is slow at this tolerance: one pose in ten
            for shape, pose, point in ((SHAPES[a], pose_a, points[k, :3]),
                                       (SHAPES[b], pose_b, points[k, 3:])):
                gap = on_surface(shape, pose, point)
                assert gap is None or abs(gap) <= TOLERANCE, (k, gap)
    assert unknown <= 2
    assert apart > count // 3   # most poses tell something


def test_touching_spheres_closed_form():
    sphere = contacts.pack_shape(Shape('sphere', (0.5,)))
    q = np.array([[0.0, 0.0, 0.0, 1.0]] * 3)
    centres = np.array([[1.5, 0, 0], [0.0, 1.0, 0.0], [0.6, 0.0, 0.0]])
    d, points = contacts.distances(sphere, q, np.zeros((3, 3)), sphere, q, centres)
    np.testing.assert_allclose(d, [0.5, 0.0, -0.4], rtol=0, atol=1e-15)
    np.testing.assert_allclose(points[0], [0.5, 0, 0, 1.0, 0, 0], rtol=0, atol=1e-15)
    assert math.isclose(d[1], 0.0, abs_tol=1e-15)


@pytest.mark.parametrize('name', list(SHAPES))
def test_the_bounding_radius_holds_the_shape_and_is_tight(name):
    # the step skips GJK while the bounding spheres are apart: a radius too small would
    # miss a contact, one too large only costs time
    shape = contacts.pack_shape(SHAPES[name])
    radius = contacts.bounding_radius(shape)
    directions = own_rng(name, 'radius').standard_normal((2000, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    dot = contacts.pack_shape(Shape('sphere', (1e-12,)))
    identity = np.tile([0.0, 0.0, 0.0, 1.0], (len(directions), 1))
    outside, _ = contacts.distances(shape, identity, np.zeros_like(directions), dot, identity,
                                    directions * (radius + 1e-9))
    assert outside.min() > 0.0
    inside, _ = contacts.distances(shape, identity, np.zeros_like(directions), dot, identity,
                                   directions * 0.7 * radius)
    assert inside.min() <= 1e-9   # some direction reaches 70 % of the radius (an offset
    # shape reaches less than its radius in most directions)


#: Penetration depth (EPA) tolerances, m: exact up to GJK's for flat faces; a curved
#: cylinder's surface is approached by EPA's facets (coal's own EPA too).
DEPTH_TOLERANCE = {'cylinder': 1e-5}


@pytest.mark.parametrize('a, b', [('box', 'box'), ('box', 'mesh'), ('mesh', 'mesh'),
                                  ('capsule', 'box'), ('sphere', 'mesh'),
                                  ('box', 'cylinder'), ('cylinder', 'mesh')])
def test_penetration_depth_matches_coals_signed_distance(a, b):
    count = 200
    rng = own_rng(a, b, 'overlap')
    qa, qb = random_quaternions(count, rng), random_quaternions(count, rng)
    direction = rng.standard_normal((count, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    pa = rng.uniform(-5, 5, (count, 3))
    pb = pa + direction * rng.uniform(0.0, 0.6, (count, 1))   # mostly overlapping
    ours, _ = contacts.distances(contacts.pack_shape(SHAPES[a]), qa, pa,
                                 contacts.pack_shape(SHAPES[b]), qb, pb)
    rot_a, rot_b = rotations.matrices(qa), rotations.matrices(qb)
    tolerance = max(DEPTH_TOLERANCE.get(a, TOLERANCE), DEPTH_TOLERANCE.get(b, TOLERANCE))
    deep = 0
    for k in range(count):
        theirs, _ = coal_distance(SHAPES[a], SHAPES[b], (rot_a[k], pa[k]), (rot_b[k], pb[k]))
        if theirs is None or theirs > 0:
            continue
        deep += 1
        assert abs(ours[k] - theirs) <= tolerance, (k, ours[k], theirs)
    assert deep > count // 2
