// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
#include "motion.hpp"

#include <cmath>

#include "algebra.hpp"

namespace cfem {
namespace motion {

using trajectory::D_POSITION, trajectory::D_VELOCITY, trajectory::D_QUATERNION,
    trajectory::D_RATES, trajectory::D_COUNT, trajectory::D_TIMES, trajectory::G_POSITION,
    trajectory::G_KEY, trajectory::G_ROTATION, trajectory::SEGMENT;

namespace {

// The unit quaternion of the rotation vector (rx, ry, rz), x y z w.
Q4 exp_map(double rx, double ry, double rz) {
  double angle = std::sqrt(rx * rx + ry * ry + rz * rz);
  double s;
  if (angle < 1e-4) {
    s = 0.5 - angle * angle / 48.0;
  } else {
    s = std::sin(0.5 * angle) / angle;
  }
  return {rx * s, ry * s, rz * s, std::cos(0.5 * angle)};
}

void constant(const Mat& bodies, idx i, double t, double* y, idx n) {
  const int c = M_DATA;
  for (int k = 0; k < 3; ++k) {
    y[state::position(n, i) + k] =
        bodies(i, c + D_POSITION + k) + bodies(i, c + D_VELOCITY + k) * t;
    y[state::velocity(n, i) + k] = bodies(i, c + D_VELOCITY + k);
    y[state::rates(n, i) + k] = bodies(i, c + D_RATES + k);
    bodies(i, M_ACC + k) = 0.0;
    bodies(i, M_ACC + 3 + k) = 0.0;  // constant body rates: d(R w)/dt = R (w x w) = 0
  }
  const int r = c + D_RATES, a = c + D_QUATERNION;
  Q4 e = exp_map(bodies(i, r) * t, bodies(i, r + 1) * t, bodies(i, r + 2) * t);
  Q4 q = qmul(bodies(i, a), bodies(i, a + 1), bodies(i, a + 2), bodies(i, a + 3), e.x, e.y,
              e.z, e.w);
  y[state::quaternion(n, i)] = q.x;
  y[state::quaternion(n, i) + 1] = q.y;
  y[state::quaternion(n, i) + 2] = q.z;
  y[state::quaternion(n, i) + 3] = q.w;
}

double poly(const Mat& bodies, idx i, idx o, double s, int order) {
  double c0 = bodies(i, o), c1 = bodies(i, o + 1), c2 = bodies(i, o + 2), c3 = bodies(i, o + 3);
  if (order == 0) return ((c0 * s + c1) * s + c2) * s + c3;
  if (order == 1) return (3.0 * c0 * s + 2.0 * c1) * s + c2;
  return 6.0 * c0 * s + 2.0 * c1;
}

V3 cubic(const Mat& bodies, idx i, idx o, double s, int order) {
  return {poly(bodies, i, o, s, order), poly(bodies, i, o + 4, s, order),
          poly(bodies, i, o + 8, s, order)};
}

// (I - k1 [r]x + k2 [r]x^2) rd: scipy's rotation-vector rate to angular rate.
V3 rate(const V3& r, const V3& rd, double k1, double k2) {
  V3 c = cross(r, rd);
  V3 cc = cross(r, c);
  return {rd.x - k1 * c.x + k2 * cc.x, rd.y - k1 * c.y + k2 * cc.y, rd.z - k1 * c.z + k2 * cc.z};
}

void table(const Mat& bodies, idx i, double t, double* y, idx n) {
  idx count = static_cast<idx>(bodies(i, M_DATA + D_COUNT));
  const idx first = M_DATA + D_TIMES;
  idx seg = 0;
  while (seg < count - 1 && bodies(i, first + seg + 1) <= t) ++seg;
  double s = t - bodies(i, first + seg);
  idx o = first + count + 1 + SEGMENT * seg;
  for (int k = 0; k < 3; ++k) {
    const idx at = o + G_POSITION + 4 * k;
    double c0 = bodies(i, at), c1 = bodies(i, at + 1);
    double c2 = bodies(i, at + 2), c3 = bodies(i, at + 3);
    y[state::position(n, i) + k] = ((c0 * s + c1) * s + c2) * s + c3;
    y[state::velocity(n, i) + k] = (3.0 * c0 * s + 2.0 * c1) * s + c2;
    bodies(i, M_ACC + k) = 6.0 * c0 * s + 2.0 * c1;
  }
  idx key = o + G_KEY;
  V3 r = cubic(bodies, i, o + G_ROTATION, s, 0);
  V3 rd = cubic(bodies, i, o + G_ROTATION, s, 1);
  V3 rdd = cubic(bodies, i, o + G_ROTATION, s, 2);
  Q4 e = exp_map(r.x, r.y, r.z);
  Q4 q = qmul(bodies(i, key), bodies(i, key + 1), bodies(i, key + 2), bodies(i, key + 3), e.x,
              e.y, e.z, e.w);
  double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  y[state::quaternion(n, i)] = q.x / norm;
  y[state::quaternion(n, i) + 1] = q.y / norm;
  y[state::quaternion(n, i) + 2] = q.z / norm;
  y[state::quaternion(n, i) + 3] = q.w / norm;
  // body rates and their derivative from the rotation vector's (scipy RotationSpline)
  double theta = std::sqrt(r.x * r.x + r.y * r.y + r.z * r.z);
  double k1, k2, n1, n2;
  if (theta > 1e-4) {
    k1 = (1.0 - std::cos(theta)) / ipow(theta, 2);
    k2 = (theta - std::sin(theta)) / ipow(theta, 3);
    n1 = (-theta * std::sin(theta) - 2.0 * (std::cos(theta) - 1.0)) / ipow(theta, 4);
    n2 = (-2.0 * theta + 3.0 * std::sin(theta) - theta * std::cos(theta)) / ipow(theta, 5);
  } else {
    k1 = 0.5 - ipow(theta, 2) / 24.0;
    k2 = 1.0 / 6.0 - ipow(theta, 2) / 120.0;
    n1 = 1.0 / 12.0 - ipow(theta, 2) / 180.0;
    n2 = -1.0 / 60.0 + ipow(theta, 2) / 12604.0;
  }
  V3 w = rate(r, rd, k1, k2);
  V3 linear = rate(r, rdd, k1, k2);
  double dp = r.x * rd.x + r.y * rd.y + r.z * rd.z;
  V3 cp = cross(r, rd);
  V3 ccp = cross(r, cp);
  V3 dccp = cross(rd, cp);
  y[state::rates(n, i)] = w.x;
  y[state::rates(n, i) + 1] = w.y;
  y[state::rates(n, i) + 2] = w.z;
  double a0 = linear.x + dp * (n1 * cp.x + n2 * ccp.x) + k2 * dccp.x;
  double a1 = linear.y + dp * (n1 * cp.y + n2 * ccp.y) + k2 * dccp.y;
  double a2 = linear.z + dp * (n1 * cp.z + n2 * ccp.z) + k2 * dccp.z;
  // world angular acceleration: R alpha_body (the w x w term is zero)
  const double* unit = y + state::quaternion(n, i);
  V3 world = unit_turn(products(unit[0], unit[1], unit[2], unit[3]), a0, a1, a2, false);
  bodies(i, M_ACC + 3) = world.x;
  bodies(i, M_ACC + 4) = world.y;
  bodies(i, M_ACC + 5) = world.z;
}

// R a (R^T a if inverse), R the matrix of the unit quaternion (x, y, z, w).
V3 turn(double x, double y, double z, double w, double a0, double a1, double a2, bool inverse) {
  return unit_turn(products(x, y, z, w), a0, a1, a2, inverse);
}

// A steady manoeuvre (KIND_ARC, a scenario's flight:): the same numbers as ``constant`` but
// the velocity v is in body axes and turns with the body, whose body rates w are constant:
// R(t) = R0 exp([w] t), velocity R(t) v, acceleration R(t) (w x v), and the position in
// closed form, p0 + R0 (t v + t^2 k1 (w x v) + t^3 k2 (w x (w x v))), k1 = (1 - cos a) / a^2,
// k2 = (a - sin a) / a^3, a = |w| t (the integral of exp([w] s) v from 0 to t).
void arc(const Mat& bodies, idx i, double t, double* y, idx n) {
  const int c = M_DATA;
  constant(bodies, i, t, y, n);  // the attitude and the body rates; the rest below
  V3 v{bodies(i, c + D_VELOCITY), bodies(i, c + D_VELOCITY + 1), bodies(i, c + D_VELOCITY + 2)};
  V3 w{bodies(i, c + D_RATES), bodies(i, c + D_RATES + 1), bodies(i, c + D_RATES + 2)};
  double a = std::sqrt(w.x * w.x + w.y * w.y + w.z * w.z) * t;
  double k1, k2;
  if (a < 1e-2) {  // the series, to rounding (the closed forms cancel)
    double a2 = a * a;
    k1 = 0.5 - a2 / 24.0 * (1.0 - a2 / 30.0 * (1.0 - a2 / 56.0));
    k2 = 1.0 / 6.0 - a2 / 120.0 * (1.0 - a2 / 42.0 * (1.0 - a2 / 72.0));
  } else {
    k1 = (1.0 - std::cos(a)) / (a * a);
    k2 = (a - std::sin(a)) / (a * a * a);
  }
  V3 wv = cross(w, v);
  V3 wwv = cross(w, wv);
  double s1 = t * t * k1, s2 = t * t * t * k2;
  const double* q0 = &bodies(i, c + D_QUATERNION);
  V3 moved = turn(q0[0], q0[1], q0[2], q0[3], t * v.x + s1 * wv.x + s2 * wwv.x,
                  t * v.y + s1 * wv.y + s2 * wwv.y, t * v.z + s1 * wv.z + s2 * wwv.z, false);
  const double* q = y + state::quaternion(n, i);
  Products now = products(q[0], q[1], q[2], q[3]);
  V3 velocity = unit_turn(now, v.x, v.y, v.z, false);
  V3 acceleration = unit_turn(now, wv.x, wv.y, wv.z, false);
  y[state::position(n, i)] = bodies(i, c + D_POSITION) + moved.x;
  y[state::position(n, i) + 1] = bodies(i, c + D_POSITION + 1) + moved.y;
  y[state::position(n, i) + 2] = bodies(i, c + D_POSITION + 2) + moved.z;
  y[state::velocity(n, i)] = velocity.x;
  y[state::velocity(n, i) + 1] = velocity.y;
  y[state::velocity(n, i) + 2] = velocity.z;
  bodies(i, M_ACC) = acceleration.x;
  bodies(i, M_ACC + 1) = acceleration.y;
  bodies(i, M_ACC + 2) = acceleration.z;
}

}  // namespace

void place(double* y, const Mat& bodies, double offset) {
  idx n = bodies.rows;
  for (idx i = 0; i < n; ++i) {
    double kind = bodies(i, M_KIND);
    if (kind == KIND_CONSTANT) {
      constant(bodies, i, bodies(i, M_T0) + offset, y, n);
    } else if (kind == KIND_TABLE) {
      table(bodies, i, bodies(i, M_T0) + offset, y, n);
    } else if (kind == KIND_ARC) {
      arc(bodies, i, bodies(i, M_T0) + offset, y, n);
    }
  }
}

void set_time(const Mat& bodies, double t) {
  for (idx i = 0; i < bodies.rows; ++i) bodies(i, M_T0) = t;
}

void relative_state(const double* position, const double* velocity, const double* quaternion,
                    const double* rates, const double* ref_position, const double* ref_velocity,
                    const double* ref_quaternion, const double* ref_rates, double* out) {
  const double* qc = ref_quaternion;
  const double* qi = quaternion;
  double nc = std::sqrt(qc[0] * qc[0] + qc[1] * qc[1] + qc[2] * qc[2] + qc[3] * qc[3]);
  double ni = std::sqrt(qi[0] * qi[0] + qi[1] * qi[1] + qi[2] * qi[2] + qi[3] * qi[3]);
  double x = qc[0] / nc, yy = qc[1] / nc, z = qc[2] / nc, w = qc[3] / nc;
  Q4 rel = qmul(-x, -yy, -z, w, qi[0] / ni, qi[1] / ni, qi[2] / ni, qi[3] / ni);
  V3 d = {position[0] - ref_position[0], position[1] - ref_position[1],
          position[2] - ref_position[2]};
  V3 wc = turn(x, yy, z, w, ref_rates[0], ref_rates[1], ref_rates[2], false);
  double xi = qi[0] / ni, yi = qi[1] / ni, zi = qi[2] / ni, wi = qi[3] / ni;
  V3 wi_world = turn(xi, yi, zi, wi, rates[0], rates[1], rates[2], false);
  V3 carried = cross(wc, d);
  V3 v = {velocity[0] - ref_velocity[0] - carried.x, velocity[1] - ref_velocity[1] - carried.y,
          velocity[2] - ref_velocity[2] - carried.z};
  V3 p = turn(x, yy, z, w, d.x, d.y, d.z, true);
  v = turn(x, yy, z, w, v.x, v.y, v.z, true);
  V3 wr = turn(x, yy, z, w, wi_world.x - wc.x, wi_world.y - wc.y, wi_world.z - wc.z, true);
  for (int k = 0; k < 3; ++k) {
    out[sample::O_POSITION + k] = p[k];
    out[sample::O_VELOCITY + k] = v[k];
    out[sample::O_RATES + k] = wr[k];
  }
  out[sample::O_QUATERNION] = rel.x;
  out[sample::O_QUATERNION + 1] = rel.y;
  out[sample::O_QUATERNION + 2] = rel.z;
  out[sample::O_QUATERNION + 3] = rel.w;
}

void sample_relative(const double* y, const Mat& bodies, double* out, idx size) {
  idx n = bodies.rows;
  idx count = 0;
  for (idx i = 0; i < n; ++i)
    if (bodies(i, M_REF) > 0.0) ++count;
  idx o = size - sample::BODY * count;
  for (idx i = 0; i < n; ++i) {
    idx c = static_cast<idx>(bodies(i, M_REF)) - 1;
    if (c < 0) continue;
    relative_state(y + state::position(n, i), y + state::velocity(n, i),
                   y + state::quaternion(n, i), y + state::rates(n, i),
                   y + state::position(n, c), y + state::velocity(n, c),
                   y + state::quaternion(n, c), y + state::rates(n, c),
                   out + o);
    o += sample::BODY;
  }
}

}  // namespace motion
}  // namespace cfem
