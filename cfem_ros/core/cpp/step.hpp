// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// RK4 and the step loop (``advance``) with its sample grid and condition checks.
#pragma once

#include "common.hpp"
#include "workspace.hpp"

namespace cfem {

// One classical RK4 step of h from y into out (size numbers), quaternions normalized;
// the largest |constraint value| at y, -1 if singular. solved: the workspace holds the
// solve at y.
double rk4(const double* y, idx size, double h, double* out, const System& s, const Work& v,
           bool solved);

// The watched joints of the step loop and their limits.
struct Watch {
  IMat joints_i;
  Mat joints_f;
  const idx* watch;   // model joint indices
  idx count;
  Mat limits;         // (count, 3): angle, distance, force; inf for none
  const idx* lines;   // their plan lines
};

// The sample grid: grid = [rate, next index, taken], rows of samples (rows x cols), the
// sampled joints' plan lines.
struct Grid {
  double* grid;
  Mat samples;
  const idx* order;
  idx order_count;
};

// Take RK4 steps of dt toward t_target as ``Simulator.advance_to`` defines them
// (kernel.advance's docstring); info = [t, steps, violation, result, limit, worst].
void advance(double* y, idx size, double* info, double t_target, double due, double limit,
             double dt, const System& s, const Work& v, const Watch& watch, const Grid& grid);

}  // namespace cfem
