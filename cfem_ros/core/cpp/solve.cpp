// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
#include "solve.hpp"

#include <cmath>

#include "algebra.hpp"

namespace cfem {

bool cholesky(const double* a, idx sa, int k, double* out, idx so) {
  for (int i = 0; i < k; ++i) {
    for (int j = 0; j <= i; ++j) {
      double total = a[i * sa + j];
      for (int s = 0; s < j; ++s) total -= out[i * so + s] * out[j * so + s];
      if (i == j) {
        if (!(total > PIVOT_RTOL * a[i * sa + i])) return false;
        out[i * so + i] = std::sqrt(total);
      } else {
        out[i * so + j] = total / out[j * so + j];
      }
    }
  }
  return true;
}

void cholesky_solve(const double* chol, idx sc, int k, double* x) {
  for (int i = 0; i < k; ++i) {
    double total = x[i];
    for (int s = 0; s < i; ++s) total -= chol[i * sc + s] * x[s];
    x[i] = total / chol[i * sc + i];
  }
  for (int i = k - 1; i >= 0; --i) {
    double total = x[i];
    for (int s = i + 1; s < k; ++s) total -= chol[s * sc + i] * x[s];
    x[i] = total / chol[i * sc + i];
  }
}

bool inverse(const double* a, idx sa, int k, double* out, idx so) {
  auto A = [a, sa](int i, int j) { return a[i * sa + j]; };
  auto O = [out, so](int i, int j) -> double& { return out[i * so + j]; };
  if (k == 0) return true;
  if (k == 1) {
    if (!(A(0, 0) > 0.0)) return false;
    O(0, 0) = 1.0 / A(0, 0);
    return true;
  }
  if (k == 2) {
    double det = A(0, 0) * A(1, 1) - A(1, 0) * A(1, 0);
    if (!(det > (PIVOT_RTOL * A(0, 0)) * A(1, 1))) return false;
    double scale = 1.0 / det;
    O(0, 0) = A(1, 1) * scale;
    O(1, 1) = A(0, 0) * scale;
    O(0, 1) = O(1, 0) = -A(1, 0) * scale;
    return true;
  }
  double c00 = A(1, 1) * A(2, 2) - A(2, 1) * A(2, 1);
  double c01 = A(2, 1) * A(2, 0) - A(1, 0) * A(2, 2);
  double c02 = A(1, 0) * A(2, 1) - A(1, 1) * A(2, 0);
  double det = A(0, 0) * c00 + A(1, 0) * c01 + A(2, 0) * c02;
  if (!(det > ((PIVOT_RTOL * A(0, 0)) * A(1, 1)) * A(2, 2))) return false;
  double scale = 1.0 / det;
  O(0, 0) = c00 * scale;
  O(0, 1) = O(1, 0) = c01 * scale;
  O(0, 2) = O(2, 0) = c02 * scale;
  O(1, 1) = (A(0, 0) * A(2, 2) - A(2, 0) * A(2, 0)) * scale;
  O(1, 2) = O(2, 1) = (A(1, 0) * A(2, 0) - A(0, 0) * A(2, 1)) * scale;
  O(2, 2) = (A(0, 0) * A(1, 1) - A(1, 0) * A(1, 0)) * scale;
  return true;
}

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

// A hinge's free motion g (6x3, column 0) and least-norm particular acceleration s
// (kernel.py's _hinge_motion).
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

// Eliminate one free motion g (6x3, column 0) of a body with articulated M^ = mh, f^ = f
// (kernel.py's _eliminate_one); false if D is not above PIVOT_RTOL times its scale.
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

bool tree_solve(const double* y, const System& sys, const Work& v) {
  const idx n_j = sys.joints();
  const idx n = sys.n();
  const IMat& plan = sys.plan;
  const double* jac = v.jac;
  const double* rhs = v.rhs;
  double* scratch = v.six;
  double* x = v.six + 36;
  double* full = v.six + 72;
  double* free_t = v.three;
  double* free_r = v.three + 9;
  double* gram = v.three + 18;
  double* vec = v.vec;
  // the joint point on joint j's child, relative to the tree child's CG
  auto joint_point = [&](idx j) {
    idx c = plan(j, P_CHILD);
    idx b = plan(j, P_SIGN) > 0 ? c : plan(j, P_PARENT);
    const double* rf = sys.rows_f.row(plan(j, P_ROW));
    V3 rho0 = rotate(v.rot + 9 * b, rf[6], rf[7], rf[8]);
    return V3{rho0.x + y[3 * b] - y[3 * c], rho0.y + y[3 * b + 1] - y[3 * c + 1],
              rho0.z + y[3 * b + 2] - y[3 * c + 2]};
  };
  // the hinges' free motions and particular accelerations (straight-line code) first:
  // they need nothing of the recursion, whose chain of dependent steps is then shorter
  for (idx j = 0; j < n_j; ++j) {
    if (plan(j, P_NT) == 3 && plan(j, P_NR) == 2)
      hinge_motion(jac, rhs, plan(j, P_ROW), plan(j, P_SIGN) > 0 ? 6 : 0, joint_point(j),
                   v.basis + 18 * j, v.particular + 6 * j);
  }
  // leaves first: pass each child's articulated inertia on to its parent
  for (idx j = 0; j < n_j; ++j) {
    idx r0 = plan(j, P_ROW), nt = plan(j, P_NT), nr = plan(j, P_NR);
    idx c = plan(j, P_CHILD), p = plan(j, P_PARENT);
    double sign = static_cast<double>(plan(j, P_SIGN));
    int off = sign > 0 ? 6 : 0;
    double* mh = v.mhat + 36 * c;
    double* fc = v.fhat + 6 * c;
    double* u = v.weighted_basis + 18 * j;
    double* g = v.basis + 18 * j;
    double* s = v.particular + 6 * j;
    double* d_inv = v.chol + 9 * j;
    double* projected = v.projected + 3 * j;
    bool parent_free = sys.roots[p] >= 0;
    if (nt == 3 && nr == 2) {  // a hinge (its g and s above)
      if (!eliminate_one(mh, fc, g, s, u, vec, x, d_inv, projected)) return false;
      if (parent_free) shift_add(x, vec, y, c, p, v.mhat + 36 * p, v.fhat + 6 * p);
      continue;
    }
    V3 rho = joint_point(j);
    // free motions G of the tree child: translations off the rows, rotations off the
    // rows with the joint point carried along
    complement(jac, r0, nt, sign, off, free_t);
    complement(jac, r0 + nt, nr, sign, off + 3, free_r);
    int k_t = static_cast<int>(3 - nt), k_r = static_cast<int>(3 - nr);
    for (int col = 0; col < k_t; ++col) {
      for (int k = 0; k < 3; ++k) {
        g[3 * k + col] = free_t[3 * col + k];
        g[3 * (3 + k) + col] = 0.0;
      }
    }
    for (int col = 0; col < k_r; ++col) {
      V3 w = {free_r[3 * col], free_r[3 * col + 1], free_r[3 * col + 2]};
      V3 rw = cross(rho, w);
      for (int k = 0; k < 3; ++k) {
        g[3 * k + k_t + col] = rw[k];
        g[3 * (3 + k) + k_t + col] = w[k];
      }
    }
    int k_free = k_t + k_r;
    // a particular acceleration s with J_c s = rhs: rotation by least norm,
    // translation along the (orthonormal) row axes
    for (int k = 0; k < 6; ++k) s[k] = 0.0;
    if (nr > 0) {
      for (idx i = 0; i < nr; ++i) {
        vec[i] = rhs[r0 + nt + i];
        for (idx i2 = 0; i2 <= i; ++i2) {
          double total = 0.0;
          for (int k = 0; k < 3; ++k)
            total += jac[12 * (r0 + nt + i) + off + 3 + k] * jac[12 * (r0 + nt + i2) + off + 3 + k];
          scratch[6 * i + i2] = total;
        }
      }
      if (!inverse(scratch, 6, static_cast<int>(nr), gram, 3)) return false;
      for (idx i = 0; i < nr; ++i) {
        double total = 0.0;
        for (idx i2 = 0; i2 < nr; ++i2) total += gram[3 * i + i2] * vec[i2];
        for (int k = 0; k < 3; ++k) s[3 + k] += total * jac[12 * (r0 + nt + i) + off + 3 + k];
      }
    }
    V3 ws = cross(V3{s[3], s[4], s[5]}, rho);
    for (idx i = 0; i < nt; ++i)
      for (int k = 0; k < 3; ++k) s[k] += rhs[r0 + i] * jac[12 * (r0 + i) + off + k];
    for (int k = 0; k < 3; ++k) s[k] -= ws[k];
    if (k_free == 1) {
      // one free motion (hinge, slider): the same algebra, straight-line
      if (!eliminate_one(mh, fc, g, s, u, vec, x, d_inv, projected)) return false;
      if (parent_free) shift_add(x, vec, y, c, p, v.mhat + 36 * p, v.fhat + 6 * p);
      continue;
    }
    // U = M^ G, D = G^T M^ G, q = G^T (f^ - M^ s)
    for (int col = 0; col < k_free; ++col) {
      for (int row = 0; row < 6; ++row) {
        double total = 0.0;
        for (int k = 0; k < 6; ++k) total += mh[6 * row + k] * g[3 * k + col];
        u[3 * row + col] = total;
      }
    }
    for (int row = 0; row < 6; ++row) {
      double total = fc[row];
      for (int k = 0; k < 6; ++k) total -= mh[6 * row + k] * s[k];
      vec[row] = total;
    }
    for (int col = 0; col < k_free; ++col) {
      double total = 0.0;
      for (int k = 0; k < 6; ++k) total += g[3 * k + col] * vec[k];
      projected[col] = total;
      for (int col2 = 0; col2 <= col; ++col2) {
        double t = 0.0;
        for (int k = 0; k < 6; ++k) t += g[3 * k + col] * u[3 * k + col2];
        scratch[6 * col + col2] = t;
      }
    }
    if (!inverse(scratch, 6, k_free, d_inv, 3)) return false;
    if (!parent_free) continue;
    // what the parent feels: M^' = M^ - V U^T and z' = z - V q, V = U D^-1
    for (int row = 0; row < 6; ++row) {
      for (int i = 0; i < k_free; ++i) {
        double total = 0.0;
        for (int k = 0; k < k_free; ++k) total += u[3 * row + k] * d_inv[3 * k + i];
        scratch[6 * i + row] = total;
      }
    }
    for (int row = 0; row < 6; ++row) {
      double total = 0.0;
      for (int i = 0; i < k_free; ++i) total += scratch[6 * i + row] * projected[i];
      vec[row] -= total;
    }
    for (int i = 0; i < 6; ++i) {
      for (int k = i; k < 6; ++k) {
        double total = mh[6 * i + k];
        for (int q = 0; q < k_free; ++q) total -= scratch[6 * q + i] * u[3 * k + q];
        x[6 * i + k] = total;
        x[6 * k + i] = total;
      }
    }
    shift_add(x, vec, y, c, p, v.mhat + 36 * p, v.fhat + 6 * p);
  }
  // roots: a = M^-1 f
  for (idx i = 0; i < n; ++i) {
    if (sys.roots[i] != 1) continue;
    for (int k = 0; k < 6; ++k) v.acc[6 * i + k] = v.fhat[6 * i + k];
    if (!cholesky(v.mhat + 36 * i, 6, 6, full, 6)) return false;
    cholesky_solve(full, 6, 6, v.acc + 6 * i);
  }
  // root first: each child's acceleration from its parent's
  for (idx j = n_j - 1; j >= 0; --j) {
    idx c = plan(j, P_CHILD), p = plan(j, P_PARENT);
    int k_free = static_cast<int>(6 - plan(j, P_NT) - plan(j, P_NR));
    const double* g = v.basis + 18 * j;
    const double* u = v.weighted_basis + 18 * j;
    const double* s = v.particular + 6 * j;
    double* ac = v.acc + 6 * c;
    const double* ap = v.acc + 6 * p;
    if (sys.roots[p] >= 0) {
      // Phi a_p: the parent's acceleration carried to the child's CG
      V3 r = {y[3 * c] - y[3 * p], y[3 * c + 1] - y[3 * p + 1], y[3 * c + 2] - y[3 * p + 2]};
      V3 ar = cross(V3{ap[3], ap[4], ap[5]}, r);
      for (int k = 0; k < 3; ++k) {
        ac[k] = ap[k] + ar[k];
        ac[3 + k] = ap[3 + k];
      }
    } else {
      for (int k = 0; k < 6; ++k) ac[k] = 0.0;
    }
    const double* d_inv = v.chol + 9 * j;
    const double* q = v.projected + 3 * j;
    switch (k_free) {
      case 0: descend<0>(g, u, s, d_inv, q, ac); break;
      case 1: descend<1>(g, u, s, d_inv, q, ac); break;
      case 2: descend<2>(g, u, s, d_inv, q, ac); break;
      case 3: descend<3>(g, u, s, d_inv, q, ac); break;
      case 4: descend<4>(g, u, s, d_inv, q, ac); break;
      case 5: descend<5>(g, u, s, d_inv, q, ac); break;
      default: descend<6>(g, u, s, d_inv, q, ac); break;
    }
  }
  return true;
}

namespace {

// Solve a x = b by LU with partial pivoting (LAPACK's gesv pivots: the first largest
// magnitude), in place: a (k x k) is overwritten, b becomes x. False if a pivot is 0.
bool lu_solve(double* a, int k, double* b) {
  for (int col = 0; col < k; ++col) {
    int pivot = col;
    double best = std::fabs(a[col * k + col]);
    for (int r = col + 1; r < k; ++r) {
      double mag = std::fabs(a[r * k + col]);
      if (mag > best) best = mag, pivot = r;
    }
    if (a[pivot * k + col] == 0.0) return false;
    if (pivot != col) {
      for (int c = 0; c < k; ++c) std::swap(a[col * k + c], a[pivot * k + c]);
      std::swap(b[col], b[pivot]);
    }
    double inv = 1.0 / a[col * k + col];
    for (int r = col + 1; r < k; ++r) {
      double factor = a[r * k + col] * inv;
      if (factor == 0.0) continue;
      for (int c = col + 1; c < k; ++c) a[r * k + c] -= factor * a[col * k + c];
      b[r] -= factor * b[col];
    }
  }
  for (int r = k - 1; r >= 0; --r) {
    double total = b[r];
    for (int c = r + 1; c < k; ++c) total -= a[r * k + c] * b[c];
    b[r] = total / a[r * k + r];
  }
  return true;
}

// The least-squares, least-norm solution of the symmetric a x = b, singular values at or
// below rcond times the largest dropped (numpy's lstsq(a, b, rcond)), by cyclic Jacobi
// rotations of a (overwritten) with their eigenvectors in vecs (k x k). b becomes x;
// tmp (k) scratch.
void symmetric_lstsq(double* a, int k, double* b, double rcond, double* vecs, double* tmp) {
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j) vecs[i * k + j] = i == j ? 1.0 : 0.0;
  for (int sweep = 0; sweep < 100; ++sweep) {
    double off = 0.0, diag = 0.0;
    for (int i = 0; i < k; ++i) {
      diag += a[i * k + i] * a[i * k + i];
      for (int j = i + 1; j < k; ++j) off += a[i * k + j] * a[i * k + j];
    }
    if (!(off > 1e-32 * diag)) break;
    for (int p = 0; p < k; ++p) {
      for (int q = p + 1; q < k; ++q) {
        double apq = a[p * k + q];
        if (apq == 0.0) continue;
        double theta = (a[q * k + q] - a[p * k + p]) / (2.0 * apq);
        double t = (theta >= 0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1.0));
        double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
        for (int r = 0; r < k; ++r) {
          double arp = a[r * k + p], arq = a[r * k + q];
          a[r * k + p] = c * arp - s * arq;
          a[r * k + q] = s * arp + c * arq;
        }
        for (int r = 0; r < k; ++r) {
          double apr = a[p * k + r], aqr = a[q * k + r];
          a[p * k + r] = c * apr - s * aqr;
          a[q * k + r] = s * apr + c * aqr;
        }
        for (int r = 0; r < k; ++r) {
          double vrp = vecs[r * k + p], vrq = vecs[r * k + q];
          vecs[r * k + p] = c * vrp - s * vrq;
          vecs[r * k + q] = s * vrp + c * vrq;
        }
      }
    }
  }
  double largest = 0.0;
  for (int i = 0; i < k; ++i) largest = std::fmax(largest, std::fabs(a[i * k + i]));
  for (int i = 0; i < k; ++i) {
    double lam = a[i * k + i];
    double total = 0.0;
    if (std::fabs(lam) > rcond * largest) {
      for (int r = 0; r < k; ++r) total += vecs[r * k + i] * b[r];
      total /= lam;
    }
    tmp[i] = total;
  }
  for (int r = 0; r < k; ++r) {
    double total = 0.0;
    for (int i = 0; i < k; ++i) total += vecs[r * k + i] * tmp[i];
    b[r] = total;
  }
}

}  // namespace

bool dense_solve(const System& sys, const Work& v, bool redundant) {
  const idx n = sys.n(), m = sys.m();
  const double* jac = v.jac;
  const double* weighted = v.weighted;
  for (idx i = 0; i < n; ++i) {
    const double* f = v.fhat + 6 * i;
    const double* inv = v.inv_inertia + 9 * i;
    for (int k = 0; k < 3; ++k) {
      v.acc[6 * i + k] = sys.bodies(i, 1) * f[k];
      v.acc[6 * i + 3 + k] = inv[3 * k] * f[3] + inv[3 * k + 1] * f[4] + inv[3 * k + 2] * f[5];
    }
  }
  if (m == 0) return true;
  double* right = v.right;
  double* schur = v.schur;
  for (idx r = 0; r < m; ++r) {
    idx a = sys.rows_i(r, 0), b = sys.rows_i(r, 1);
    double free = 0.0;
    for (int k = 0; k < 6; ++k) free += jac[12 * r + k] * v.acc[6 * a + k] + jac[12 * r + 6 + k] * v.acc[6 * b + k];
    right[r] = v.rhs[r] - free;
  }
  for (idx r = 0; r < m; ++r) {
    for (idx s = r; s < m; ++s) {
      double total = 0.0;
      for (int side_r = 0; side_r < 2; ++side_r) {
        idx body_r = sys.rows_i(r, side_r);
        for (int side_s = 0; side_s < 2; ++side_s) {
          if (sys.rows_i(s, side_s) == body_r) {
            for (int k = 0; k < 6; ++k) total += weighted[12 * r + 6 * side_r + k] * jac[12 * s + 6 * side_s + k];
          }
        }
      }
      schur[r * m + s] = total;
      schur[s * m + r] = total;
    }
  }
  double* lam = right;
  if (redundant) {
    // the eigenvectors go to the second m x m of the workspace's schur part
    symmetric_lstsq(schur, static_cast<int>(m), right, 1e-10, v.schur + m * m, v.lam);
  } else if (!lu_solve(schur, static_cast<int>(m), right)) {
    return false;
  }
  for (idx r = 0; r < m; ++r) {
    idx a = sys.rows_i(r, 0), b = sys.rows_i(r, 1);
    for (int k = 0; k < 6; ++k) {
      v.acc[6 * a + k] += lam[r] * weighted[12 * r + k];
      v.acc[6 * b + k] += lam[r] * weighted[12 * r + 6 + k];
    }
  }
  // each joint's load on its tree child, as the tree solve reports it
  for (idx j = 0; j < sys.joints(); ++j) {
    int off = sys.plan(j, P_SIGN) > 0 ? 6 : 0;
    double* w = v.wrench + 6 * j;
    for (int k = 0; k < 6; ++k) w[k] = 0.0;
    idx first = sys.plan(j, P_ROW);
    idx last = first + sys.plan(j, P_NT) + sys.plan(j, P_NR);
    for (idx r = first; r < last; ++r)
      for (int k = 0; k < 6; ++k) w[k] += lam[r] * jac[12 * r + off + k];
  }
  return true;
}

}  // namespace cfem
