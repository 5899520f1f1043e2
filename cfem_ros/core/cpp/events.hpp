// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Where in a step a release condition, an ejector's stroke end or a contact is first
// reached, on the step's RK4 map s -> rk4(y0, s), by Brent's method as scipy computes it:
// the package's one implementation of event location. Compiled without contraction into
// fused multiply-adds (-ffp-contract=off), so that the root finder, the excesses and the
// force magnitudes round as scipy's brentq and numpy do: the same bits as the reference
// search of the tests (test/crossings.py). The RK4, conditions, joint loads and strokes
// it calls are the other files' (contracted) functions.
// A new event kind: a column of ``excess`` and a block in ``locate`` like the strokes'.
#pragma once

#include "common.hpp"
#include "workspace.hpp"

namespace cfem {

// Brent's tolerances for a crossing (scipy's brentq's xtol, rtol and maxiter).
constexpr double CROSSING_XTOL = 1e-15;
constexpr double CROSSING_RTOL = 4 * 2.220446049250313e-16;
constexpr int CROSSING_MAXITER = 200;

// The watched joints of a located step and their triggers (NaN for none).
struct Triggers {
  IMat joints_i;
  Mat joints_f;
  const idx* watch;
  idx count;
  Mat triggers;       // (count, 3): angle, distance, force
  const idx* lines;   // their plan lines
};

// Take an RK4 step of h from y0 into y1 and find where in it a condition is first
// reached (kernel.locate's docstring). joints_found (count, 2), wrenches_found, info (7).
void locate(double* y0, idx size, double h, double* y1, double* ys, const System& s,
            const Work& v, const Triggers& t, idx* joints_found, idx* wrenches_found,
            double* info);

}  // namespace cfem
