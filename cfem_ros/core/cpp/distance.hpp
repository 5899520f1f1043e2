// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Minimum distance between two convex collision shapes, part 3 of 3
// (shapecore.hpp, gjk.hpp): the signed distance of two placed shapes, from closed
// forms or GJK and EPA, and of compound shapes (SPEC section 11), the least over
// their parts. The method and the packed shapes are described in shapecore.hpp.

#pragma once

#include "gjk.hpp"

namespace cfem {
namespace shapes {

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

// The radius about the body's CG of a sphere that holds a packed shape (convex or compound:
// the farthest of its parts' spheres), m.
template <class P>
inline double bounding_radius(const P& d) {
  const bool compound = static_cast<int>(d[kKind]) == kCompound;
  const int count = compound ? static_cast<int>(d[kParts]) : 1;
  long at = compound ? kShapeHeader : 0;
  double most = 0.0;
  for (int k = 0; k < count; ++k) {
    double radius = compound ? d[at] : 0.0;
    if (compound) ++at;
    Shifted<P> part{d, at};
    double x = part[kCentre], y = part[kCentre + 1], z = part[kCentre + 2];
    most = std::fmax(most, std::sqrt(x * x + y * y + z * z) + (compound ? radius : reach(part)));
    at += convex_length(part);
  }
  return most;
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
  out.count = compound ? static_cast<int>(d[kParts]) : 1;
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
// d: a flat array (const double*, Flat) or a shape kept in rows of ``loads`` (Rows).
template <class P>
inline long checked_length(const P& d, long size) {
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
  double count = d[kParts];
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
