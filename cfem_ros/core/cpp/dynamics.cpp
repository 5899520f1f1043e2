// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
#include "dynamics.hpp"

#include <cmath>

#include "algebra.hpp"
#include "loads.hpp"
#include "motion.hpp"
#include "solve.hpp"

namespace cfem {

namespace {

// out (row stride so) [0:3, 0:3] = rot @ B @ rot^T, B the 9 numbers at src.
inline void body_congruence(const double* rot, const double* src, double* out, idx so) {
  for (int r = 0; r < 3; ++r) {
    double t0 = rot[3 * r] * src[0] + rot[3 * r + 1] * src[3] + rot[3 * r + 2] * src[6];
    double t1 = rot[3 * r] * src[1] + rot[3 * r + 1] * src[4] + rot[3 * r + 2] * src[7];
    double t2 = rot[3 * r] * src[2] + rot[3 * r + 1] * src[5] + rot[3 * r + 2] * src[8];
    for (int c = 0; c < 3; ++c)
      out[r * so + c] = t0 * rot[3 * c] + t1 * rot[3 * c + 1] + t2 * rot[3 * c + 2];
  }
}

}  // namespace

void body_terms(const double* y, const System& s, const Work& v, bool need_inverse) {
  const idx n = s.n();
  const Mat& bodies = s.bodies;
  for (idx i = 0; i < n; ++i) {
    idx o = state::quaternion(n, i);
    double* rot = v.rot + 9 * i;
    quat_matrix(y[o], y[o + 1], y[o + 2], y[o + 3], rot);
    o = state::rates(n, i);
    V3 w = rotate(rot, y[o], y[o + 1], y[o + 2]);
    v.omega[3 * i] = w.x;
    v.omega[3 * i + 1] = w.y;
    v.omega[3 * i + 2] = w.z;
    double* fh = v.fhat + 6 * i;
    if (bodies(i, motion::B_INV_MASS) == 0.0) {
      // fixed or kinematic: its rows need its rotation and rates only (its mass terms,
      // never written, stay the workspace's zeros; its load is reset for the scheduled
      // wrenches, which may act on it)
      for (int k = 0; k < 6; ++k) fh[k] = 0.0;
      continue;
    }
    const double* body = bodies.row(i);
    if (need_inverse) body_congruence(rot, body + motion::B_INV_INERTIA, v.inv_inertia + 9 * i, 3);
    double* mh = v.mhat + 36 * i;
    for (int k = 0; k < 36; k += LANES) store(mh + k, Pack{});
    double mass = body[motion::B_MASS];
    mh[0] = mh[7] = mh[14] = mass;
    body_congruence(rot, body + motion::B_INERTIA, mh + 21, 6);
    const double* held = s.loads.row(i);
    const double* hf = held + loads::H_FORCE;
    const double* ht = held + loads::H_TORQUE;
    double force[3] = {hf[0], hf[1], hf[2]};
    double torque[3] = {ht[0], ht[1], ht[2]};
    if (held[loads::H_AXES] > 0.0) {
      V3 f = rotate(rot, force[0], force[1], force[2]);
      V3 t = rotate(rot, torque[0], torque[1], torque[2]);
      force[0] = f.x, force[1] = f.y, force[2] = f.z;
      torque[0] = t.x, torque[1] = t.y, torque[2] = t.z;
    }
    loads::held_moment(rot, s.loads, i, force, torque);  // loads at points
    V3 spin = {mh[21] * w.x + mh[22] * w.y + mh[23] * w.z,
               mh[27] * w.x + mh[28] * w.y + mh[29] * w.z,
               mh[33] * w.x + mh[34] * w.y + mh[35] * w.z};
    V3 gyro = cross(w, spin);
    for (int k = 0; k < 3; ++k) {
      fh[k] = mass * s.gravity[k] + force[k];
      fh[3 + k] = torque[k] - gyro[k];
    }
  }
  if (s.loads.rows > n) loads::add_scheduled(y, v.rot, bodies, s.loads, v.fhat);
}

namespace {

// The terms of a joint point that the joint's translation rows share: where the point
// is on b (rho_b) and from a's CG (t1), the separation d, its rate and the centripetal
// acceleration.
struct Point {
  V3 rho_b, t1, d, d_dot, centripetal;
};

// Not inlined: the point is then kept in memory and read by each of its rows, instead
// of being held in registers across every row and spilled at each.
__attribute__((noinline)) void joint_point(const double* y, idx n, const Work& v, idx a, idx b,
                                           const double* rf, const V3& wa, Point& q) {
  V3 wb = {v.omega[3 * b], v.omega[3 * b + 1], v.omega[3 * b + 2]};
  V3 rho_a = rotate(v.rot + 9 * a, rf[3], rf[4], rf[5]);
  V3 rho_b = rotate(v.rot + 9 * b, rf[6], rf[7], rf[8]);
  const double* cg_a = y + state::position(n, a);
  const double* cg_b = y + state::position(n, b);
  V3 pa = {cg_a[0], cg_a[1], cg_a[2]};
  V3 t1 = {cg_b[0] + rho_b.x - pa.x, cg_b[1] + rho_b.y - pa.y, cg_b[2] + rho_b.z - pa.z};
  q.rho_b = rho_b;
  q.t1 = t1;
  q.d = {t1.x - rho_a.x, t1.y - rho_a.y, t1.z - rho_a.z};
  V3 vb = cross(wb, rho_b);
  V3 va = cross(wa, rho_a);
  const double* vel_a = y + state::velocity(n, a);
  const double* vel_b = y + state::velocity(n, b);
  q.d_dot = {vel_b[0] + vb.x - vel_a[0] - va.x, vel_b[1] + vb.y - vel_a[1] - va.y,
             vel_b[2] + vb.z - vel_a[2] - va.z};
  V3 cb = cross(wb, vb), ca = cross(wa, va);
  q.centripetal = {cb.x - ca.x, cb.y - ca.y, cb.z - ca.z};
}

}  // namespace

void row_terms(const double* y, const System& s, const Work& v, bool dense, bool full) {
  const idx n = s.n(), m = s.m();
  const bool kinematic = motion::any(s.bodies);
  full = full || dense || kinematic;
  const double eta = s.eta;
  Point point = {};
  for (idx r = 0; r < m; ++r) {
    idx a = s.rows_i(r, 0), b = s.rows_i(r, 1), kind = s.rows_i(r, 2);
    const double* rf = s.rows_f.row(r);
    double* jac = v.jac + 12 * r;
    V3 wa = {v.omega[3 * a], v.omega[3 * a + 1], v.omega[3 * a + 2]};
    V3 e = rotate(v.rot + 9 * a, rf[0], rf[1], rf[2]);
    double value, rate, gamma;
    if (kind) {
      // the joint point's terms, shared by a joint's translation rows
      if (kind == 1) joint_point(y, n, v, a, b, rf, wa, point);
      const V3& t1 = point.t1;
      const V3& d = point.d;
      const V3& d_dot = point.d_dot;
      const V3& centripetal = point.centripetal;
      V3 wa_e = cross(wa, e);
      for (int k = 0; k < 3; ++k) {
        jac[k] = -e[k];
        jac[6 + k] = e[k];
      }
      if (full) {  // the rotation columns, which the tree solve does not read
        V3 t1e = cross(t1, e);
        V3 rbe = cross(point.rho_b, e);
        for (int k = 0; k < 3; ++k) {
          jac[3 + k] = -t1e[k];
          jac[9 + k] = rbe[k];
        }
      }
      // dot_yx: the products rounded as the earlier kernel rounded them (algebra.hpp)
      value = dot_yx(d, e);
      rate = dot_yx(e, d_dot) + dot_yx(d, wa_e);
      // centripetal terms: wb x (wb x rho_b) - wa x (wa x rho_a)
      gamma = 2.0 * dot_yx(wa_e, d_dot) + dot_yx(e, centripetal) + dot_yx(d, cross(wa, wa_e));
    } else {
      V3 wb = {v.omega[3 * b], v.omega[3 * b + 1], v.omega[3 * b + 2]};
      V3 f = rotate(v.rot + 9 * b, rf[3], rf[4], rf[5]);
      V3 c = cross(f, e);
      V3 rel = {wb.x - wa.x, wb.y - wa.y, wb.z - wa.z};
      for (int k = 0; k < 3; ++k) {
        jac[k] = 0.0;
        jac[3 + k] = -c[k];
        jac[6 + k] = 0.0;
        jac[9 + k] = c[k];
      }
      value = dot(e, f);
      rate = dot(rel, c);
      gamma = dot(rel, cross(cross(wb, f), e)) + dot(rel, cross(f, cross(wa, e)));
    }
    v.value[r] = value;
    v.rate[r] = rate;
    v.gamma[r] = gamma;
    v.rhs[r] = -gamma - 2.0 * eta * rate - eta * eta * value;
    if (kinematic) v.rhs[r] -= motion::known(jac, s.bodies, a, b);  // known accelerations
    if (dense) {
      double* wt = v.weighted + 12 * r;
      for (int side = 0; side < 2; ++side) {
        idx body = side == 0 ? a : b;
        int base = 6 * side;
        for (int k = 0; k < 3; ++k) wt[base + k] = s.bodies(body, motion::B_INV_MASS) * jac[base + k];
        const double* inv = v.inv_inertia + 9 * body;
        for (int k = 0; k < 3; ++k)
          wt[base + 3 + k] = inv[3 * k] * jac[base + 3] + inv[3 * k + 1] * jac[base + 4]
                             + inv[3 * k + 2] * jac[base + 5];
      }
    }
  }
}

bool solve(const double* y, const System& s, const Work& v) {
  body_terms(y, s, v, s.dense > 0);
  row_terms(y, s, v, s.dense > 0, false);
  if (s.dense > 0) return dense_solve(s, v, s.dense > 1);
  for (idx i = 0; i < s.n(); ++i) {
    if (s.roots[i] == 2) {  // a free body on its own: a = M^-1 f directly
      double* inv = v.inv_inertia + 9 * i;
      body_congruence(v.rot + 9 * i, s.bodies.row(i) + motion::B_INV_INERTIA, inv, 3);
      const double* f = v.fhat + 6 * i;
      double* acc = v.acc + 6 * i;
      for (int k = 0; k < 3; ++k) {
        acc[k] = s.bodies(i, motion::B_INV_MASS) * f[k];
        acc[3 + k] = inv[3 * k] * f[3] + inv[3 * k + 1] * f[4] + inv[3 * k + 2] * f[5];
      }
    }
  }
  return tree_solve(y, s, v);
}

double derivative(const double* y, double* dy, const System& s, const Work& v, bool solved,
                  bool largest) {
  const idx n = s.n();
  if (!solved && !solve(y, s, v)) return -1.0;
  const bool kinematic = motion::any(s.bodies);
  for (idx i = 0; i < n; ++i) {
    idx o = state::quaternion(n, i);
    const double* rot = v.rot + 9 * i;
    const double* acc = v.acc + 6 * i;
    const double* rates = y + state::rates(n, i);
    double w0 = rates[0], w1 = rates[1], w2 = rates[2];
    for (int k = 0; k < 3; ++k) {
      dy[state::position(n, i) + k] = y[state::velocity(n, i) + k];
      dy[state::velocity(n, i) + k] = acc[k];
      // body-axis angular acceleration: R^T alpha_world
      dy[state::rates(n, i) + k] = rot[k] * acc[3] + rot[3 + k] * acc[4] + rot[6 + k] * acc[5];
    }
    if (kinematic && s.bodies(i, motion::M_KIND) > 0.0)
      motion::derivative(s.bodies, i, v.rot, dy, n);  // a kinematic body's own
    // dq/dt = q * (w, 0) / 2, scalar last
    dy[o + 0] = 0.5 * (y[o + 3] * w0 + y[o + 1] * w2 - y[o + 2] * w1);
    dy[o + 1] = 0.5 * (y[o + 3] * w1 + y[o + 2] * w0 - y[o + 0] * w2);
    dy[o + 2] = 0.5 * (y[o + 3] * w2 + y[o + 0] * w1 - y[o + 1] * w0);
    dy[o + 3] = -0.5 * (y[o + 0] * w0 + y[o + 1] * w1 + y[o + 2] * w2);
  }
  double worst = 0.0;
  for (idx r = 0; largest && r < s.m(); ++r) {
    double a = std::fabs(v.value[r]);
    if (a > worst) worst = a;
  }
  return worst;
}

}  // namespace cfem
