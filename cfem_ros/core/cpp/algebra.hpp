// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Small 3-vector and rotation algebra, inlined where it is used. Compiled with
// the contraction of the file that includes it: events.cpp (no contraction)
// does not include it, and calls the other files' functions instead.
#pragma once

#include "common.hpp"

namespace cfem {

struct V3 {
  double x, y, z;
  double operator[](int k) const { return k == 0 ? x : (k == 1 ? y : z); }
};

inline V3 cross(const V3& a, const V3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

inline double dot(const V3& a, const V3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// m @ (x, y, z), m a row-major 3x3.
inline V3 rotate(const double* m, double x, double y, double z) {
  return {m[0] * x + m[1] * y + m[2] * z, m[3] * x + m[4] * y + m[5] * z,
          m[6] * x + m[7] * y + m[8] * z};
}

// Rotation matrix of the quaternion (x, y, z, w) of any non-zero norm.
inline void quat_matrix(double x, double y, double z, double w, double* out) {
  double xx = x * x, yy = y * y, zz = z * z;
  double xy = x * y, xz = x * z, yz = y * z;
  double wx = w * x, wy = w * y, wz = w * z;
  double s = 2.0 / (xx + yy + zz + w * w);
  out[0] = 1 - s * (yy + zz);
  out[1] = s * (xy - wz);
  out[2] = s * (xz + wy);
  out[3] = s * (xy + wz);
  out[4] = 1 - s * (xx + zz);
  out[5] = s * (yz - wx);
  out[6] = s * (xz - wy);
  out[7] = s * (yz + wx);
  out[8] = 1 - s * (xx + yy);
}

// Hamilton product of two quaternions (x y z w).
struct Q4 {
  double x, y, z, w;
};

inline Q4 qmul(double ax, double ay, double az, double aw, double bx, double by, double bz,
               double bw) {
  return {aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
          aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz};
}

// x ** k for an integer k >= 0, multiplied as numba does (square and multiply).
inline double ipow(double x, int k) {
  double r = 1.0;
  while (k) {
    if (k & 1) r *= x;
    k >>= 1;
    if (k) x *= x;
  }
  return r;
}

}  // namespace cfem
