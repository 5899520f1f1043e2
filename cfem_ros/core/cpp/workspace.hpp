// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The one float workspace of a set of active joints, cut into named parts.
#pragma once

#include "common.hpp"

namespace cfem {

// Pointers into the workspace (kernel.carve lists the first 23 in this order).
struct Work {
  double* rot;             // (n, 3, 3)
  double* omega;           // (n, 3)
  double* inv_inertia;     // (n, 3, 3)
  double* mhat;            // (n, 6, 6)
  double* fhat;            // (n, 6)
  double* acc;             // (n, 6)
  double* jac;             // (m, 12)
  double* weighted;        // (m, 12)
  double* rate;            // (m,)
  double* gamma;           // (m,)
  double* value;           // (m,)
  double* rhs;             // (m,)
  double* basis;           // (J, 6, 3)
  double* weighted_basis;  // (J, 6, 3)
  double* chol;            // (J, 3, 3)
  double* projected;       // (J, 3)
  double* particular;      // (J, 6)
  double* wrench;          // (J, 6)
  double* stages;          // (6, 13 n)
  double* six;             // (4, 6, 6)
  double* three;           // (4, 3, 3)
  double* vec;             // (8, 3)
  // after the parts kernel.carve shows: scratch of the dense solve and of a sample
  double* schur;           // (2, m, m): the complement, its eigenvectors (dense only)
  double* right;           // (m,)
  double* lam;             // (m,)
  double* sample_rot;      // (n, 3, 3)
  double* sample_wrench;   // (18,)
  double* force;           // (J, 3)
  double* moment;          // (J, 3)
};

// Length of the workspace for n bodies, m rows and nj joints; the dense solve's m x m parts
// only if dense (closed loops): a tree's is linear in the bodies.
idx workspace_size(idx n, idx m, idx nj, idx dense);

// Offsets of the parts (the views kernel.carve makes) and the parts themselves.
Work carve(double* work, idx n, idx m, idx nj, idx dense);

}  // namespace cfem
