// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The 6x6 blocks of the tree solve's passes (treesolve.cpp, which alone includes this
// header): a joint's free motions, the elimination of one, the shift of an articulated
// inertia to the parent and the descent of an acceleration to the child, as small
// straight-line functions on fixed-size blocks (Pinocchio's aba.hxx works on its 6x6
// Inertia and Motion objects the same way). Internal linkage, as before the solve was split by stage:
// the compiler inlines them into the passes as it did, so the numbers stay the same bits.
#pragma once

#include <cmath>

#include "algebra.hpp"
#include "common.hpp"

namespace cfem {
namespace {

double normalize(double* v) {
  // kept(): complement() passes a 0 in one entry, which GCC would fold into the sum
  // (rounding it otherwise than the earlier kernel, whose sum takes it as any number)
  double x = kept(v[0]), y = kept(v[1]), z = kept(v[2]);
  double norm = std::sqrt(x * x + y * y + z * z);
  double scale = 1.0 / norm;
  for (int k = 0; k < 3; ++k) v[k] *= scale;
  return norm;
}

// Fill out[0:3 - count] (3x3) with unit vectors spanning what is orthogonal to the rows
// sign * jac[first + i, base:base + 3], i < count.
inline void complement(const double* jac, idx first, idx count, double sign, int base,
                       double* out) {
  if (count == 0) {
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) out[3 * i + k] = i == k ? 1.0 : 0.0;
  } else if (count == 1) {
    const double* r = jac + 12 * first + base;
    double v0 = r[0] * sign, v1 = r[1] * sign, v2 = r[2] * sign;
    // the world axis least aligned with v, crossed with v
    double a0 = std::fabs(v0), a1 = std::fabs(v1), a2 = std::fabs(v2);
    if (a0 <= a1 && a0 <= a2) {
      out[0] = 0.0, out[1] = v2, out[2] = -v1;
    } else if (a1 <= a2) {
      out[0] = -v2, out[1] = 0.0, out[2] = v0;
    } else {
      out[0] = v1, out[1] = -v0, out[2] = 0.0;
    }
    normalize(out);
    out[3] = v1 * out[2] - v2 * out[1];
    out[4] = v2 * out[0] - v0 * out[2];
    out[5] = v0 * out[1] - v1 * out[0];
    normalize(out + 3);
  } else if (count == 2) {
    const double* a = jac + 12 * first + base;
    const double* b = jac + 12 * (first + 1) + base;
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
    normalize(out);
  }
}

// A hinge's free motion g (6x3, column 0) and least-norm particular acceleration s: the
// general joint's (tree_backward_step) with one rotation free, in straight-line code.
inline void hinge_motion(const double* jac, const double* rhs, idx r0, int off, const V3& rho,
                         double* g, double* s) {
  const double* j3 = jac + 12 * (r0 + 3) + off + 3;
  const double* j4 = jac + 12 * (r0 + 4) + off + 3;
  V3 c1 = {j3[0], j3[1], j3[2]};
  V3 c2 = {j4[0], j4[1], j4[2]};
  V3 n = cross(c1, c2);
  double nn = dot(n, n);
  double scale = 1.0 / std::sqrt(nn);
  V3 w = {n.x * scale, n.y * scale, n.z * scale};
  V3 rw = cross(rho, w);
  V3 a = cross(c2, n), b = cross(n, c1);
  double h1 = rhs[r0 + 3] / nn, h2 = rhs[r0 + 4] / nn;
  V3 rot = {h1 * a.x + h2 * b.x, h1 * a.y + h2 * b.y, h1 * a.z + h2 * b.z};
  V3 ws = cross(rot, rho);
  for (int k = 0; k < 3; ++k) {
    g[3 * k] = rw[k];
    g[3 * (3 + k)] = w[k];
    s[k] = (rhs[r0] * jac[12 * r0 + off + k] + rhs[r0 + 1] * jac[12 * (r0 + 1) + off + k]
            + rhs[r0 + 2] * jac[12 * (r0 + 2) + off + k]) - ws[k];
    s[3 + k] = rot[k];
  }
}

// Eliminate one free motion g (6x3, column 0) of a body with articulated M^ = mh, f^ = f:
// u = M^ g, D = g^T M^ g, z = f^ - M^ s less u D^-1 g^T z, x = M^ - u D^-1 u^T (the general
// elimination of tree_backward_step for K = 1); false if D is not above PIVOT_RTOL times
// its scale.
inline bool eliminate_one(const double* mh, const double* f, const double* g, const double* s,
                          double* u, double* z, double* x, double* d_inv, double* projected) {
  double g0 = g[0], g1 = g[3], g2 = g[6], g3 = g[9], g4 = g[12], g5 = g[15];
  double s0 = s[0], s1 = s[1], s2 = s[2], s3 = s[3], s4 = s[4], s5 = s[5];
  double total_d = 0.0;
  double total_q = 0.0;
  for (int i = 0; i < 6; ++i) {
    const double* m = mh + 6 * i;
    double ui = m[0] * g0 + m[1] * g1 + m[2] * g2 + m[3] * g3 + m[4] * g4 + m[5] * g5;
    double zi = f[i] - (m[0] * s0 + m[1] * s1 + m[2] * s2 + m[3] * s3 + m[4] * s4 + m[5] * s5);
    u[3 * i] = ui;
    z[i] = zi;
    total_d += g[3 * i] * ui;
    total_q += g[3 * i] * zi;
  }
  double scale_d = mh[0] * (g0 * g0) + mh[7] * (g1 * g1) + mh[14] * (g2 * g2)
                   + mh[21] * (g3 * g3) + mh[28] * (g4 * g4) + mh[35] * (g5 * g5);
  if (!(total_d > PIVOT_RTOL * scale_d)) return false;
  double inv = 1.0 / total_d;
  d_inv[0] = inv;
  projected[0] = total_q;
  double a = total_q * inv;
#pragma GCC unroll 6
  for (int i = 0; i < 6; ++i) {
    double vi = u[3 * i] * inv;
    z[i] -= u[3 * i] * a;
#pragma GCC unroll 6
    for (int k = i; k < 6; ++k) x[6 * i + k] = x[6 * k + i] = mh[6 * i + k] - vi * u[3 * k];
  }
  return true;
}

// Add Phi^T x Phi to mhat_p and Phi^T z to fhat_p (x symmetric 6x6, Phi from c to p).
// Inlined: the call's saving and restoring of registers was a tenth of its cost.
__attribute__((always_inline))
inline void shift_add(const double* x, const double* z, const double* y, idx c, idx p,
                      double* mp, double* fp) {
  double r0 = y[3 * c] - y[3 * p], r1 = y[3 * c + 1] - y[3 * p + 1],
         r2 = y[3 * c + 2] - y[3 * p + 2];
  auto X = [x](int i, int j) { return x[6 * i + j]; };
  double a00 = X(0, 0), a01 = X(0, 1), a02 = X(0, 2), a11 = X(1, 1), a12 = X(1, 2),
         a22 = X(2, 2);
  double b00 = X(0, 3), b01 = X(0, 4), b02 = X(0, 5);
  double b10 = X(1, 3), b11 = X(1, 4), b12 = X(1, 5);
  double b20 = X(2, 3), b21 = X(2, 4), b22 = X(2, 5);
  double c00 = X(3, 3), c01 = X(3, 4), c02 = X(3, 5), c11 = X(4, 4), c12 = X(4, 5),
         c22 = X(5, 5);
  // B' = B - A S with S = [[0, -r2, r1], [r2, 0, -r0], [-r1, r0, 0]]
  // the products used twice, rounded once (kept(): as the earlier kernel's LLVM fuses them)
  double a01r2 = kept(a01 * r2), a02r1 = kept(a02 * r1), a12r0 = kept(a12 * r0);
  double p00 = b00 - (a01r2 - a02r1);
  double p01 = b01 - (a02 * r0 - a00 * r2);
  double p02 = b02 - (a00 * r1 - a01 * r0);
  double p10 = b10 - (a11 * r2 - a12 * r1);
  double p11 = b11 - (a12r0 - a01r2);
  double p12 = b12 - (a01 * r1 - a11 * r0);
  double p20 = b20 - (a12 * r2 - a22 * r1);
  double p21 = b21 - (a22 * r0 - a02 * r2);
  double p22 = b22 - (a02r1 - a12r0);
  double q00 = r1 * p20 - r2 * p10, q10 = r2 * p00 - r0 * p20, q20 = r0 * p10 - r1 * p00;
  double q01 = r1 * p21 - r2 * p11, q11 = r2 * p01 - r0 * p21, q21 = r0 * p11 - r1 * p01;
  double q02 = r1 * p22 - r2 * p12, q12 = r2 * p02 - r0 * p22, q22 = r0 * p12 - r1 * p02;
  double t00 = r1 * b20 - r2 * b10, t10 = r2 * b00 - r0 * b20, t20 = r0 * b10 - r1 * b00;
  double t01 = r1 * b21 - r2 * b11, t11 = r2 * b01 - r0 * b21, t21 = r0 * b11 - r1 * b01;
  double t02 = r1 * b22 - r2 * b12, t12 = r2 * b02 - r0 * b22, t22 = r0 * b12 - r1 * b02;
  auto M = [mp](int i, int j) -> double& { return mp[6 * i + j]; };
  M(3, 3) += c00 + q00 + t00;
  M(3, 4) += c01 + q01 + t10;
  M(3, 5) += c02 + q02 + t20;
  M(4, 3) += c01 + q10 + t01;
  M(4, 4) += c11 + q11 + t11;
  M(4, 5) += c12 + q12 + t21;
  M(5, 3) += c02 + q20 + t02;
  M(5, 4) += c12 + q21 + t12;
  M(5, 5) += c22 + q22 + t22;
  M(0, 0) += a00;
  M(0, 1) += a01;
  M(0, 2) += a02;
  M(1, 0) += a01;
  M(1, 1) += a11;
  M(1, 2) += a12;
  M(2, 0) += a02;
  M(2, 1) += a12;
  M(2, 2) += a22;
  M(0, 3) += p00;
  M(0, 4) += p01;
  M(0, 5) += p02;
  M(1, 3) += p10;
  M(1, 4) += p11;
  M(1, 5) += p12;
  M(2, 3) += p20;
  M(2, 4) += p21;
  M(2, 5) += p22;
  M(3, 0) += p00;
  M(4, 0) += p01;
  M(5, 0) += p02;
  M(3, 1) += p10;
  M(4, 1) += p11;
  M(5, 1) += p12;
  M(3, 2) += p20;
  M(4, 2) += p21;
  M(5, 2) += p22;
  double z0 = z[0], z1 = z[1], z2 = z[2], z3 = z[3], z4 = z[4], z5 = z[5];
  fp[0] += z0;
  fp[1] += z1;
  fp[2] += z2;
  fp[3] += z3 + r1 * z2 - r2 * z1;
  fp[4] += z4 + r2 * z0 - r0 * z2;
  fp[5] += z5 + r0 * z1 - r1 * z0;
}

// A child's acceleration ac (in place, its parent's carried to it) with its K free
// motions': their accelerations D^-1 (q - U^T ac), then ac + s + G of them. K is a
// constant so that the loops unroll (a hinge's K = 1 is most chains' every joint).
template <int K>
inline void descend(const double* g, const double* u, const double* s, const double* d_inv,
                    const double* q, double* ac) {
  double t1[K > 0 ? K : 1], vec[K > 0 ? K : 1];
  for (int col = 0; col < K; ++col) {
    double total = q[col];
    for (int k = 0; k < 6; ++k) total -= u[3 * k + col] * ac[k];
    t1[col] = total;
  }
  for (int col = 0; col < K; ++col) {
    double total = 0.0;
    for (int k = 0; k < K; ++k) total += d_inv[3 * col + k] * t1[k];
    vec[col] = total;
  }
  for (int k = 0; k < 6; ++k) {
    double total = ac[k] + s[k];
    for (int col = 0; col < K; ++col) total += g[3 * k + col] * vec[col];
    ac[k] = total;
  }
}

}  // namespace
}  // namespace cfem
