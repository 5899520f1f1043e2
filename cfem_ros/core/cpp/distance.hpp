// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Minimum distance between two convex collision shapes (SPEC section 8):
// sphere, capsule, box, cylinder, and a mesh's convex hull. Each shape is a
// core (a point, a segment, a box, a cylinder, a polytope) swept by a radius
// (the sphere's and capsule's); the cores' distance comes from closed forms
// where they are exact (point-point, point-segment, segment-segment,
// point-box) and from GJK otherwise (Gilbert, Johnson and Keerthi 1988, with
// the closest points of the simplex by Voronoi regions, Ericson 2005, ch. 5,
// and the duality-gap stop of van den Bergen 2003: it stops when the distance
// is known to kTolerance m); overlapping cores, by EPA's penetration depth.
// Pure functions over flat arrays; no allocation.
//
// A packed shape (cfem_ros.core.contacts builds it) is kShapeHeader doubles:
// kind, size (3), the shape's axes in the body's (row-major 3x3) and its
// centre from the CG (3, body axes, m), the hull's vertex count; then the
// hull's vertices (3 each, shape axes, m). Cylinders and capsules lie along
// the shape's x axis; size: box edges (x, y, z); cylinder radius, length;
// sphere radius; capsule radius, overall length.
//
// A compound shape (SPEC section 11) is a header of kShapeHeader doubles (kCompound, the
// part count, zeros) and then its parts, each the radius of a sphere about the part's
// centre that holds it (m) followed by the part's own packed convex shape. Its distance
// to another shape is the least over the pairs of parts; a pair whose bounding spheres
// are farther apart than the least found so far is skipped (the pairs in the order of
// that bound), the test the contact rows' bounding spheres make for whole shapes.
#pragma once

#include <cmath>

#include "multilinear.hpp"   // Flat, Rows: how a packed table is read

namespace cfem {
namespace shapes {

constexpr int kSphere = 0, kCapsule = 1, kBox = 2, kCylinder = 3, kHull = 4, kCompound = 5;
constexpr int kKind = 0, kSize = 1, kAxes = 4, kCentre = 13, kVertices = 16;
constexpr int kShapeHeader = 17;
//: The distance is known to this much, m (GJK's stop).
constexpr double kTolerance = 1e-12;
constexpr int kMaxIterations = 256;

struct Vec { double x, y, z; };
inline Vec operator+(Vec a, Vec b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec operator-(Vec a, Vec b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec operator*(double s, Vec a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(Vec a, Vec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec cross(Vec a, Vec b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// A shape placed in the world: its packed data (Flat or Rows), axes (row-major, shape
// to world), centre.
template <class P>
struct Placed {
  P data;
  double rot[9];
  Vec centre;
  int kind;
  double radius;     // swept radius (sphere, capsule), else 0
  double half;       // capsule: half the segment; cylinder: half its length
};

inline Vec turn(const double* r, Vec v) {
  return {r[0] * v.x + r[1] * v.y + r[2] * v.z, r[3] * v.x + r[4] * v.y + r[5] * v.z,
          r[6] * v.x + r[7] * v.y + r[8] * v.z};
}
inline Vec turn_back(const double* r, Vec v) {
  return {r[0] * v.x + r[3] * v.y + r[6] * v.z, r[1] * v.x + r[4] * v.y + r[7] * v.z,
          r[2] * v.x + r[5] * v.y + r[8] * v.z};
}

// Place a packed shape on a body at (body_rot row-major body to world, body_position world).
template <class P>
inline Placed<P> place(const P& data, const double* body_rot, const double* body_position) {
  Placed<P> s;
  s.data = data;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      s.rot[3 * i + j] = body_rot[3 * i] * data[kAxes + j] +
                         body_rot[3 * i + 1] * data[kAxes + 3 + j] +
                         body_rot[3 * i + 2] * data[kAxes + 6 + j];
    }
  }
  Vec c = turn(body_rot, {data[kCentre], data[kCentre + 1], data[kCentre + 2]});
  s.centre = {body_position[0] + c.x, body_position[1] + c.y, body_position[2] + c.z};
  s.kind = static_cast<int>(data[kKind]);
  s.radius = 0.0;
  s.half = 0.0;
  if (s.kind == kSphere) {
    s.radius = data[kSize];
  } else if (s.kind == kCapsule) {
    s.radius = data[kSize];
    s.half = 0.5 * data[kSize + 1] - data[kSize];
  } else if (s.kind == kCylinder) {
    s.half = 0.5 * data[kSize + 1];
  }
  return s;
}

// The core's farthest point along d (world), world coordinates.
template <class P>
inline Vec support(const Placed<P>& s, Vec d) {
  Vec l = turn_back(s.rot, d), p = {0.0, 0.0, 0.0};
  const double size[3] = {s.data[kSize], s.data[kSize + 1], s.data[kSize + 2]};
  switch (s.kind) {
    case kCapsule:
      p.x = l.x >= 0.0 ? s.half : -s.half;
      break;
    case kBox:
      p = {l.x >= 0.0 ? 0.5 * size[0] : -0.5 * size[0], l.y >= 0.0 ? 0.5 * size[1] : -0.5 * size[1],
           l.z >= 0.0 ? 0.5 * size[2] : -0.5 * size[2]};
      break;
    case kCylinder: {
      p.x = l.x >= 0.0 ? s.half : -s.half;
      double radial = std::sqrt(l.y * l.y + l.z * l.z);
      if (radial > 0.0) {
        p.y = size[0] * l.y / radial;
        p.z = size[0] * l.z / radial;
      }
      break;
    }
    case kHull: {
      long count = static_cast<long>(s.data[kVertices]);
      double best = -INFINITY;
      for (long k = 0, v = kShapeHeader; k < count; ++k, v += 3) {
        double x = s.data[v], y = s.data[v + 1], z = s.data[v + 2];
        double along = x * l.x + y * l.y + z * l.z;
        if (along > best) {
          best = along;
          p = {x, y, z};
        }
      }
      break;
    }
    default:
      break;
  }
  return s.centre + turn(s.rot, p);
}

// ------------------------------------------------------------------ closed forms

// Closest points of segments p1 + s (q1 - p1) and p2 + t (q2 - p2) (Ericson 5.1.9).
inline void segments(Vec p1, Vec q1, Vec p2, Vec q2, Vec& c1, Vec& c2) {
  Vec d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  double a = dot(d1, d1), e = dot(d2, d2), f = dot(d2, r);
  double s, t;
  if (a <= 0.0 && e <= 0.0) {
    c1 = p1;
    c2 = p2;
    return;
  }
  if (a <= 0.0) {
    s = 0.0;
    t = f / e;
    t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
  } else {
    double c = dot(d1, r);
    if (e <= 0.0) {
      t = 0.0;
      s = -c / a;
      s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
    } else {
      double b = dot(d1, d2), denom = a * e - b * b;
      s = denom > 0.0 ? (b * f - c * e) / denom : 0.0;
      s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = -c / a;
        s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
      } else if (t > 1.0) {
        t = 1.0;
        s = (b - c) / a;
        s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
      }
    }
  }
  c1 = p1 + s * d1;
  c2 = p2 + t * d2;
}

// The segment of a capsule (its end points; a sphere's is its centre twice).
template <class P>
inline void segment_of(const Placed<P>& s, Vec& p, Vec& q) {
  Vec axis = {s.rot[0] * s.half, s.rot[3] * s.half, s.rot[6] * s.half};
  p = s.centre - axis;
  q = s.centre + axis;
}

// Closest point of a box to a point (both world).
template <class P>
inline Vec box_point(const Placed<P>& s, Vec point) {
  Vec l = turn_back(s.rot, point - s.centre);
  const double size[3] = {s.data[kSize], s.data[kSize + 1], s.data[kSize + 2]};
  double h[3] = {0.5 * size[0], 0.5 * size[1], 0.5 * size[2]};
  double c[3] = {l.x, l.y, l.z};
  for (int k = 0; k < 3; ++k) c[k] = c[k] < -h[k] ? -h[k] : (c[k] > h[k] ? h[k] : c[k]);
  return s.centre + turn(s.rot, {c[0], c[1], c[2]});
}

// ------------------------------------------------------------------ GJK

struct Vertex { Vec w, a, b; };

template <class P>
inline double epa(const Placed<P>& a, const Placed<P>& b, const Vertex* simplex, Vec& ca,
                  Vec& cb);

// Reduce simplex y (count points) to the sub-simplex nearest the origin; its
// barycentric weights into lambda. Returns the new count (4: the origin is inside).
inline int nearest(Vertex* y, int count, double* lambda);

inline int nearest_segment(Vertex* y, double* lambda) {
  Vec ab = y[1].w - y[0].w;
  double t = -dot(y[0].w, ab), len2 = dot(ab, ab);
  if (t <= 0.0 || len2 <= 0.0) {
    lambda[0] = 1.0;
    return 1;
  }
  if (t >= len2) {
    y[0] = y[1];
    lambda[0] = 1.0;
    return 1;
  }
  lambda[1] = t / len2;
  lambda[0] = 1.0 - lambda[1];
  return 2;
}

// Ericson's ClosestPtPointTriangle with the point at the origin.
inline int nearest_triangle(Vertex* y, double* lambda) {
  Vec a = y[0].w, b = y[1].w, c = y[2].w;
  Vec ab = b - a, ac = c - a, ap = -1.0 * a;
  double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0.0 && d2 <= 0.0) {
    lambda[0] = 1.0;
    return 1;
  }
  Vec bp = -1.0 * b;
  double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) {
    y[0] = y[1];
    lambda[0] = 1.0;
    return 1;
  }
  double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    double v = d1 / (d1 - d3);
    lambda[0] = 1.0 - v;
    lambda[1] = v;
    return 2;
  }
  Vec cp = -1.0 * c;
  double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) {
    y[0] = y[2];
    lambda[0] = 1.0;
    return 1;
  }
  double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    double w = d2 / (d2 - d6);
    y[1] = y[2];
    lambda[0] = 1.0 - w;
    lambda[1] = w;
    return 2;
  }
  double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    y[0] = y[1];
    y[1] = y[2];
    lambda[0] = 1.0 - w;
    lambda[1] = w;
    return 2;
  }
  double denom = 1.0 / (va + vb + vc);
  lambda[1] = vb * denom;
  lambda[2] = vc * denom;
  lambda[0] = 1.0 - lambda[1] - lambda[2];
  return 3;
}

inline int nearest_tetrahedron(Vertex* y, double* lambda) {
  // faces opposite each vertex; the origin is outside a face when it lies on
  // the other side of the face's plane from the fourth vertex
  static const int faces[4][4] = {{0, 1, 2, 3}, {0, 2, 3, 1}, {0, 3, 1, 2}, {1, 3, 2, 0}};
  Vertex best[3];
  double best_lambda[3] = {0, 0, 0}, best_d2 = INFINITY;
  int best_count = 0;
  bool outside_any = false;
  for (const auto& f : faces) {
    Vec a = y[f[0]].w, b = y[f[1]].w, c = y[f[2]].w, d = y[f[3]].w;
    Vec n = cross(b - a, c - a);
    double side_origin = -dot(a, n), side_d = dot(d - a, n);
    if (side_origin * side_d >= 0.0 && side_d != 0.0) continue;   // origin on d's side
    outside_any = true;
    Vertex t[3] = {y[f[0]], y[f[1]], y[f[2]]};
    double l[3];
    int count = nearest_triangle(t, l);
    Vec p = {0, 0, 0};
    for (int k = 0; k < count; ++k) p = p + l[k] * t[k].w;
    double d2 = dot(p, p);
    if (d2 < best_d2) {
      best_d2 = d2;
      best_count = count;
      for (int k = 0; k < count; ++k) {
        best[k] = t[k];
        best_lambda[k] = l[k];
      }
    }
  }
  if (!outside_any) return 4;
  for (int k = 0; k < best_count; ++k) {
    y[k] = best[k];
    lambda[k] = best_lambda[k];
  }
  return best_count;
}

inline int nearest(Vertex* y, int count, double* lambda) {
  switch (count) {
    case 1: lambda[0] = 1.0; return 1;
    case 2: return nearest_segment(y, lambda);
    case 3: return nearest_triangle(y, lambda);
    default: return nearest_tetrahedron(y, lambda);
  }
}

// GJK between the cores of a and b: their distance, and their closest points
// into ca, cb (world). 0 when the cores overlap (ca, cb then a common point, approximately).
// guess (3, optional): a direction from b toward a to start from (the last call's, which
// it is set to on return), so that a pair watched step after step starts near its answer.
template <class P>
inline double gjk(const Placed<P>& a, const Placed<P>& b, Vec& ca, Vec& cb,
                  double* guess = nullptr, double* depth = nullptr) {
  Vertex y[4];
  double lambda[4] = {1.0, 0, 0, 0};
  Vec d = a.centre - b.centre;
  if (guess && (guess[0] != 0.0 || guess[1] != 0.0 || guess[2] != 0.0))
    d = {guess[0], guess[1], guess[2]};
  if (dot(d, d) == 0.0) d = {1.0, 0.0, 0.0};
  y[0].a = support(a, -1.0 * d);
  y[0].b = support(b, d);
  y[0].w = y[0].a - y[0].b;
  int count = 1;
  Vec v = y[0].w;
  double vv = dot(v, v);
  for (int iteration = 0; iteration < kMaxIterations && vv > 0.0; ++iteration) {
    Vertex w;
    w.a = support(a, -1.0 * v);
    w.b = support(b, v);
    w.w = w.a - w.b;
    // the distance lies in [v.w / |v|, |v|]: stop once that is narrower than the tolerance
    double gap = vv - dot(v, w.w);
    if (gap <= kTolerance * std::sqrt(vv)) break;
    bool repeated = false;
    for (int k = 0; k < count; ++k) {
      Vec e = y[k].w - w.w;
      if (dot(e, e) == 0.0) repeated = true;
    }
    if (repeated) break;
    Vertex saved[4];
    double saved_lambda[4];
    int saved_count = count;
    for (int k = 0; k < count; ++k) {
      saved[k] = y[k];
      saved_lambda[k] = lambda[k];
    }
    y[count++] = w;
    count = nearest(y, count, lambda);
    if (count == 4) {
      vv = 0.0;
      break;
    }
    Vec nv = {0, 0, 0};
    for (int k = 0; k < count; ++k) nv = nv + lambda[k] * y[k].w;
    double nvv = dot(nv, nv);
    if (nvv >= vv) {   // no progress in floating point: the previous simplex is the answer
      count = saved_count;
      for (int k = 0; k < count; ++k) {
        y[k] = saved[k];
        lambda[k] = saved_lambda[k];
      }
      break;
    }
    v = nv;
    vv = nvv;
  }
  ca = {0, 0, 0};
  cb = {0, 0, 0};
  if (guess && vv > 0.0) {
    guess[0] = v.x;
    guess[1] = v.y;
    guess[2] = v.z;
  }
  if (count == 4) {   // the origin is inside: the cores overlap
    ca = y[0].a;
    cb = y[0].a;
    if (depth) {
      Vec pa, pb;
      double found = epa(a, b, y, pa, pb);
      if (found >= 0.0) {
        *depth = found;
        ca = pa;
        cb = pb;
      }
    }
    return 0.0;
  }
  for (int k = 0; k < count; ++k) {
    ca = ca + lambda[k] * y[k].a;
    cb = cb + lambda[k] * y[k].b;
  }
  return std::sqrt(vv);
}

// ------------------------------------------------------------------ EPA

constexpr int kEpaVertices = 96, kEpaFaces = 192, kEpaIterations = 80;

struct Face { int v[3]; Vec n; double d; bool alive; };

// Set a face's outward unit normal and its distance from the origin; false if degenerate.
inline bool face_of(const Vertex* w, Face& f) {
  Vec n = cross(w[f.v[1]].w - w[f.v[0]].w, w[f.v[2]].w - w[f.v[0]].w);
  double len = std::sqrt(dot(n, n));
  if (!(len > 0.0)) return false;
  f.n = (1.0 / len) * n;
  f.d = dot(f.n, w[f.v[0]].w);
  if (f.d < 0.0) {   // wound inward: turn it
    int t = f.v[1];
    f.v[1] = f.v[2];
    f.v[2] = t;
    f.n = -1.0 * f.n;
    f.d = -f.d;
  }
  f.alive = true;
  return true;
}

// The expanding polytope algorithm (van den Bergen 2001) from GJK's tetrahedron around
// the origin: the depth of the cores' overlap (the shortest translation that parts them,
// m) and a witness point on each into ca, cb. -1 if the polytope degenerates (then the
// caller keeps 0).
template <class P>
inline double epa(const Placed<P>& a, const Placed<P>& b, const Vertex* simplex, Vec& ca,
                  Vec& cb) {
  Vertex w[kEpaVertices];
  Face f[kEpaFaces];
  for (int k = 0; k < 4; ++k) w[k] = simplex[k];
  int nv = 4, nf = 0;
  static const int start[4][3] = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
  for (const auto& t : start) {
    f[nf].v[0] = t[0];
    f[nf].v[1] = t[1];
    f[nf].v[2] = t[2];
    if (!face_of(w, f[nf])) return -1.0;
    ++nf;
  }
  for (int iteration = 0; iteration < kEpaIterations; ++iteration) {
    int best = -1;
    for (int k = 0; k < nf; ++k)
      if (f[k].alive && (best < 0 || f[k].d < f[best].d)) best = k;
    if (best < 0) return -1.0;
    Face& near = f[best];
    Vertex s;
    s.a = support(a, near.n);
    s.b = support(b, -1.0 * near.n);
    s.w = s.a - s.b;
    double reach = dot(s.w, near.n);
    if (reach - near.d <= kTolerance || nv == kEpaVertices) {
      // the origin's projection on the nearest face, in barycentric coordinates
      Vec p = near.d * near.n;
      Vec e0 = w[near.v[1]].w - w[near.v[0]].w, e1 = w[near.v[2]].w - w[near.v[0]].w;
      Vec r = p - w[near.v[0]].w;
      double d00 = dot(e0, e0), d01 = dot(e0, e1), d11 = dot(e1, e1);
      double d20 = dot(r, e0), d21 = dot(r, e1), den = d00 * d11 - d01 * d01;
      double l1 = den > 0.0 ? (d11 * d20 - d01 * d21) / den : 0.0;
      double l2 = den > 0.0 ? (d00 * d21 - d01 * d20) / den : 0.0;
      double l0 = 1.0 - l1 - l2;
      ca = l0 * w[near.v[0]].a + l1 * w[near.v[1]].a + l2 * w[near.v[2]].a;
      cb = l0 * w[near.v[0]].b + l1 * w[near.v[1]].b + l2 * w[near.v[2]].b;
      return near.d;
    }
    // remove the faces the new point sees; their horizon's edges make the new faces
    int edges[kEpaFaces][2], ne = 0;
    for (int k = 0; k < nf; ++k) {
      if (!f[k].alive || dot(f[k].n, s.w) - f[k].d <= 0.0) continue;
      f[k].alive = false;
      for (int e = 0; e < 3; ++e) {
        int i = f[k].v[e], j = f[k].v[(e + 1) % 3];
        bool shared = false;
        for (int m = 0; m < ne; ++m) {
          if (edges[m][0] == j && edges[m][1] == i) {   // seen from the other side: inside
            edges[m][0] = edges[ne - 1][0];
            edges[m][1] = edges[ne - 1][1];
            --ne;
            shared = true;
            break;
          }
        }
        if (!shared) {
          if (ne == kEpaFaces) return -1.0;
          edges[ne][0] = i;
          edges[ne][1] = j;
          ++ne;
        }
      }
    }
    w[nv] = s;
    int live = 0;   // compact the faces still standing
    for (int k = 0; k < nf; ++k)
      if (f[k].alive) f[live++] = f[k];
    nf = live;
    if (nf + ne > kEpaFaces) return -1.0;
    for (int m = 0; m < ne; ++m) {
      f[nf].v[0] = edges[m][0];
      f[nf].v[1] = edges[m][1];
      f[nf].v[2] = nv;
      if (face_of(w, f[nf])) ++nf;
    }
    ++nv;
  }
  return -1.0;
}

// ------------------------------------------------------------------ the distance

// Signed distance between two placed shapes, m: negative by the penetration depth
// (the shortest translation that parts them: the radii's overlap while the cores are
// apart, EPA's depth plus the radii when the cores overlap; 0 if EPA degenerates), and
// the closest points (or, overlapping, the deepest ones) on each into pa, pb (world).
template <class P>
inline double distance(const Placed<P>& a, const Placed<P>& b, double* pa, double* pb,
                       double* guess = nullptr) {
  Vec ca, cb;
  bool overlap = false;
  double depth = 0.0;
  bool a_segment = a.kind == kSphere || a.kind == kCapsule;
  bool b_segment = b.kind == kSphere || b.kind == kCapsule;
  if (a_segment && b_segment) {
    Vec p1, q1, p2, q2;
    segment_of(a, p1, q1);
    segment_of(b, p2, q2);
    segments(p1, q1, p2, q2, ca, cb);
  } else if (a.kind == kSphere && b.kind == kBox) {
    ca = a.centre;
    cb = box_point(b, ca);
  } else if (b.kind == kSphere && a.kind == kBox) {
    cb = b.centre;
    ca = box_point(a, cb);
  } else {
    overlap = gjk(a, b, ca, cb, guess, &depth) == 0.0;
  }
  Vec gap = ca - cb;
  double core = overlap ? 0.0 : std::sqrt(dot(gap, gap));
  Vec n = core > 0.0 ? (1.0 / core) * gap : Vec{0.0, 0.0, 0.0};
  if (overlap && depth > 0.0 && dot(gap, gap) > 0.0) {   // the witnesses' gap: a into b
    n = (-1.0 / std::sqrt(dot(gap, gap))) * gap;
  }
  Vec qa = ca - a.radius * n, qb = cb + b.radius * n;
  pa[0] = qa.x; pa[1] = qa.y; pa[2] = qa.z;
  pb[0] = qb.x; pb[1] = qb.y; pb[2] = qb.z;
  if (overlap) return depth > 0.0 ? -depth - a.radius - b.radius : 0.0;
  return core > 0.0 ? core - a.radius - b.radius : 0.0;
}

// Distance between packed shapes on bodies at the given poses (rot row-major
// body to world, position the CG, world); closest points into pa, pb (world); guess as gjk's.
template <class P>
inline double distance(const P& shape_a, const double* rot_a, const double* position_a,
                       const P& shape_b, const double* rot_b, const double* position_b,
                       double* pa, double* pb, double* guess = nullptr) {
  return distance(place(shape_a, rot_a, position_a), place(shape_b, rot_b, position_b), pa, pb,
                  guess);
}

// ------------------------------------------------------------------ compound shapes

constexpr int kMaxParts = 16;

// A packed shape read from an offset in another (a compound's part).
template <class P>
struct Shifted {
  P base;
  long first;
  double operator[](long k) const { return base[first + k]; }
};

// Numbers of a packed convex shape.
template <class P>
inline long convex_length(const P& d) {
  return kShapeHeader + 3 * static_cast<long>(d[kVertices]);
}

// The radius about its centre of a sphere that holds a packed convex shape, m.
template <class P>
inline double reach(const P& d) {
  switch (static_cast<int>(d[kKind])) {
    case kSphere: return d[kSize];
    case kCapsule: return 0.5 * d[kSize + 1];
    case kBox: {
      double x = d[kSize], y = d[kSize + 1], z = d[kSize + 2];
      return 0.5 * std::sqrt(x * x + y * y + z * z);
    }
    case kCylinder: return std::sqrt(d[kSize] * d[kSize] + 0.25 * d[kSize + 1] * d[kSize + 1]);
    default: {
      long count = static_cast<long>(d[kVertices]);
      double most = 0.0;
      for (long k = 0, v = kShapeHeader; k < count; ++k, v += 3)
        most = std::fmax(most, d[v] * d[v] + d[v + 1] * d[v + 1] + d[v + 2] * d[v + 2]);
      return std::sqrt(most);
    }
  }
}

// The parts of a packed shape placed on a body: where each starts, its bounding sphere's
// centre (world) and radius. A convex shape is its own one part.
struct Parts {
  long first[kMaxParts];
  Vec centre[kMaxParts];
  double radius[kMaxParts];
  int count;
};

template <class P>
inline void parts_of(const P& d, const double* rot, const double* position, Parts& out) {
  const bool compound = static_cast<int>(d[kKind]) == kCompound;
  out.count = compound ? static_cast<int>(d[1]) : 1;
  long at = compound ? kShapeHeader : 0;
  for (int k = 0; k < out.count; ++k) {
    double radius = compound ? d[at] : 0.0;
    if (compound) ++at;
    Shifted<P> part{d, at};
    out.first[k] = at;
    out.radius[k] = compound ? radius : reach(part);
    Vec c = turn(rot, {part[kCentre], part[kCentre + 1], part[kCentre + 2]});
    out.centre[k] = {position[0] + c.x, position[1] + c.y, position[2] + c.z};
    at += convex_length(part);
  }
}

// Distance between packed shapes, convex or compound, at the given poses (as distance's);
// the closest parts' indices into parts[0:2] if parts is not null (0 for a convex shape).
// guess (gjk's warm start) is used between two convex shapes only.
template <class P>
inline double any_distance(const P& shape_a, const double* rot_a, const double* position_a,
                           const P& shape_b, const double* rot_b, const double* position_b,
                           double* pa, double* pb, double* guess = nullptr,
                           int* parts = nullptr) {
  if (static_cast<int>(shape_a[kKind]) != kCompound
      && static_cast<int>(shape_b[kKind]) != kCompound) {
    if (parts) parts[0] = parts[1] = 0;
    return distance(shape_a, rot_a, position_a, shape_b, rot_b, position_b, pa, pb, guess);
  }
  Parts a, b;
  parts_of(shape_a, rot_a, position_a, a);
  parts_of(shape_b, rot_b, position_b, b);
  // each pair's lower bound: its bounding spheres' distance (signed: a part can go no
  // deeper into another than their spheres overlap)
  double lower[kMaxParts * kMaxParts];
  int order[kMaxParts * kMaxParts];
  int count = 0;
  for (int i = 0; i < a.count; ++i) {
    for (int j = 0; j < b.count; ++j) {
      Vec gap = a.centre[i] - b.centre[j];
      double bound = std::sqrt(dot(gap, gap)) - a.radius[i] - b.radius[j];
      int k = count++;
      while (k > 0 && lower[order[k - 1]] > bound) {   // insertion by bound
        order[k] = order[k - 1];
        --k;
      }
      lower[i * kMaxParts + j] = bound;
      order[k] = i * kMaxParts + j;
    }
  }
  double best = INFINITY;
  double qa[3], qb[3];
  for (int k = 0; k < count; ++k) {
    int pair = order[k];
    if (lower[pair] >= best) break;   // no later pair can come nearer
    int i = pair / kMaxParts, j = pair % kMaxParts;
    double d = distance(Shifted<P>{shape_a, a.first[i]}, rot_a, position_a,
                        Shifted<P>{shape_b, b.first[j]}, rot_b, position_b, qa, qb);
    if (d < best) {
      best = d;
      for (int c = 0; c < 3; ++c) {
        pa[c] = qa[c];
        pb[c] = qb[c];
      }
      if (parts) parts[0] = i, parts[1] = j;
    }
  }
  return best;
}

// Numbers of a packed shape of `size` numbers (convex or compound), or -1 if it is not one.
inline long checked_length(const double* d, long size) {
  if (size < kShapeHeader) return -1;
  auto convex = [&](long at) -> long {
    if (at + kShapeHeader > size) return -1;
    int kind = static_cast<int>(d[at + kKind]);
    double vertices = d[at + kVertices];
    if (kind < kSphere || kind > kHull || !(vertices >= 0.0) || vertices > 1e7) return -1;
    long length = kShapeHeader + 3 * static_cast<long>(vertices);
    return at + length <= size ? length : -1;
  };
  if (static_cast<int>(d[kKind]) != kCompound) return convex(0);
  double count = d[1];
  if (!(count >= 1.0 && count <= kMaxParts)) return -1;
  long at = kShapeHeader;
  for (int k = 0; k < static_cast<int>(count); ++k) {
    long length = convex(at + 1);
    if (length < 0) return -1;
    at += 1 + length;
  }
  return at;
}

}  // namespace shapes
}  // namespace cfem
