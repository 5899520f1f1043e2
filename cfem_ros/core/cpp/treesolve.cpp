// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The tree solve of the joint loads, as named passes over the plan (Pinocchio's aba.hxx:
// AbaForwardStep1, AbaBackwardStep, AbaForwardStep2), and the small factorizations the
// passes use. The plan lists the joints leaves first (Topology's plan); a joint's tree
// child c hangs from its tree parent p.
//
//   tree_forward_step1  each hinge's free motion and particular acceleration: they need
//                       nothing of the recursion, whose chain of dependent steps is then
//                       shorter (the other joints' are made in the backward step)
//   tree_backward_step  leaves first: eliminate c's free motions, pass c's articulated
//                       inertia M^ and force f^ on to p
//   tree_root_step      each tree's root: a = M^-1 f^ (Cholesky)
//   tree_forward_step2  root first: c's acceleration from p's carried to c and c's own
//                       free motions'
//
// The steps are inlined into tree_solve, as the loops they were: the same instructions,
// so the same bits (benchmarks/fingerprint.py).
#include <cmath>

#include "algebra.hpp"
#include "solve.hpp"
#include "treeblocks.hpp"

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

#define CFEM_STEP __attribute__((always_inline)) inline

// The joint point on joint j's child, relative to the tree child's CG (world, m).
CFEM_STEP V3 joint_point(idx j, const double* y, const System& sys, const Work& v) {
  const IMat& plan = sys.plan;
  idx c = plan(j, P_CHILD);
  idx b = plan(j, P_SIGN) > 0 ? c : plan(j, P_PARENT);
  const double* rf = sys.rows_f.row(plan(j, P_ROW));
  V3 rho0 = rotate(v.rot + 9 * b, rf[6], rf[7], rf[8]);
  return V3{rho0.x + y[3 * b] - y[3 * c], rho0.y + y[3 * b + 1] - y[3 * c + 1],
            rho0.z + y[3 * b + 2] - y[3 * c + 2]};
}

// Joint j's free motion and particular acceleration if it is a hinge (into basis and
// particular).
CFEM_STEP void tree_forward_step1(idx j, const double* y, const System& sys, const Work& v) {
  const IMat& plan = sys.plan;
  if (plan(j, P_NT) == 3 && plan(j, P_NR) == 2)
    hinge_motion(v.jac, v.rhs, plan(j, P_ROW), plan(j, P_SIGN) > 0 ? 6 : 0,
                 joint_point(j, y, sys, v), v.basis + 18 * j, v.particular + 6 * j);
}

// Joint j's child's free motions G (null space of its rows on the child), particular
// acceleration s, U = M^ G, D^-1 and q = G^T (f^ - M^ s); then what the parent feels,
// M^ - U D^-1 U^T and (f^ - M^ s) - U D^-1 q, shifted to the parent's CG and added to its
// M^ and f^. False if D is singular or ill-conditioned (PIVOT_RTOL).
CFEM_STEP bool tree_backward_step(idx j, const double* y, const System& sys, const Work& v) {
  const IMat& plan = sys.plan;
  const double* jac = v.jac;
  const double* rhs = v.rhs;
  double* scratch = v.six;
  double* x = v.six + 36;
  double* free_t = v.three;
  double* free_r = v.three + 9;
  double* gram = v.three + 18;
  double* vec = v.vec;
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
    return true;
  }
  V3 rho = joint_point(j, y, sys, v);
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
    return true;
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
  if (!parent_free) return true;
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
  return true;
}

// Root i of a tree (roots[i] == 1): its acceleration M^-1 f^. False if M^ is not positive
// definite (PIVOT_RTOL).
CFEM_STEP bool tree_root_step(idx i, const System& sys, const Work& v) {
  double* full = v.six + 72;
  if (sys.roots[i] != 1) return true;
  for (int k = 0; k < 6; ++k) v.acc[6 * i + k] = v.fhat[6 * i + k];
  if (!cholesky(v.mhat + 36 * i, 6, 6, full, 6)) return false;
  cholesky_solve(full, 6, 6, v.acc + 6 * i);
  return true;
}

// Joint j's child's acceleration: its parent's carried to its CG (Phi a_p; zero under a
// fixed parent), plus s and its free motions' G D^-1 (q - U^T a).
CFEM_STEP void tree_forward_step2(idx j, const double* y, const System& sys, const Work& v) {
  const IMat& plan = sys.plan;
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

#undef CFEM_STEP

}  // namespace

bool tree_solve(const double* y, const System& sys, const Work& v) {
  const idx n_j = sys.joints();
  for (idx j = 0; j < n_j; ++j) tree_forward_step1(j, y, sys, v);
  for (idx j = 0; j < n_j; ++j)
    if (!tree_backward_step(j, y, sys, v)) return false;
  for (idx i = 0; i < sys.n(); ++i)
    if (!tree_root_step(i, sys, v)) return false;
  for (idx j = n_j - 1; j >= 0; --j) tree_forward_step2(j, y, sys, v);
  return true;
}

}  // namespace cfem
