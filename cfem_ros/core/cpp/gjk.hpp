// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Minimum distance between two convex collision shapes, part 2 of 3
// (shapecore.hpp, distance.hpp): GJK on the shapes' cores and EPA's penetration
// depth where they overlap. Pure functions over flat arrays; no allocation.

#pragma once

#include "shapecore.hpp"

namespace cfem {
namespace shapes {

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

}  // namespace shapes
}  // namespace cfem
