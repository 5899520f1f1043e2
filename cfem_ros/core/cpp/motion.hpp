// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Kinematic bodies: prescribed trajectories in the extra columns of ``bodies``
// (layout.hpp; motion.py fills them).
#pragma once

#include "common.hpp"
#include "layout.hpp"

namespace cfem {
namespace motion {

// The columns (M_*): layout.hpp (CFEM_BODIES_LAYOUT).

inline bool any(const Mat& bodies) { return bodies.cols > BODY_COLUMNS; }

// Row r's J (jac row, 12) times the known accelerations of its ends.
inline double known(const double* jac_row, const Mat& bodies, idx a, idx b) {
  double total = 0.0;
  for (int k = 0; k < 6; ++k)
    total += jac_row[k] * bodies(a, M_ACC + k) + jac_row[6 + k] * bodies(b, M_ACC + k);
  return total;
}

// Put kinematic body i's acceleration (world) and body-axis angular one into dy.
inline void derivative(const Mat& bodies, idx i, const double* rot, double* dy, idx n) {
  const double* r = rot + 9 * i;
  for (int k = 0; k < 3; ++k) {
    dy[state::velocity(n, i) + k] = bodies(i, M_ACC + k);
    dy[state::rates(n, i) + k] = r[k] * bodies(i, M_ACC + 3) + r[3 + k] * bodies(i, M_ACC + 4)
                             + r[6 + k] * bodies(i, M_ACC + 5);
  }
}

// Write each kinematic body's state and accelerations at its step start + offset.
void place(double* y, const Mat& bodies, double offset);

// Write the time of the step's start into the kinematic bodies' columns.
void set_time(const Mat& bodies, double t);

// One body's pose and twist relative to a reference body into out, sample::BODY numbers in
// a sample's body columns (layout.hpp): the CG from the reference's CG and the attitude
// relative to it (x y z w), the CG velocity seen from the reference and the relative
// angular velocity; all in the reference's axes. Each body's CG position and velocity
// (world, m and m/s), quaternion (x y z w, body to world, any non-zero norm) and rates
// (body axes, rad/s).
void relative_state(const double* position, const double* velocity, const double* quaternion,
                    const double* rates, const double* ref_position, const double* ref_velocity,
                    const double* ref_quaternion, const double* ref_rates, double* out);

// Each body's pose and twist relative to its reference (relative_state), at the end of out
// (size).
void sample_relative(const double* y, const Mat& bodies, double* out, idx size);

}  // namespace motion
}  // namespace cfem
