// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
#include "metrics.hpp"

#include <cmath>

#include "algebra.hpp"

namespace cfem {

void world_points(const double* position, const double* quat, const Mat& points, double* out) {
  double norm = std::sqrt(quat[0] * quat[0] + quat[1] * quat[1] + quat[2] * quat[2]
                          + quat[3] * quat[3]);
  Products p = products(quat[0] / norm, quat[1] / norm, quat[2] / norm, quat[3] / norm);
  for (idx i = 0; i < points.rows; ++i) {
    V3 r = unit_turn(p, points(i, 0), points(i, 1), points(i, 2), false);
    out[3 * i] = position[0] + r.x;
    out[3 * i + 1] = position[1] + r.y;
    out[3 * i + 2] = position[2] + r.z;
  }
}

void clearance(const Mat& pos_a, const Mat& quat_a, const Mat& points_a, const Mat& pos_b,
               const Mat& quat_b, const Mat& points_b, double* out, double* world_a,
               double* world_b) {
  out[0] = INFINITY, out[1] = -1.0, out[2] = -1.0, out[3] = -1.0;
  for (idx k = 0; k < pos_a.rows; ++k) {
    world_points(pos_a.row(k), quat_a.row(k), points_a, world_a);
    world_points(pos_b.row(k), quat_b.row(k), points_b, world_b);
    for (idx i = 0; i < points_a.rows; ++i) {
      for (idx j = 0; j < points_b.rows; ++j) {
        double dx = world_a[3 * i] - world_b[3 * j];
        double dy = world_a[3 * i + 1] - world_b[3 * j + 1];
        double dz = world_a[3 * i + 2] - world_b[3 * j + 2];
        double distance = std::sqrt(dx * dx + dy * dy + dz * dz);
        if (distance < out[0]) {
          out[0] = distance, out[1] = static_cast<double>(k), out[2] = static_cast<double>(i),
          out[3] = static_cast<double>(j);
        }
      }
    }
  }
}

}  // namespace cfem
