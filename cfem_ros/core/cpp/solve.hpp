// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The joint loads' solves: the articulated tree recursion as named passes and the small
// factorizations (treesolve.cpp, its 6x6 blocks in treeblocks.hpp), and the dense Schur
// complement (densesolve.cpp).
#pragma once

#include "common.hpp"
#include "workspace.hpp"

namespace cfem {

// Lower Cholesky factor of a[:k, :k] (row stride sa) into out (stride so); false if not
// positive definite (a pivot at or below PIVOT_RTOL times its diagonal).
bool cholesky(const double* a, idx sa, int k, double* out, idx so);

// Solve (L L^T) x = b in place for the first k entries of x (chol's row stride sc).
void cholesky_solve(const double* chol, idx sc, int k, double* x);

// Inverse of the symmetric a[:k, :k] (k <= 3, lower part used; stride sa) into out
// (stride so); false if singular or ill-conditioned.
bool inverse(const double* a, idx sa, int k, double* out, idx so);

// Accelerations of a joint forest (kernel.py's docstring); false if singular.
bool tree_solve(const double* y, const System& s, const Work& v);

// Accelerations and joint loads from the whole Schur complement (closed loops); false if
// the complement is exactly singular (numpy's LinAlgError).
bool dense_solve(const System& s, const Work& v, bool redundant);

}  // namespace cfem
