// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Aerodynamic force and moment on a body (SPEC sections 8 and 10), from one
// packed table (cfem_ros.core.engine.aeropack builds it; its offsets are the same
// there): free-stream coefficients over (alpha, beta, Mach) plus proximity
// increments over the body's position and attitude relative to a carrier (and
// Mach), plus constant increments (`delta`), with the air at rest in the world
// frame plus a constant wind, and the ISA density and speed of sound at the
// body's own altitude (a temperature offset for a hot or cold day, isa.hpp).
//
// Conventions (the user guide's table): body axes x forward, y right, z down
// for the coefficient signs; alpha = atan2(w, u), beta = asin(v / V) with
// (u, v, w) the air-relative velocity of the CG in body axes; CX, CY, CZ act
// along the body axes; Cl, Cm, Cn about the reference point r (body axes, from
// the actual CG), so the moment about the CG is q S L C + r x F, plus the
// damping derivatives times p L / 2V, q L / 2V, r L / 2V (about the CG).
//
// A table is held at the edges of its grids. `axes` gives the values of the
// axes that can be left (every axis with two grid values or more) and their
// ranges, so that leaving a table is an event (loads.cpp, events.cpp).
#pragma once

#include <cmath>

#include "isa.hpp"
#include "layout.hpp"
#include "multilinear.hpp"

namespace cfem {
namespace aero {

// header offsets of a packed table (doubles): layout.hpp's CFEM_AERO_TABLE_LAYOUT
constexpr int kArea = aero_table::AREA, kLength = aero_table::LENGTH,
              kDensity = aero_table::DENSITY, kAltitude = aero_table::ALTITUDE,
              kWind = aero_table::WIND, kDamping = aero_table::DAMPING, kUp = aero_table::UP,
              kNa = aero_table::NA, kNb = aero_table::NB, kNm = aero_table::NM,
              kProxAxes = aero_table::PROX_AXES, kFade = aero_table::FADE,
              kStart = aero_table::START, kProxCode = aero_table::PROX_CODE,
              kProxSize = aero_table::PROX_SIZE, kTotal = aero_table::TOTAL,
              kBody = aero_table::BODY, kCarrier = aero_table::CARRIER,
              kTemperatureOffset = aero_table::TEMPERATURE_OFFSET,
              kReference = aero_table::REFERENCE, kDelta = aero_table::DELTA;
constexpr int kHeader = aero_table::WIDTH;
// proximity axis codes
constexpr int kDx = aero_table::AXIS_DX, kDy = aero_table::AXIS_DY, kDz = aero_table::AXIS_DZ,
              kDphi = aero_table::AXIS_DPHI, kDtheta = aero_table::AXIS_DTHETA,
              kDpsi = aero_table::AXIS_DPSI, kMach = aero_table::AXIS_MACH;
// Axes a body can leave: alpha, beta, Mach (slots 0-2), then the proximity axes (3 ..).
constexpr int kSlots = loads::AERO_SLOTS;

// What the load was computed from (for tests and recordings).
struct Air {
  double alpha, beta, mach, speed, density, altitude, pressure;  // pressure: dynamic, Pa
  double coefficients[6];  // free stream plus increments plus delta (moments about r)
  double increments[6];    // of the proximity table
  double about_cg[3];      // the moment coefficients about the CG (damping included)
};

// The flow at the body: air-relative velocity in body axes, angles, Mach, density and
// every table axis's value (alpha, beta, Mach, then the proximity axes).
struct Flow {
  double u, v, w, speed, alpha, beta, mach, density, altitude;
  double x[kSlots];
};

// One ZYX angle (0 roll, 1 pitch, 2 yaw; rad) of a rotation matrix (row-major).
inline double zyx_angle(const double* r, int which) {
  if (which == 0) return std::atan2(r[7], r[8]);
  if (which == 2) return std::atan2(r[3], r[0]);
  double s = -r[6];
  return std::asin(s > 1.0 ? 1.0 : (s < -1.0 ? -1.0 : s));
}

// Where the free-stream grids, coefficients and proximity grids start in a packed table.
template <class P>
inline long table_at(const P& p) { return kHeader + static_cast<long>(p[kNa] + p[kNb] + p[kNm]); }
template <class P>
inline long proximity_at(const P& p) {
  return table_at(p) + 6L * static_cast<long>(p[kNa] * p[kNb] * p[kNm]);
}

// The flow at a state. position, velocity: CG, world (m, m/s); rot: body to world,
// row-major; carrier_position, carrier_rot: the carrier's (read with a proximity table).
template <class P>
inline void flow(const P& p, const double* position, const double* velocity, const double* rot,
                 const double* carrier_position, const double* carrier_rot, Flow& f) {
  double rel[3] = {velocity[0] - p[kWind], velocity[1] - p[kWind + 1],
                   velocity[2] - p[kWind + 2]};
  f.u = rot[0] * rel[0] + rot[3] * rel[1] + rot[6] * rel[2];
  f.v = rot[1] * rel[0] + rot[4] * rel[1] + rot[7] * rel[2];
  f.w = rot[2] * rel[0] + rot[5] * rel[1] + rot[8] * rel[2];
  f.speed = std::sqrt(f.u * f.u + f.v * f.v + f.w * f.w);
  f.altitude = p[kAltitude] + p[kUp] * position[0] + p[kUp + 1] * position[1] +
               p[kUp + 2] * position[2];
  f.density = p[kDensity];
  double sound = 0.0;
  if (!(f.density > 0.0) || p[kNm] > 1.0 || p[kProxAxes] > 0.0) {
    double isa_density;
    isa(f.altitude, p[kTemperatureOffset], isa_density, sound);
    if (!(f.density > 0.0)) f.density = isa_density;
  }
  f.alpha = f.beta = f.mach = 0.0;
  if (f.speed > 0.0) {
    f.alpha = std::atan2(f.w, f.u);
    double vs = f.v / f.speed;
    f.beta = std::asin(vs > 1.0 ? 1.0 : (vs < -1.0 ? -1.0 : vs));
    f.mach = sound > 0.0 ? f.speed / sound : 0.0;
  }
  f.x[0] = f.alpha, f.x[1] = f.beta, f.x[2] = f.mach;
  int axes = static_cast<int>(p[kProxAxes]);
  if (axes == 0) return;
  // the CG in the carrier's axes, from where it was at t = 0; the attitude relative to it
  double gap[3] = {position[0] - carrier_position[0], position[1] - carrier_position[1],
                   position[2] - carrier_position[2]};
  double q[7];
  for (int i = 0; i < 3; ++i) {
    q[i] = carrier_rot[i] * gap[0] + carrier_rot[3 + i] * gap[1] + carrier_rot[6 + i] * gap[2] -
           p[kStart + i];
  }
  double relative[9];  // carrier_rot^T rot
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      relative[3 * i + j] = carrier_rot[i] * rot[j] + carrier_rot[3 + i] * rot[3 + j] +
                            carrier_rot[6 + i] * rot[6 + j];
    }
  }
  q[6] = f.mach;
  for (int a = 0; a < axes; ++a) {
    int code = static_cast<int>(p[kProxCode + a]);
    f.x[3 + a] = code >= kDphi && code <= kDpsi ? zyx_angle(relative, code - kDphi) : q[code];
  }
}

// The numbers a packed table takes by its header (the header, the free-stream grids and
// their coefficients, the proximity grids and increments: engine/aeropack.py's order), or
// -1 if its header is not one this reader can read within `size` numbers: a grid of no
// node or of a fraction of one, a proximity axis count or code out of range, more numbers
// than size. The System and aero_wrench check a table with it once (never a read past it).
template <class P>
inline long packed_length(const P& p, long size) {
  auto count = [](double v, double most) { return v >= 0.0 && v <= most && v == std::floor(v); };
  if (size < kHeader) return -1;
  double length = kHeader, cells = 1.0;
  for (int k = 0; k < 3; ++k) {
    double nodes = p[kNa + k];
    if (!count(nodes, 1e7) || nodes < 1.0) return -1;
    length += nodes;
    cells *= nodes;
  }
  length += 6.0 * cells;
  double axes = p[kProxAxes];
  if (!count(axes, kSlots - 3)) return -1;
  double prox_cells = 1.0;
  for (int a = 0; a < static_cast<int>(axes); ++a) {
    double nodes = p[kProxSize + a], code = p[kProxCode + a];
    if (!count(nodes, 1e7) || nodes < 1.0 || !count(code, kMach)) return -1;
    length += nodes;
    prox_cells *= nodes;
  }
  if (axes > 0.0) length += 6.0 * prox_cells;
  return length <= static_cast<double>(size) ? static_cast<long>(length) : -1;
}

// The axes of a packed table a body can leave, by slot: 1 if watched, with the grid's first
// and last values into low and high (rad for angles, Mach, m). Returns the slots used.
template <class P>
inline int ranges(const P& p, int* watched, double* low, double* high) {
  long at = kHeader;
  for (int k = 0; k < 3; ++k) {
    long size = static_cast<long>(p[kNa + k]);
    watched[k] = size > 1;
    low[k] = p[at];
    high[k] = p[at + size - 1];
    at += size;
  }
  int axes = static_cast<int>(p[kProxAxes]);
  at = proximity_at(p);
  for (int a = 0; a < axes; ++a) {
    long size = static_cast<long>(p[kProxSize + a]);
    watched[3 + a] = 1;
    low[3 + a] = p[at];
    high[3 + a] = p[at + size - 1];
    at += size;
  }
  return 3 + axes;
}

// The dynamic pressure of air of density rho (kg/m^3) at speed v (m/s), Pa: rho v^2 / 2.
inline double dynamic_pressure(double rho, double v) { return 0.5 * rho * v * v; }

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
  Flow f;
  flow(p, position, velocity, rot, carrier_position, carrier_rot, f);
  if (f.speed == 0.0) {
    if (air) *air = Air{0.0, 0.0, 0.0, 0.0, f.density, f.altitude, 0.0, {0}, {0}, {0}};
    return;
  }
  int sizes[kMaxAxes] = {static_cast<int>(p[kNa]), static_cast<int>(p[kNb]),
                         static_cast<int>(p[kNm])};
  double c[6], d[6] = {0, 0, 0, 0, 0, 0};
  multilinear(3, sizes, p, kHeader, table_at(p), 6, f.x, c);
  for (int k = 0; k < 6; ++k) c[k] += p[kDelta + k];
  int axes = static_cast<int>(p[kProxAxes]);
  if (axes > 0) {
    int prox_sizes[kMaxAxes], position_axis[kMaxAxes];
    long count = 0;
    for (int a = 0; a < axes; ++a) {
      prox_sizes[a] = static_cast<int>(p[kProxSize + a]);
      position_axis[a] = static_cast<int>(p[kProxCode + a]) <= kDz;
      count += prox_sizes[a];
    }
    const long prox_grids = proximity_at(p);
    double weight = fade_weight(axes, prox_sizes, p, prox_grids, position_axis, f.x + 3,
                                p[kFade]);
    if (weight > 0.0) {   // faded out far from the carrier: nothing to interpolate
      multilinear(axes, prox_sizes, p, prox_grids, prox_grids + count, 6, f.x + 3, d);
      for (int k = 0; k < 6; ++k) {
        d[k] *= weight;
        c[k] += d[k];
      }
    }
  }
  double dynamic = dynamic_pressure(f.density, f.speed);
  double qs = dynamic * p[kArea];
  double length = p[kLength];
  double scale = length / (2.0 * f.speed);
  double force[3] = {qs * c[0], qs * c[1], qs * c[2]};
  const double r[3] = {p[kReference], p[kReference + 1], p[kReference + 2]};
  double m[3] = {r[1] * force[2] - r[2] * force[1], r[2] * force[0] - r[0] * force[2],
                 r[0] * force[1] - r[1] * force[0]};
  for (int k = 0; k < 3; ++k)
    m[k] += qs * length * (c[3 + k] + p[kDamping + k] * rates[k] * scale);
  for (int i = 0; i < 3; ++i) {
    out[i] = rot[3 * i] * force[0] + rot[3 * i + 1] * force[1] + rot[3 * i + 2] * force[2];
    out[3 + i] = rot[3 * i] * m[0] + rot[3 * i + 1] * m[1] + rot[3 * i + 2] * m[2];
  }
  if (air) {
    *air = Air{f.alpha, f.beta, f.mach, f.speed, f.density, f.altitude, dynamic,
               {0}, {0}, {0}};
    for (int k = 0; k < 6; ++k) {
      air->coefficients[k] = c[k];
      air->increments[k] = d[k];
    }
    for (int k = 0; k < 3; ++k) air->about_cg[k] = m[k] / (qs * length);
  }
}

}  // namespace aero
}  // namespace cfem
