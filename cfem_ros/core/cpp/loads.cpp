// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
#include "loads.hpp"

#include <algorithm>
#include <cmath>

#include "aero.hpp"
#include "algebra.hpp"
#include "braces.hpp"
#include "distance.hpp"

namespace cfem {
namespace loads {

namespace {

void turn(const double* rot, const double* v, double* out) {
  for (int k = 0; k < 3; ++k) out[k] = rot[3 * k] * v[0] + rot[3 * k + 1] * v[1] + rot[3 * k + 2] * v[2];
}

// Body i's CG plus its rotation (from its quaternion in y) applied to p.
V3 carried(const double* y, idx n, idx i, double px, double py, double pz) {
  idx o = state::quaternion(n, i);
  Products p = products(y[o], y[o + 1], y[o + 2], y[o + 3]);
  double s = 2.0 / (p.xx + p.yy + p.zz + p.w * p.w);
  return {y[state::position(n, i)] + (1 - s * (p.yy + p.zz)) * px + s * (p.xy - p.wz) * py
              + s * (p.xz + p.wy) * pz,
          y[state::position(n, i) + 1] + s * (p.xy + p.wz) * px + (1 - s * (p.xx + p.zz)) * py
              + s * (p.yz - p.wx) * pz,
          y[state::position(n, i) + 2] + s * (p.xz - p.wy) * px + s * (p.yz + p.wx) * py
              + (1 - s * (p.xx + p.yy)) * pz};
}

// Force and moment of the row's table at x into out (6), linear, held beyond its ends.
void table_value(const Mat& loads, idx row, double x, double* out) {
  idx first = static_cast<idx>(loads(row, S_FIRST)), count = static_cast<idx>(loads(row, S_COUNT));
  idx last = first + count - 1;
  if (x <= loads(first, 0)) {
    for (int k = 0; k < 6; ++k) out[k] = loads(first, 1 + k);
    return;
  }
  if (x >= loads(last, 0)) {
    for (int k = 0; k < 6; ++k) out[k] = loads(last, 1 + k);
    return;
  }
  idx lo = first;
  while (loads(lo + 1, 0) < x) ++lo;
  double x0 = loads(lo, 0), x1 = loads(lo + 1, 0);
  double u = (x - x0) / (x1 - x0);
  for (int k = 0; k < 6; ++k) out[k] = loads(lo, 1 + k) + u * (loads(lo + 1, 1 + k) - loads(lo, 1 + k));
}

// The scheduled row's wrench on its body at y into out (18), world axes; false if off.
// out: force (3), moment about the body's CG (3), world point (3), moment given (3), scratch.
bool scheduled_wrench(const double* y, const double* rot, const Mat& loads, idx row, idx n,
                      double* out) {
  if (loads(row, S_ON) <= 0.0) return false;
  double* point = out + 6;
  double stroke = point_and_stroke(y, loads, row, n, point);
  double* local = out + 12;
  int kind = static_cast<int>(loads(row, S_TABLE));
  if (kind == TABLE_NONE) {
    for (int k = 0; k < 6; ++k) local[k] = loads(row, S_FORCE + k);
  } else {
    double x = kind == TABLE_TIME ? loads(row, S_T) - loads(row, S_START) : stroke;
    table_value(loads, row, x, local);
  }
  idx f = static_cast<idx>(loads(row, S_FRAME));
  if (f >= 0) {
    turn(rot + 9 * f, local, out);
    turn(rot + 9 * f, local + 3, out + 9);
  } else {
    for (int k = 0; k < 3; ++k) {
      out[k] = local[k];
      out[9 + k] = local[3 + k];
    }
  }
  idx b = static_cast<idx>(loads(row, S_BODY));
  const double* cg = y + state::position(n, b);
  double r0 = point[0] - cg[0], r1 = point[1] - cg[1], r2 = point[2] - cg[2];
  out[3] = out[9] + r1 * out[2] - r2 * out[1];
  out[4] = out[10] + r2 * out[0] - r0 * out[2];
  out[5] = out[11] + r0 * out[1] - r1 * out[0];
  return true;
}

// The aerodynamic force and moment about the CG of the row's body at y into out[0:6]
// (world axes): aero.hpp on the row's packed table (loads.py keeps it in the first 23
// columns of the rows from A_FIRST on); zero at zero airspeed. air: what it was computed from.
void aero_wrench(const double* y, const double* rot, const Mat& loads, idx row, idx n,
                 double* out, aero::Air* air = nullptr) {
  idx b = static_cast<idx>(loads(row, A_BODY));
  idx c = static_cast<idx>(loads(row, A_CARRIER));
  if (c < 0) c = b;   // no proximity table: the carrier is not read
  const double* rb = rot + 9 * b;
  aero::wrench(Rows{loads.row(static_cast<idx>(loads(row, A_FIRST)))}, y + state::position(n, b),
               y + state::velocity(n, b), rb, y + state::rates(n, b), y + state::position(n, c),
               rot + 9 * c, out, air);
}

// Where aero row `row`'s body is on each axis at y: values, status, ends (aero_axes).
void axes_at(const double* y, const Mat& loads, idx row, idx n, double* values, int* status,
             double* low, double* high) {
  idx b = static_cast<idx>(loads(row, A_BODY));
  idx c = static_cast<idx>(loads(row, A_CARRIER));
  if (c < 0) c = b;
  double rb[9], rc[9];
  const double* qb = y + state::quaternion(n, b);
  const double* qc = y + state::quaternion(n, c);
  quat_matrix(qb[0], qb[1], qb[2], qb[3], rb);
  quat_matrix(qc[0], qc[1], qc[2], qc[3], rc);
  Rows p{loads.row(static_cast<idx>(loads(row, A_FIRST)))};
  aero::Flow f;
  aero::flow(p, y + state::position(n, b), y + state::velocity(n, b), rb,
             y + state::position(n, c), rc, f);
  int watched[aero::kSlots] = {0};
  int used = aero::ranges(p, watched, low, high);
  for (int k = 0; k < aero::kSlots; ++k) {
    values[k] = k < used ? f.x[k] : 0.0;
    status[k] = 0;
    if (k < used && watched[k]) status[k] = f.x[k] < low[k] ? -1 : (f.x[k] > high[k] ? 1 : 0);
  }
}


// Body a's pose in body b's axes at y into pose: its CG (3) and quaternion (4, x y z w).
void relative_pose(const double* y, idx n, idx a, idx b, double* pose) {
  const double* qa = y + state::quaternion(n, a);
  const double* qb = y + state::quaternion(n, b);
  Products pb = products(qb[0], qb[1], qb[2], qb[3]);
  const double* ca = y + state::position(n, a);
  const double* cb = y + state::position(n, b);
  V3 r = unit_turn(pb, ca[0] - cb[0], ca[1] - cb[1], ca[2] - cb[2], true);
  pose[0] = r.x;
  pose[1] = r.y;
  pose[2] = r.z;
  // conj(qb) qa
  double x = qb[0], yb = qb[1], z = qb[2], w = qb[3];
  pose[3] = w * qa[0] - x * qa[3] - yb * qa[2] + z * qa[1];
  pose[4] = w * qa[1] - yb * qa[3] - z * qa[0] + x * qa[2];
  pose[5] = w * qa[2] - z * qa[3] - x * qa[1] + yb * qa[0];
  pose[6] = w * qa[3] + x * qa[0] + yb * qa[1] + z * qa[2];
}

// True if the shapes of contact row `row` are surely more than CONTACT_GAP apart at y,
// without GJK: farther apart than the bounding spheres, or than the distance GJK last found
// (C_SEEN, at the pose C_POSE) less the most any point of shape a can have moved since in
// b's axes: its CG's move plus its radius times |R - R_seen| <= 2 |q - q_seen| (either
// sign of q). Else false, and GJK decides (its distance and pose kept for the next time).
bool surely_apart(const double* y, const Mat& loads, idx row, idx n) {
  idx a = static_cast<idx>(loads(row, C_A)), b = static_cast<idx>(loads(row, C_B));
  const double* ca = y + state::position(n, a);
  const double* cb = y + state::position(n, b);
  double d0 = ca[0] - cb[0], d1 = ca[1] - cb[1];
  double d2 = ca[2] - cb[2];
  double radius_a = loads(row, C_RADIUS_A);
  if (std::sqrt(d0 * d0 + d1 * d1 + d2 * d2) - radius_a - loads(row, C_RADIUS_B) > CONTACT_GAP)
    return true;
  double pose[7];
  relative_pose(y, n, a, b, pose);
  const double* seen = loads.row(row) + C_POSE;
  double seen_gap = loads(row, C_SEEN);
  if (seen_gap > 0.0) {
    double moved2 = 0.0, minus2 = 0.0, plus2 = 0.0;
    for (int k = 0; k < 3; ++k) moved2 += (pose[k] - seen[k]) * (pose[k] - seen[k]);
    for (int k = 3; k < 7; ++k) {
      minus2 += (pose[k] - seen[k]) * (pose[k] - seen[k]);
      plus2 += (pose[k] + seen[k]) * (pose[k] + seen[k]);
    }
    double moved = std::sqrt(moved2) + 2.0 * radius_a * std::sqrt(std::min(minus2, plus2));
    // the margin covers GJK's tolerance (1e-12 m) and the rounding of the bound
    if (seen_gap - moved > CONTACT_GAP + 1e-9 * (1.0 + seen_gap)) return true;
  }
  double gap = contact_gap(y, loads, row, n, nullptr);
  loads(row, C_SEEN) = gap > 0.0 ? gap : 0.0;
  for (int k = 0; k < 7; ++k) loads(row, C_POSE + k) = pose[k];
  return gap > CONTACT_GAP;
}

// Add to fhat the opposite of wrench w (force (3), moment about the loaded body's CG (3),
// world point (6:9), moment given (9:12) or none) on body j about its own CG, at cg.
void react(const double* cg, const double* w, bool given, idx j, double* fhat) {
  double r0 = w[6] - cg[0], r1 = w[7] - cg[1], r2 = w[8] - cg[2];
  double* fj = fhat + 6 * j;
  fj[0] -= w[0];
  fj[1] -= w[1];
  fj[2] -= w[2];
  fj[3] -= (given ? w[9] : 0.0) + r1 * w[2] - r2 * w[1];
  fj[4] -= (given ? w[10] : 0.0) + r2 * w[0] - r0 * w[2];
  fj[5] -= (given ? w[11] : 0.0) + r0 * w[1] - r1 * w[0];
}

}  // namespace

double point_and_stroke(const double* y, const Mat& loads, idx row, idx n, double* point) {
  idx b = static_cast<idx>(loads(row, S_BODY));
  V3 p = carried(y, n, b, loads(row, S_POINT), loads(row, S_POINT + 1), loads(row, S_POINT + 2));
  idx j = static_cast<idx>(loads(row, S_REACT));
  V3 ref = {loads(row, S_ANCHOR), loads(row, S_ANCHOR + 1), loads(row, S_ANCHOR + 2)};
  if (j >= 0) ref = carried(y, n, j, ref.x, ref.y, ref.z);
  double g0 = p.x - ref.x, g1 = p.y - ref.y, g2 = p.z - ref.z;
  if (point) {
    point[0] = p.x;
    point[1] = p.y;
    point[2] = p.z;
  }
  return std::sqrt(g0 * g0 + g1 * g1 + g2 * g2);
}

void add_scheduled(const double* y, const double* rot, const Mat& bodies, const Mat& loads,
                   double* fhat) {
  idx n = bodies.rows;
  double* w = loads.row(loads.rows - 1);  // the scratch row
  for (idx row = n; row < loads.rows; ++row) {
    double kind = loads(row, S_KIND);
    if (kind == KIND_TABLE || kind == KIND_SCRATCH) break;  // the tables: no more loads
    if (kind == KIND_AERO) {
      aero_wrench(y, rot, loads, row, n, w);
      idx b = static_cast<idx>(loads(row, A_BODY));
      for (int k = 0; k < 6; ++k) fhat[6 * b + k] += w[k];
      continue;
    }
    bool brace = kind == KIND_BRACE;
    if (brace) {
      if (!braces::wrench(y, rot, loads, row, n, w)) continue;
    } else if (kind != KIND_SCHEDULED || !scheduled_wrench(y, rot, loads, row, n, w)) {
      continue;
    }
    idx b = static_cast<idx>(loads(row, S_BODY));
    for (int k = 0; k < 6; ++k) fhat[6 * b + k] += w[k];
    idx j = static_cast<idx>(loads(row, S_REACT));
    if (j >= 0 && bodies(j, motion::B_INV_MASS) > 0.0)
      react(y + state::position(n, j), w, !brace, j, fhat);
  }
}

void set_time(const Mat& loads, idx n, double t) {
  for (idx row = n; row < loads.rows; ++row) {
    if (loads(row, S_KIND) != KIND_SCHEDULED) break;
    loads(row, S_T0) = t;
    loads(row, S_T) = t;
  }
}

void stage_time(const Mat& loads, idx n, double offset) {
  for (idx row = n; row < loads.rows; ++row) {
    if (loads(row, S_KIND) != KIND_SCHEDULED) break;
    loads(row, S_T) = loads(row, S_T0) + offset;
  }
}

void rotations(const double* y, idx n, double* rot) {
  for (idx i = 0; i < n; ++i) {
    idx o = state::quaternion(n, i);
    Products p = products(y[o], y[o + 1], y[o + 2], y[o + 3]);
    double s = 2.0 / (p.xx + p.yy + p.zz + p.w * p.w);
    double* r = rot + 9 * i;
    r[0] = 1 - s * (p.yy + p.zz);
    r[1] = s * (p.xy - p.wz);
    r[2] = s * (p.xz + p.wy);
    r[3] = s * (p.xy + p.wz);
    r[4] = 1 - s * (p.xx + p.zz);
    r[5] = s * (p.yz - p.wx);
    r[6] = s * (p.xz - p.wy);
    r[7] = s * (p.yz + p.wx);
    r[8] = 1 - s * (p.xx + p.yy);
  }
}

void strokes(const double* y, const Mat& loads, idx n, double* out) {
  for (idx row = n; row < loads.rows; ++row) {
    out[row - n] = -1.0;
    if (loads(row, S_KIND) == KIND_SCHEDULED) out[row - n] = point_and_stroke(y, loads, row, n, nullptr);
  }
}

bool stroke_reached(const double* y, const Mat& loads, idx n) {
  for (idx row = n; row < loads.rows; ++row) {
    double kind = loads(row, S_KIND);
    if (kind != KIND_SCHEDULED && kind != KIND_AERO && kind != KIND_CONTACT
        && kind != KIND_BRACE)
      break;
    if (kind == KIND_BRACE && braces::switched(y, loads, row, n)) return true;
    if (kind == KIND_SCHEDULED && loads(row, S_ON) > 0.0 && loads(row, S_STROKE) < INFINITY) {
      if (point_and_stroke(y, loads, row, n, nullptr) >= loads(row, S_STROKE)) return true;
    }
    if (kind == KIND_AERO && aero_moved(y, loads, row, n)) return true;
    if (kind == KIND_CONTACT) {
      bool apart = surely_apart(y, loads, row, n);
      if (loads(row, S_ON) > 0.0 && !apart) return true;
      if (apart) loads(row, S_ON) = 1.0;   // apart again: watched again
    }
  }
  return false;
}

double contact_gap(const double* y, const Mat& loads, idx row, idx n, double* points,
                   int* parts) {
  idx a = static_cast<idx>(loads(row, C_A)), b = static_cast<idx>(loads(row, C_B));
  double rot_a[9], rot_b[9], scratch[closest::WIDTH];
  const double* qa = y + state::quaternion(n, a);
  const double* qb = y + state::quaternion(n, b);
  quat_matrix(qa[0], qa[1], qa[2], qa[3], rot_a);
  quat_matrix(qb[0], qb[1], qb[2], qb[3], rot_b);
  double* p = points ? points : scratch;
  return shapes::any_distance(Rows{loads.row(static_cast<idx>(loads(row, C_SHAPE_A)))}, rot_a,
                              y + state::position(n, a),
                              Rows{loads.row(static_cast<idx>(loads(row, C_SHAPE_B)))}, rot_b,
                              y + state::position(n, b), p + closest::P_A, p + closest::P_B,
                              loads.row(row) + C_GUESS, parts);
}

void sample_applied(const double* y, const Mat& bodies, const Mat& loads, double* out,
                    double* rot, double* w) {
  idx n = bodies.rows;
  rotations(y, n, rot);
  idx o = 0;
  idx aero_first = -1, aero_count = 0;
  for (idx row = n; row < loads.rows; ++row) {
    double kind = loads(row, S_KIND);
    if (kind == KIND_TABLE || kind == KIND_SCRATCH) break;  // the tables
    if (kind == KIND_AERO) {
      if (aero_first < 0) aero_first = row;
      ++aero_count;
      aero_wrench(y, rot, loads, row, n, w);
      for (int k = 0; k < 6; ++k) out[o + sample::O_WRENCH_FORCE + k] = w[k];
      o += sample::WRENCH;
      continue;
    }
    bool brace = kind == KIND_BRACE;
    if (kind != KIND_SCHEDULED && !brace) continue;
    bool on = brace ? braces::wrench(y, rot, loads, row, n, w)
                    : scheduled_wrench(y, rot, loads, row, n, w);
    for (int k = 0; k < 6; ++k) out[o + sample::O_WRENCH_FORCE + k] = on ? w[k] : 0.0;
    o += sample::WRENCH;
    idx j = static_cast<idx>(loads(row, S_REACT));
    if (j >= 0 && bodies(j, motion::B_INV_MASS) > 0.0) {
      const double* cg = y + state::position(n, j);
      double r0 = w[6] - cg[0], r1 = w[7] - cg[1], r2 = w[8] - cg[2];
      double g0 = brace ? 0.0 : w[9], g1 = brace ? 0.0 : w[10], g2 = brace ? 0.0 : w[11];
      double reaction[6] = {-w[0], -w[1], -w[2], -(g0 + r1 * w[2] - r2 * w[1]),
                            -(g1 + r2 * w[0] - r0 * w[2]), -(g2 + r0 * w[1] - r1 * w[0])};
      for (int k = 0; k < 6; ++k) out[o + sample::O_WRENCH_FORCE + k] = on ? reaction[k] : 0.0;
      o += sample::WRENCH;
    }
  }
  // the air each body with aero tables sees: flow, air, force and moment coefficients
  const double deg = 180.0 / 3.14159265358979323846;
  for (idx row = aero_first; row >= 0 && row < aero_first + aero_count; ++row) {
    aero::Air air;
    aero_wrench(y, rot, loads, row, n, w, &air);
    double* a = out + o;
    a[sample::O_ALPHA] = air.alpha * deg;
    a[sample::O_BETA] = air.beta * deg;
    a[sample::O_MACH] = air.mach;
    a[sample::O_PRESSURE] = air.pressure;
    a[sample::O_DENSITY] = air.density;
    a[sample::O_SPEED] = air.speed;
    for (int k = 0; k < 3; ++k) {
      a[sample::O_FORCE_COEFFICIENTS + k] = air.coefficients[k];
      a[sample::O_MOMENT_COEFFICIENTS + k] = air.about_cg[k];
    }
    o += sample::AIR;
  }
}

idx applied_size(const Mat& bodies, const Mat& loads) {
  idx size = 0;
  for (idx row = bodies.rows; row < loads.rows; ++row) {
    double kind = loads(row, S_KIND);
    if (kind == KIND_TABLE || kind == KIND_SCRATCH) break;   // as sample_applied
    if (kind == KIND_AERO) {
      size += sample::WRENCH + sample::AIR;
    } else if (kind == KIND_SCHEDULED || kind == KIND_BRACE) {
      idx j = static_cast<idx>(loads(row, S_REACT));
      size += j >= 0 && bodies(j, motion::B_INV_MASS) > 0.0 ? 2 * sample::WRENCH
                                                            : sample::WRENCH;
    }
  }
  return size;
}

bool aero_moved(const double* y, const Mat& loads, idx row, idx n) {
  double values[aero::kSlots], low[aero::kSlots], high[aero::kSlots];
  int status[aero::kSlots];
  axes_at(y, loads, row, n, values, status, low, high);
  for (int k = 0; k < aero::kSlots; ++k)
    if (status[k] != static_cast<int>(loads(row, A_STATUS + k))) return true;
  return false;
}

void aero_axes(const double* y, const Mat& loads, idx row, idx n, double* values,
               double* status, double* low, double* high) {
  int where[aero::kSlots];
  axes_at(y, loads, row, n, values, where, low, high);
  for (int k = 0; k < aero::kSlots; ++k) status[k] = where[k];
}

double aero_crossing(const double* y, const double* y1, const Mat& loads, idx row, idx n) {
  double values[aero::kSlots], low[aero::kSlots], high[aero::kSlots];
  double end[aero::kSlots];
  int status[aero::kSlots], target[aero::kSlots];
  axes_at(y1, loads, row, n, end, target, low, high);
  axes_at(y, loads, row, n, values, status, low, high);
  double most = -INFINITY;
  for (int k = 0; k < aero::kSlots; ++k) {
    int was = static_cast<int>(loads(row, A_STATUS + k));
    if (target[k] == was) continue;
    // leaving: past the end it leaves by; coming back (or across): inside the end it left by
    double e = was == 0 ? (target[k] > 0 ? values[k] - high[k] : low[k] - values[k])
                        : (was > 0 ? high[k] - values[k] : values[k] - low[k]);
    if (e > most) most = e;
  }
  return most;
}

}  // namespace loads
}  // namespace cfem
