// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Small 3-vector and rotation algebra, inlined where it is used. Compiled with
// the contraction of the file that includes it: events.cpp (no contraction)
// does not include it, and calls the other files' functions instead.
#pragma once

#include "common.hpp"

namespace cfem {

// x as it is, hidden from the compiler's contraction of a * b + c into a fused
// multiply-add. LLVM (the compiler of the earlier kernel, whose numbers this one keeps:
// CHANGELOG.md) fuses a product only into its single use; GCC also fuses a product that
// has several uses, in each of them. A product with several uses (written twice, or kept
// in a variable) is passed through kept() so that it is rounded once, as LLVM does. No
// instruction is emitted.
inline double kept(double x) {
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
  __asm__("" : "+x"(x));
#elif defined(__GNUC__) && defined(__aarch64__)
  __asm__("" : "+w"(x));
#endif
  return x;
}

// LANES numbers at a time (GCC's vector extension, any alignment): four with AVX, else
// two (a wider vector than the instruction set's would pass through memory). Each
// lane is rounded as the scalar expression is, the same products fused.
#ifdef __AVX__
constexpr int LANES = 4;
#else
constexpr int LANES = 2;
#endif
typedef double Pack __attribute__((vector_size(8 * LANES), may_alias, aligned(8)));

inline Pack load(const double* p) { return *reinterpret_cast<const Pack*>(p); }

inline void store(double* p, Pack v) { *reinterpret_cast<Pack*>(p) = v; }

struct V3 {
  double x, y, z;
  double operator[](int k) const { return k == 0 ? x : (k == 1 ? y : z); }
};

inline V3 cross(const V3& a, const V3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

inline double dot(const V3& a, const V3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// a . b as the earlier kernel rounded it where LLVM had put a.y b.y first: LLVM orders the
// operands of a sum by where their values come from before it fuses, then fuses the
// product it put first. So a.y b.y is fused into a.x b.x, rounded (kept: GCC would fuse
// whichever of the two products it computes first), then a.z b.z into that.
inline double dot_yx(const V3& a, const V3& b) {
  return a.y * b.y + kept(a.x * b.x) + a.z * b.z;
}

// m @ (x, y, z), m a row-major 3x3.
inline V3 rotate(const double* m, double x, double y, double z) {
  return {m[0] * x + m[1] * y + m[2] * z, m[3] * x + m[4] * y + m[5] * z,
          m[6] * x + m[7] * y + m[8] * z};
}

// The products of a quaternion's components that its rotation matrix uses, each used
// twice or more (kept: see kept()).
struct Products {
  double x, y, z, w;
  double xx, yy, zz, xy, xz, yz, wx, wy, wz;
};

inline Products products(double x, double y, double z, double w) {
  return {x, y, z, w, kept(x * x), kept(y * y), kept(z * z), kept(x * y), kept(x * z),
          kept(y * z), kept(w * x), kept(w * y), kept(w * z)};
}

// R a (R^T a if inverse), R = [[1 - 2 (yy + zz), 2 (xy - wz), 2 (xz + wy)], ...] the matrix
// of a unit quaternion, written out as the earlier kernel wrote it (the same roundings).
inline V3 unit_turn(const Products& p, double a0, double a1, double a2, bool inverse) {
  double r00 = 1 - 2 * (p.yy + p.zz), r01 = 2 * (p.xy - p.wz), r02 = 2 * (p.xz + p.wy);
  double r10 = 2 * (p.xy + p.wz), r11 = 1 - 2 * (p.xx + p.zz), r12 = 2 * (p.yz - p.wx);
  double r20 = 2 * (p.xz - p.wy), r21 = 2 * (p.yz + p.wx), r22 = 1 - 2 * (p.xx + p.yy);
  if (inverse)
    return {r00 * a0 + r10 * a1 + r20 * a2, r01 * a0 + r11 * a1 + r21 * a2,
            r02 * a0 + r12 * a1 + r22 * a2};
  return {r00 * a0 + r01 * a1 + r02 * a2, r10 * a0 + r11 * a1 + r12 * a2,
          r20 * a0 + r21 * a1 + r22 * a2};
}

// Rotation matrix of the quaternion (x, y, z, w) of any non-zero norm.
inline void quat_matrix(double x, double y, double z, double w, double* out) {
  double xx = kept(x * x), yy = kept(y * y), zz = kept(z * z);
  double xy = kept(x * y), xz = kept(x * z), yz = kept(y * z);
  double wx = kept(w * x), wy = kept(w * y), wz = kept(w * z);
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

// x ** k for an integer k >= 0 by square and multiply (the earlier kernel's roundings).
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
