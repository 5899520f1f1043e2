// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
#include "braces.hpp"

#include <cmath>

#include "algebra.hpp"
#include "loads.hpp"

namespace cfem {
namespace braces {

namespace {

// Rotation matrix (row-major, body to world) of body i's quaternion in y, as the step
// computes the bodies' (quat_matrix).
void matrix(const double* y, idx n, idx i, double* r) {
  const double* q = y + state::quaternion(n, i);
  quat_matrix(q[0], q[1], q[2], q[3], r);
}

void turn(const double* r, const double* v, double* out) {
  for (int k = 0; k < 3; ++k) out[k] = r[3 * k] * v[0] + r[3 * k + 1] * v[1] + r[3 * k + 2] * v[2];
}

void cross(const double* a, const double* b, double* out) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

}  // namespace

double push(const double* y, const double* rot, const Mat& loads, idx row, idx n,
            double* point, double* direction, double* lateral) {
  const double* br = loads.row(row);
  idx b = static_cast<idx>(br[loads::BR_BODY]), c = static_cast<idx>(br[loads::BR_CARRIER]);
  double own_b[9], own_c[9], arm_b[3], arm_c[3], omega_b[3], omega_c[3], spin_b[3], spin_c[3];
  const double* rb = rot ? rot + 9 * b : own_b;
  const double* rc = rot ? rot + 9 * c : own_c;
  if (!rot) {
    matrix(y, n, b, own_b);
    matrix(y, n, c, own_c);
  }
  turn(rb, br + loads::BR_POINT, arm_b);
  turn(rc, br + loads::BR_AXIS, direction);   // the pad's axis turns with the carrier
  turn(rc, br + loads::BR_PAD, arm_c);
  turn(rb, y + state::rates(n, b), omega_b);
  turn(rc, y + state::rates(n, c), omega_c);
  cross(omega_b, arm_b, spin_b);
  cross(omega_c, arm_c, spin_c);
  double gap[3], closing[3], turning[3];
  for (int k = 0; k < 3; ++k) {
    point[k] = y[state::position(n, b) + k] + arm_b[k];
    gap[k] = point[k] - (y[state::position(n, c) + k] + arm_c[k]);
    closing[k] = (y[state::velocity(n, b) + k] + spin_b[k])
                 - (y[state::velocity(n, c) + k] + spin_c[k]);
  }
  cross(omega_c, direction, turning);
  // s = -gap . a, and ds/dt = -(d gap/dt . a + gap . (omega_c x a)), a the pad's axis
  double along = gap[0] * direction[0] + gap[1] * direction[1] + gap[2] * direction[2];
  double s = -along;
  double rate = -(closing[0] * direction[0] + closing[1] * direction[1]
                  + closing[2] * direction[2])
                - (gap[0] * turning[0] + gap[1] * turning[1] + gap[2] * turning[2]);
  if (lateral) {   // the contact point's distance from the pad's axis
    double side = 0.0;
    for (int k = 0; k < 3; ++k) {
      double e = gap[k] - along * direction[k];
      side += e * e;
    }
    *lateral = std::sqrt(side);
  }
  return br[loads::BR_PRELOAD] + br[loads::BR_STIFFNESS] * s + br[loads::BR_DAMPING] * rate;
}

bool wrench(const double* y, const double* rot, const Mat& loads, idx row, idx n,
            double* out) {
  if (!(loads(row, loads::BR_ON) > 0.0)) {
    for (int k = 0; k < 6; ++k) out[k] = 0.0;
    return false;
  }
  double* point = out + 6;
  double direction[3];
  double f = push(y, rot, loads, row, n, point, direction, nullptr);
  idx b = static_cast<idx>(loads(row, loads::BR_BODY));
  const double* cg = y + state::position(n, b);
  double r[3] = {point[0] - cg[0], point[1] - cg[1], point[2] - cg[2]};
  for (int k = 0; k < 3; ++k) out[k] = f * direction[k];
  cross(r, out, out + 3);
  return true;
}

bool switched(const double* y, const Mat& loads, idx row, idx n) {
  return excess(y, loads, row, n) > 0.0;
}

double excess(const double* y, const Mat& loads, idx row, idx n) {
  double point[3], direction[3], lateral;
  double f = push(y, nullptr, loads, row, n, point, direction, &lateral);
  double radius = loads(row, loads::BR_RADIUS);
  if (loads(row, loads::BR_ON) > 0.0) return std::fmax(-f, lateral - radius);
  // out of contact: back within the band of the pad's face and pushing more than the band
  double band = loads(row, loads::BR_BAND);
  return std::fmin(f - band, radius * (1.0 - RADIUS_BAND) - lateral);
}

}  // namespace braces
}  // namespace cfem
