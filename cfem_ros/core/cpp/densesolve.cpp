// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The dense solve of the joint loads (closed loops, redundant rows): the Schur complement
// J M^-1 J^T as one matrix, by LU or, with redundant rows, in least squares.
#include <cmath>
#include <utility>

#include "solve.hpp"

namespace cfem {

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
