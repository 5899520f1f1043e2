// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The geometric release conditions of watched joints: relative angle and distance.
#pragma once

#include "common.hpp"

namespace cfem {

// Angle (rad) and distance (m) of the watched joints at y (13 n numbers) into
// out[w * stride + 0:2]. joints_i (joints, 2): parent, child; joints_f (joints, 10): anchor on
// the parent, anchor on the child (body axes), relative attitude at t = 0 (x y z w).
void conditions(const double* y, idx size, const IMat& joints_i, const Mat& joints_f,
                const idx* watch, idx count, double* out, idx stride);

}  // namespace cfem
