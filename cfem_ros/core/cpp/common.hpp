// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// What every file of the compiled core shares: the result codes, the views of
// the caller's numpy arrays (row-major, no copy) and the arguments of a solve.
#pragma once

#include <cstdint>

#include "layout.hpp"

namespace cfem {

using idx = std::int64_t;

// ``advance`` results (info[I_RESULT]) and ``locate`` codes (info[L_CODE]).
enum Code : int {
  REACHED = 0, CONDITION = 1, NOT_FINITE = 2, VIOLATION = 3, SINGULAR = 4, ROWS_FULL = 5,
  LOADS_NOT_FINITE = 6, NAN_VALUE = 7, SAME_SIGNS = 8, NO_CONVERGENCE = 9,
};

// A pivot at or below this fraction of its scale is reported as singular (kernel.py).
constexpr double PIVOT_RTOL = 1e-12;

// Columns of ``plan``: layout.hpp (CFEM_PLAN_LAYOUT).
using plan_layout::P_ROW, plan_layout::P_NT, plan_layout::P_NR, plan_layout::P_CHILD,
    plan_layout::P_PARENT, plan_layout::P_SIGN, plan_layout::P_JOINT;

// A row-major float64 matrix the caller owns (or a part of the workspace).
struct Mat {
  double* data = nullptr;
  idx rows = 0;
  idx cols = 0;
  double& operator()(idx i, idx j) const { return data[i * cols + j]; }
  double* row(idx i) const { return data + i * cols; }
};

// A row-major int64 matrix the caller owns.
struct IMat {
  const idx* data = nullptr;
  idx rows = 0;
  idx cols = 0;
  idx operator()(idx i, idx j) const { return data[i * cols + j]; }
};

// The arguments of every solve after the state: ``Topology.bind``.
struct System {
  Mat bodies;            // (n, BODY_COLUMNS + kinematic columns)
  const double* gravity;  // (3,)
  Mat loads;             // (n + scheduled rows, loads.WIDTH)
  IMat rows_i;           // (m, 3)
  Mat rows_f;            // (m, 9)
  IMat plan;             // (J, plan_layout::WIDTH)
  const idx* roots;      // (n,)
  double eta;
  idx dense;
  idx n() const { return bodies.rows; }
  idx m() const { return rows_i.rows; }
  idx joints() const { return plan.rows; }
};

}  // namespace cfem
