// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Aerodynamic force and moment on a body (SPEC section 8), from one packed
// table (cfem_ros.core.aeropack builds it; its offsets are the same there):
// free-stream coefficients over (alpha, beta, Mach) plus proximity increments
// over the body's position and attitude relative to a carrier (and Mach),
// with the air at rest in the world frame plus a constant wind, and the ISA
// density and speed of sound at the body's own altitude.
//
// Conventions (the user guide's table): body axes x forward, y right, z down
// for the coefficient signs; alpha = atan2(w, u), beta = asin(v / V) with
// (u, v, w) the air-relative velocity of the CG in body axes; CX, CY, CZ act
// along the body axes; Cl, Cm, Cn about them at the CG, plus the damping
// derivatives times p L / 2V, q L / 2V, r L / 2V.
#pragma once

#include <cmath>

#include "isa.hpp"
#include "multilinear.hpp"

namespace cfem {
namespace aero {

// header offsets of a packed table (doubles)
constexpr int kArea = 0, kLength = 1, kDensity = 2, kAltitude = 3, kWind = 4, kDamping = 7,
              kUp = 10, kNa = 13, kNb = 14, kNm = 15, kProxAxes = 16, kFade = 17, kStart = 18,
              kProxCode = 21, kProxSize = 28, kTotal = 35, kBody = 36, kCarrier = 37;
constexpr int kHeader = 48;
// proximity axis codes
constexpr int kDx = 0, kDy = 1, kDz = 2, kDphi = 3, kDtheta = 4, kDpsi = 5, kMach = 6;

// What the load was computed from (for tests and recordings).
struct Air {
  double alpha, beta, mach, speed, density, altitude;
  double coefficients[6];  // free stream plus increments
  double increments[6];
};

// One ZYX angle (0 roll, 1 pitch, 2 yaw; rad) of a rotation matrix (row-major).
inline double zyx_angle(const double* r, int which) {
  if (which == 0) return std::atan2(r[7], r[8]);
  if (which == 2) return std::atan2(r[3], r[0]);
  double s = -r[6];
  return std::asin(s > 1.0 ? 1.0 : (s < -1.0 ? -1.0 : s));
}

// The aerodynamic wrench of the body into out (force (3), moment about the CG (3),
// world axes). p: the packed table (Flat or Rows). position, velocity: CG, world (m, m/s);
// rot: body to world, row-major (3x3); rates: body axes (rad/s); carrier_position,
// carrier_rot: the carrier's CG and axes (only read with a proximity table).
// air (optional): what it was computed from. Zero at zero airspeed.
template <class P>
inline void wrench(const P& p, const double* position, const double* velocity,
                   const double* rot, const double* rates, const double* carrier_position,
                   const double* carrier_rot, double* out, Air* air = nullptr) {
  for (int k = 0; k < 6; ++k) out[k] = 0.0;
  double rel[3] = {velocity[0] - p[kWind], velocity[1] - p[kWind + 1],
                   velocity[2] - p[kWind + 2]};
  double u = rot[0] * rel[0] + rot[3] * rel[1] + rot[6] * rel[2];
  double v = rot[1] * rel[0] + rot[4] * rel[1] + rot[7] * rel[2];
  double w = rot[2] * rel[0] + rot[5] * rel[1] + rot[8] * rel[2];
  double speed = std::sqrt(u * u + v * v + w * w);
  double altitude = p[kAltitude] + p[kUp] * position[0] + p[kUp + 1] * position[1] +
                    p[kUp + 2] * position[2];
  double density = p[kDensity], sound = 0.0;
  if (!(density > 0.0) || p[kNm] > 1.0 || p[kProxAxes] > 0.0) {
    double isa_density;
    isa(altitude, isa_density, sound);
    if (!(density > 0.0)) density = isa_density;
  }
  if (speed == 0.0) {
    if (air) *air = Air{0.0, 0.0, 0.0, 0.0, density, altitude, {0}, {0}};
    return;
  }
  double alpha = std::atan2(w, u);
  double vs = v / speed;
  double beta = std::asin(vs > 1.0 ? 1.0 : (vs < -1.0 ? -1.0 : vs));
  double mach = sound > 0.0 ? speed / sound : 0.0;
  int sizes[kMaxAxes] = {static_cast<int>(p[kNa]), static_cast<int>(p[kNb]),
                         static_cast<int>(p[kNm])};
  const long grids = kHeader;
  const long table = grids + sizes[0] + sizes[1] + sizes[2];
  double x[kMaxAxes] = {alpha, beta, mach};
  double c[6], d[6] = {0, 0, 0, 0, 0, 0};
  multilinear(3, sizes, p, grids, table, 6, x, c);
  int axes = static_cast<int>(p[kProxAxes]);
  if (axes > 0) {
    // the CG in the carrier's axes, from where it was at t = 0; the attitude relative to it
    double gap[3] = {position[0] - carrier_position[0], position[1] - carrier_position[1],
                     position[2] - carrier_position[2]};
    double q[7];
    for (int i = 0; i < 3; ++i) {
      q[i] = carrier_rot[i] * gap[0] + carrier_rot[3 + i] * gap[1] +
             carrier_rot[6 + i] * gap[2] - p[kStart + i];
    }
    double relative[9];  // carrier_rot^T rot
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        relative[3 * i + j] = carrier_rot[i] * rot[j] + carrier_rot[3 + i] * rot[3 + j] +
                              carrier_rot[6 + i] * rot[6 + j];
      }
    }
    q[6] = mach;
    int prox_sizes[kMaxAxes], position_axis[kMaxAxes];
    double px[kMaxAxes];
    long count = 0;
    for (int a = 0; a < axes; ++a) {
      int code = static_cast<int>(p[kProxCode + a]);
      prox_sizes[a] = static_cast<int>(p[kProxSize + a]);
      position_axis[a] = code <= kDz;
      px[a] = code >= kDphi && code <= kDpsi ? zyx_angle(relative, code - kDphi) : q[code];
      count += prox_sizes[a];
    }
    const long prox_grids = table + 6L * sizes[0] * sizes[1] * sizes[2];
    double weight = fade_weight(axes, prox_sizes, p, prox_grids, position_axis, px, p[kFade]);
    if (weight > 0.0) {   // faded out far from the carrier: nothing to interpolate
      multilinear(axes, prox_sizes, p, prox_grids, prox_grids + count, 6, px, d);
      for (int k = 0; k < 6; ++k) {
        d[k] *= weight;
        c[k] += d[k];
      }
    }
  }
  double qs = 0.5 * density * speed * speed * p[kArea];
  double length = p[kLength];
  double scale = length / (2.0 * speed);
  double f[3] = {qs * c[0], qs * c[1], qs * c[2]};
  double m[3];
  for (int k = 0; k < 3; ++k) m[k] = qs * length * (c[3 + k] + p[kDamping + k] * rates[k] * scale);
  for (int i = 0; i < 3; ++i) {
    out[i] = rot[3 * i] * f[0] + rot[3 * i + 1] * f[1] + rot[3 * i + 2] * f[2];
    out[3 + i] = rot[3 * i] * m[0] + rot[3 * i + 1] * m[1] + rot[3 * i + 2] * m[2];
  }
  if (air) {
    *air = Air{alpha, beta, mach, speed, density, altitude, {0}, {0}};
    for (int k = 0; k < 6; ++k) {
      air->coefficients[k] = c[k];
      air->increments[k] = d[k];
    }
  }
}

}  // namespace aero
}  // namespace cfem
