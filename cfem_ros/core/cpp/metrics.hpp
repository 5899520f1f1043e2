// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Run metrics over recorded samples (study.metrics).
#pragma once

#include "common.hpp"

namespace cfem {

// Body-axis points (p, 3) at a CG position (world, m) and attitude (x y z w, normalized
// here) in world, into out (p, 3).
void world_points(const double* position, const double* quat, const Mat& points, double* out);

// The least distance between points on two bodies over k samples into out[0:4]: the
// distance (m), then the sample, the point on a and the point on b where it is least
// (the first in that order on ties); inf and -1 with no sample or no point. pos (k, 3),
// quat (k, 4) x y z w (normalized here), points (p, 3) in body axes; world_a, world_b
// scratch (p, 3) each.
void clearance(const Mat& pos_a, const Mat& quat_a, const Mat& points_a, const Mat& pos_b,
               const Mat& quat_b, const Mat& points_b, double* out, double* world_a,
               double* world_b);

}  // namespace cfem
