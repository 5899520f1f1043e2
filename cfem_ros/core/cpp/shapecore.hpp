// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Minimum distance between two convex collision shapes (SPEC section 8), part 1 of
// 3 (gjk.hpp, distance.hpp): the shapes placed in the world, their support points
// and the closed forms. The method:
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
// A packed shape (cfem_ros.core.native.contacts builds it; laid out in layout.hpp,
// CFEM_SHAPE_LAYOUT) is kShapeHeader doubles: kind, size (3), the shape's axes in the
// body's (row-major 3x3) and its centre from the CG (3, body axes, m), the hull's vertex
// count; then the hull's vertices (3 each, shape axes, m). A compound shape (SPEC section
// 11): kShapeHeader doubles (kCompound, the part count, zeros) and then its parts, each
// the radius of a sphere about the part's centre that holds it (m) followed by the part's
// own packed convex shape. Its distance
// to another shape is the least over the pairs of parts; a pair whose bounding spheres
// are farther apart than the least found so far is skipped (the pairs in the order of
// that bound), the test the contact rows' bounding spheres make for whole shapes.
#pragma once

#include <cmath>

#include "layout.hpp"
#include "multilinear.hpp"   // Flat, Rows: how a packed table is read

namespace cfem {
namespace shapes {

// The kinds and columns of a packed shape: layout.hpp (CFEM_SHAPE_LAYOUT).
constexpr int kSphere = shape_layout::KIND_SPHERE, kCapsule = shape_layout::KIND_CAPSULE,
              kBox = shape_layout::KIND_BOX, kCylinder = shape_layout::KIND_CYLINDER,
              kHull = shape_layout::KIND_HULL, kCompound = shape_layout::KIND_COMPOUND;
constexpr int kKind = shape_layout::SH_KIND, kSize = shape_layout::SH_SIZE,
              kAxes = shape_layout::SH_AXES, kCentre = shape_layout::SH_CENTRE,
              kVertices = shape_layout::SH_VERTICES, kParts = shape_layout::SH_PARTS;
constexpr int kShapeHeader = shape_layout::HEADER;
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

}  // namespace shapes
}  // namespace cfem
