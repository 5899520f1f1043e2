// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The one float workspace of a set of active joints, cut into named parts.
#pragma once

#include <string>
#include <vector>

#include "common.hpp"

// The parts in their order, PART(name, shape...): the shape in n bodies, m rows, nj
// joints and dense (0 for a tree's solve, whose workspace is linear in the bodies). The
// size, the cut and the offsets Python reads (workspace_parts) are all made from this
// one table.
#define CFEM_WORK_PARTS(PART)                                                            \
  PART(rot, n, 3, 3)                                                                     \
  PART(omega, n, 3)                                                                      \
  PART(inv_inertia, n, 3, 3)                                                             \
  PART(mhat, n, 6, 6)                                                                    \
  PART(fhat, n, 6)                                                                       \
  PART(acc, n, 6)                                                                        \
  PART(jac, m, 12)                                                                       \
  PART(weighted, m, 12)                                                                  \
  PART(rate, m)                                                                          \
  PART(gamma, m)                                                                         \
  PART(value, m)                                                                         \
  PART(rhs, m)                                                                           \
  PART(basis, nj, 6, 3)                                                                  \
  PART(weighted_basis, nj, 6, 3)                                                         \
  PART(chol, nj, 3, 3)                                                                   \
  PART(projected, nj, 3)                                                                 \
  PART(particular, nj, 6)                                                                \
  PART(wrench, nj, 6)                                                                    \
  PART(stages, 6, 13 * n)                                                                \
  PART(six, 4, 6, 6)                                                                     \
  PART(three, 4, 3, 3)                                                                   \
  PART(vec, 8, 3)                                                                        \
  PART(schur, dense > 0 ? 2 : 0, m, m) /* the dense solve's complement, eigenvectors */ \
  PART(right, m)                                                                         \
  PART(lam, m)                                                                           \
  PART(sample_rot, n, 3, 3)                                                              \
  PART(sample_wrench, 18)                                                                \
  PART(force, nj, 3)                                                                     \
  PART(moment, nj, 3)

namespace cfem {

// Pointers into the workspace, one per part of CFEM_WORK_PARTS.
struct Work {
#define CFEM_WORK_FIELD(name, ...) double* name;
  CFEM_WORK_PARTS(CFEM_WORK_FIELD)
#undef CFEM_WORK_FIELD
};

// A part's name, first number and shape.
struct Part {
  std::string name;
  idx offset;
  std::vector<idx> shape;
};

// Length of the workspace for n bodies, m rows, nj joints and a solve (dense).
idx workspace_size(idx n, idx m, idx nj, idx dense);

// The parts of that workspace, in order (their sizes add up to workspace_size).
std::vector<Part> workspace_parts(idx n, idx m, idx nj, idx dense);

// The parts themselves, cut from work.
Work carve(double* work, idx n, idx m, idx nj, idx dense);

}  // namespace cfem
