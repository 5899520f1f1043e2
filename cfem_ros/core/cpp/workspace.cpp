// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
#include "workspace.hpp"

namespace cfem {

idx workspace_size(idx n, idx m, idx nj, idx dense) {
  return n * (9 + 3 + 9 + 36 + 6 + 6) + m * (12 + 12 + 4) + nj * (18 + 18 + 9 + 3 + 6 + 6)
         + 6 * 13 * n + 4 * 36 + 4 * 9 + 8 * 3
         + (dense > 0 ? 2 * m * m : 0) + 2 * m + 9 * n + 18 + 6 * nj;
}

Work carve(double* work, idx n, idx m, idx nj, idx dense) {
  Work w;
  double* o = work;
  auto take = [&o](idx size) { double* p = o; o += size; return p; };
  w.rot = take(9 * n);
  w.omega = take(3 * n);
  w.inv_inertia = take(9 * n);
  w.mhat = take(36 * n);
  w.fhat = take(6 * n);
  w.acc = take(6 * n);
  w.jac = take(12 * m);
  w.weighted = take(12 * m);
  w.rate = take(m);
  w.gamma = take(m);
  w.value = take(m);
  w.rhs = take(m);
  w.basis = take(18 * nj);
  w.weighted_basis = take(18 * nj);
  w.chol = take(9 * nj);
  w.projected = take(3 * nj);
  w.particular = take(6 * nj);
  w.wrench = take(6 * nj);
  w.stages = take(6 * 13 * n);
  w.six = take(4 * 36);
  w.three = take(4 * 9);
  w.vec = take(8 * 3);
  w.schur = take(dense > 0 ? 2 * m * m : 0);  // a tree's solve needs none
  w.right = take(m);
  w.lam = take(m);
  w.sample_rot = take(9 * n);
  w.sample_wrench = take(18);
  w.force = take(3 * nj);
  w.moment = take(3 * nj);
  return w;
}

}  // namespace cfem
