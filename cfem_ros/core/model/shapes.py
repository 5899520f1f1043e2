# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What a body looks like (SPEC sections 5, 8, 11): a convex shape, or several.

A box, cylinder, sphere, capsule or mesh, or a compound of several of them
(``{parts: [...]}``, each placed with ``at`` and ``rpy_deg`` in the body's axes).

Shapes are drawn (markers in RViz and Foxglove) and, for the pairs a
scenario's ``contacts`` watch, are the collision shapes: a mesh then by its
convex hull, computed here when the scenario is read. A body without a
``shape`` is drawn as the box with its mass and inertia (a uniform solid
box with the same principal moments, turned to the principal axes), so
that a long, slender store looks long and slender; a fixed body without
one is a small cube.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
import os
import pathlib
from typing import Callable
import urllib.parse

from cfem_ros.core.errors import ArgumentError
import numpy as np

#: Edge of the cube drawn for a fixed body without a shape, m.
FIXED_BODY_CUBE = 0.1
#: Smallest edge of an inertia-equivalent box, m (a flat plate keeps some thickness).
THINNEST = 0.01

KINDS = ('box', 'cylinder', 'sphere', 'capsule', 'mesh')
#: Most parts of a compound shape (``cfem::shapes::kMaxParts``).
MAX_PARTS = 16
#: The keys that place a compound's part in its body's axes.
PART_KEYS = ('at', 'rpy_deg')
#: Most vertices of a mesh file read for its hull.
MAX_MESH_VERTICES = 5_000_000
#: Largest size or vertex coordinate of a shape, m (the bound of every scenario position).
MAX_EXTENT = 1e9


@dataclass(frozen=True)
class Shape:
    """
    A body's shape in its own axes.

    Attributes
    ----------
    kind : str
        'box', 'cylinder' (along the body's x axis), 'sphere', 'capsule'
        (along x), 'mesh', or 'compound' (its ``parts``).
    size : tuple of float
        box: edges along x, y, z; cylinder: radius, length; sphere: radius;
        capsule: radius, overall length (tip to tip, >= 2 radius);
        mesh: scale factors along x, y, z. m.
    offset : tuple of float
        The shape's centre from the CG, body axes, m.
    orientation_xyzw : tuple of float
        The shape's axes relative to the body's (identity but for the
        inertia-equivalent box of a body whose inertia has products).
    mesh : str
        The mesh's file or URL (mesh only): ``package://``, ``file://``,
        ``http(s)://``, or a path (made absolute, as a ``file://`` URL).
    given : bool
        False for a shape made up from the body's mass and inertia.
    hull : tuple of tuple
        mesh only: the vertices of its convex hull, shape axes, scaled, m
        (empty when the mesh is not a local file).
    parts : tuple of Shape
        compound only: its convex parts, each placed in the body's axes
        (its ``offset`` and ``orientation_xyzw``).

    """

    kind: str
    size: tuple
    offset: tuple = (0.0, 0.0, 0.0)
    orientation_xyzw: tuple = (0.0, 0.0, 0.0, 1.0)
    mesh: str = ''
    given: bool = True
    hull: tuple = ()
    parts: tuple = ()

    def pieces(self) -> tuple:
        """Return the convex shapes it is made of: its parts, or itself."""
        return self.parts if self.kind == 'compound' else (self,)


def equivalent_box(mass: float, inertia: np.ndarray) -> Shape:
    """
    Return the uniform solid box with a body's mass and principal moments.

    A box of edges a, b, c has Ixx = m (b^2 + c^2) / 12 and so on, so
    a^2 = 6 (Iyy + Izz - Ixx) / m; edges below ``THINNEST`` are raised to it.
    """
    moments, axes = np.linalg.eigh(np.asarray(inertia, dtype=float))
    if np.linalg.det(axes) < 0:
        axes[:, 2] *= -1.0
    total = moments.sum()
    edges = tuple(max(THINNEST, math.sqrt(max(0.0, 6.0 * (total - 2.0 * moments[k]) / mass)))
                  for k in range(3))
    return Shape('box', edges, orientation_xyzw=_quaternion_of(axes), given=False)


def _quaternion_of(matrix: np.ndarray) -> tuple:
    """
    Quaternion (x, y, z, w) of a rotation matrix (columns: the new axes).

    scipy's ``Rotation.from_matrix(matrix).as_quat()``, operation for
    operation (the same bits), without importing scipy (most of a second):
    the largest of the trace and the diagonal picks the formula. A matrix
    that is not orthogonal to scipy's tolerance goes to scipy, which
    orthogonalizes it first.
    """
    m = np.array(matrix, dtype=float)
    gram = m[np.newaxis] @ np.transpose(m[np.newaxis], (0, 2, 1))
    if not (np.linalg.det(m) > 0 and np.all(np.isclose(gram, np.eye(3), atol=1e-12))):
        from scipy.spatial.transform import Rotation
        return tuple(float(v) for v in Rotation.from_matrix(matrix).as_quat())
    m = m.tolist()
    decision = (m[0][0], m[1][1], m[2][2], m[0][0] + m[1][1] + m[2][2])
    choice = 0
    for k in (1, 2, 3):
        if decision[k] > decision[choice]:
            choice = k
    quat = [0.0] * 4
    if choice != 3:
        i = choice
        j = (i + 1) % 3
        k = (j + 1) % 3
        quat[i] = 1 - decision[3] + 2 * m[i][i]
        quat[j] = m[j][i] + m[i][j]
        quat[k] = m[k][i] + m[i][k]
        quat[3] = m[k][j] - m[j][k]
    else:
        quat = [m[2][1] - m[1][2], m[0][2] - m[2][0], m[1][0] - m[0][1], 1 + decision[3]]
    norm = math.sqrt(quat[0] * quat[0] + quat[1] * quat[1] + quat[2] * quat[2]
                     + quat[3] * quat[3])
    return tuple(q / norm for q in quat)


def default_shape(fixed: bool, mass: float, inertia: np.ndarray) -> Shape:
    """Return the shape drawn for a body whose scenario gives none."""
    if fixed:
        return Shape('box', (FIXED_BODY_CUBE,) * 3, given=False)
    return equivalent_box(mass, inertia)


def parse_shape(value, key: str, fail: Callable, number: Callable, vector: Callable,
                base_dir: str = '') -> Shape:
    """
    Read a body's ``shape`` mapping; ``fail``, ``number``, ``vector`` report errors.

    Forms: ``{box: [x, y, z]}``, ``{cylinder: [radius, length]}``,
    ``{sphere: radius}``, ``{capsule: [radius, length]}``,
    ``{mesh: file or URL, scale: [sx, sy, sz]}``, each
    with an optional ``offset: [x, y, z]`` (body axes, m, from the CG);
    or ``{parts: [...]}``, a compound of up to ``MAX_PARTS`` of those, each
    placed by ``at: [x, y, z]`` (m) and ``rpy_deg: [roll, pitch, yaw]``
    (Z-Y-X, deg) in the body's axes.
    """
    if isinstance(value, dict) and 'parts' in value:
        return _parse_compound(value, key, fail, number, vector, base_dir)
    return _parse_convex(value, key, fail, number, vector, base_dir)


def _parse_compound(value, key, fail, number, vector, base_dir) -> Shape:
    extra = [k for k in value if k != 'parts']
    if extra:
        fail(f'{key}.{extra[0]}', 'is given with parts', "only parts: a compound's parts "
             'are placed each by its own at and rpy_deg')
    parts = value['parts']
    if not isinstance(parts, list) or not 1 <= len(parts) <= MAX_PARTS:
        fail(f'{key}.parts', f'is {parts!r:.80}',
             f'a list of 1 to {MAX_PARTS} convex shapes such as {{box: [x, y, z], at: [x, y, z]}}')
    out = []
    for k, part in enumerate(parts):
        where = f'{key}.parts[{k}]'
        if isinstance(part, dict) and 'offset' in part:
            fail(f'{where}.offset', 'is given for a part', 'at: [x, y, z] (and rpy_deg)')
        if isinstance(part, dict) and 'parts' in part:
            fail(f'{where}.parts', 'nests a compound', 'a convex shape (box, cylinder, '
                 'sphere, capsule or mesh)')
        convex = _parse_convex({k2: v for k2, v in part.items() if k2 not in PART_KEYS}
                               if isinstance(part, dict) else part, where, fail, number,
                               vector, base_dir, extra_keys=PART_KEYS)
        at = tuple(float(v) for v in vector(part.get('at', [0, 0, 0]), f'{where}.at'))
        rpy = vector(part.get('rpy_deg', [0, 0, 0]), f'{where}.rpy_deg')
        from cfem_ros.core import rotations
        quat = tuple(float(v) for v in rotations.from_rpy_deg(rpy))
        out.append(Shape(convex.kind, convex.size, at, quat, mesh=convex.mesh, hull=convex.hull))
    return Shape('compound', (), parts=tuple(out))


def _parse_convex(value, key, fail, number, vector, base_dir, extra_keys=()) -> Shape:
    if not isinstance(value, dict):
        fail(key, f'is {value!r:.80}', 'a mapping such as {box: [x, y, z]}')
    kinds = [k for k in value if k in KINDS]
    place = extra_keys or ('offset',)
    extra = [k for k in value if k not in KINDS + ('offset', 'scale')]
    if extra:
        fail(f'{key}.{extra[0]}', 'unknown key',
             'one of ' + ', '.join(KINDS + place + ('parts',)))
    if len(kinds) != 1:
        fail(key, f'names {len(kinds)} kinds of shape', 'exactly one of ' + ', '.join(KINDS))
    kind = kinds[0]
    if 'scale' in value and kind != 'mesh':
        fail(f'{key}.scale', f'is given for a {kind}', 'scale only with mesh')
    offset = tuple(float(v) for v in vector(value.get('offset', [0, 0, 0]), f'{key}.offset'))
    spec, where = value[kind], f'{key}.{kind}'
    if kind == 'box':
        size = tuple(float(v) for v in vector(spec, where))
    elif kind in ('cylinder', 'capsule'):
        size = tuple(float(v) for v in vector(spec, where, 2))
        if kind == 'capsule' and min(size) > 0.0 and size[1] < 2.0 * size[0]:
            fail(where, f'is {list(size)}: shorter than its two hemispheres',
                 '[radius, overall length] with length >= 2 radius')
    elif kind == 'sphere':
        size = (number(spec, where, positive=True, limit=MAX_EXTENT),)
    else:
        if not isinstance(spec, str) or not spec.strip():
            fail(where, f'is {spec!r:.80}', 'a mesh file or URL (package://, file://, http://)')
        size = tuple(float(v) for v in vector(value.get('scale', [1, 1, 1]), f'{key}.scale'))
        url = _mesh_url(spec.strip(), base_dir)
        hull = ()
        if url.startswith('file://'):
            path = urllib.parse.unquote(urllib.parse.urlsplit(url).path)
            if not os.path.isfile(path):
                fail(where, f'names {path!r}, which is not a file',
                     'the path of an existing mesh file (STL, DAE or OBJ), relative to the '
                     'scenario file, or a package:// or http(s):// URL')
            hull = mesh_hull(path, size, where, fail)
        return Shape('mesh', size, offset, mesh=url, hull=hull)
    if min(size) <= 0.0:
        fail(where, f'is {list(size)}', 'sizes > 0 m')
    return Shape(kind, size, offset)


def _mesh_url(spec: str, base_dir: str) -> str:
    """
    Return a mesh reference as a URL viewers resolve.

    A path becomes a ``file://`` URL, percent-encoded (RFC 8089: a space is
    ``%20``), as RViz's resource retriever (libcurl) and Foxglove require.
    """
    if '://' in spec:
        return spec
    path = spec if os.path.isabs(spec) else os.path.join(base_dir or os.getcwd(), spec)
    return pathlib.Path(os.path.abspath(path)).as_uri()


def triangles(shape: Shape) -> np.ndarray:
    """
    Return the triangles that draw a capsule or a mesh's hull, shape axes, m, shape (k, 3, 3).

    A capsule in 24 facets around and 6 rings per end cap; a hull by its
    facets (Qhull's). Empty for the other shapes (viewers draw those).
    """
    if shape.kind == 'capsule':
        radius, length = shape.size
        half = 0.5 * length - radius
        caps = np.linspace(0.0, 0.5 * np.pi, 7)
        rings = [(-half - radius * math.cos(a), radius * math.sin(a)) for a in caps]
        rings += [(half + radius * math.cos(a), radius * math.sin(a)) for a in caps[::-1]]
        around = np.linspace(0.0, 2 * np.pi, 25)
        points = np.array([[[x, r * math.cos(b), r * math.sin(b)] for b in around]
                           for x, r in rings])
        quads = [(points[i, j], points[i + 1, j], points[i + 1, j + 1], points[i, j + 1])
                 for i in range(len(rings) - 1) for j in range(len(around) - 1)]
        return np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    if shape.kind == 'mesh' and shape.hull:
        from scipy.spatial import ConvexHull
        points = np.array(shape.hull)
        return points[ConvexHull(points).simplices]
    return np.zeros((0, 3, 3))


def mesh_hull(path: str, scale, key: str, fail: Callable) -> tuple:
    """
    Return the vertices of a mesh file's convex hull, scaled, m (scipy's Qhull).

    Reads binary or ASCII STL and OBJ (its ``v`` lines). A file that cannot
    be read, or whose points span no volume, is reported through ``fail``.
    """
    from scipy.spatial import ConvexHull, QhullError

    name = os.path.basename(path)
    try:
        points = read_mesh_vertices(path)
    except (OSError, ValueError) as err:
        fail(key, f'{name}: {err}', 'a readable STL or OBJ file')
    points = points * np.asarray(scale, dtype=float)
    if len(points) < 4 or not np.all(np.isfinite(points)):
        fail(key, f'{name} has {len(points)} finite vertices', 'a mesh that encloses a volume')
    extent = float(np.max(np.abs(points)))
    if extent > MAX_EXTENT:
        fail(key, f'{name} has a vertex {extent:g} m from its origin (scaled)',
             f'vertices within {MAX_EXTENT:g} m, as every scenario position')
    try:
        hull = ConvexHull(points)
    except QhullError:
        fail(key, f'{name} is flat (its vertices span no volume)', 'a mesh that encloses a '
             'volume (its convex hull is the collision shape)')
    return tuple(tuple(float(c) for c in points[i]) for i in hull.vertices)


def read_mesh_vertices(path: str) -> np.ndarray:
    """Return the vertices of an STL (binary or ASCII) or OBJ file, shape (n, 3)."""
    with open(path, 'rb') as handle:
        data = handle.read()
    lower = path.lower()
    if lower.endswith('.obj'):
        rows = [line.split()[1:4] for line in data.decode('utf-8', 'replace').splitlines()
                if line.startswith('v ')]
        return np.array(rows, dtype=float).reshape(-1, 3)
    if not lower.endswith('.stl'):
        raise ArgumentError('not an .stl or .obj file')
    if len(data) >= 84:
        count = int.from_bytes(data[80:84], 'little')
        if 84 + 50 * count == len(data) and count <= MAX_MESH_VERTICES // 3:
            record = np.dtype([('normal', '<f4', 3), ('vertices', '<f4', (3, 3)),
                               ('attribute', '<u2')])
            triangles = np.frombuffer(data, dtype=record, count=count, offset=84)
            return triangles['vertices'].reshape(-1, 3).astype(float)
    text = data.decode('ascii', 'replace')
    rows = [line.split()[1:4] for line in text.splitlines() if line.strip().startswith('vertex')]
    if not rows:
        raise ArgumentError('no vertices (neither binary nor ASCII STL)')
    return np.array(rows, dtype=float)
