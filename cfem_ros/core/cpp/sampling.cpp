// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
#include "sampling.hpp"

#include <cmath>

#include "algebra.hpp"
#include "dynamics.hpp"
#include "loads.hpp"
#include "motion.hpp"
#include "solve.hpp"

namespace cfem {

bool joint_loads(const double* y, const System& s, const Work& v, double* force,
                 double* moment) {
  if (!solve(y, s, v)) return false;
  for (idx j = 0; j < s.joints(); ++j) {
    idx c = s.plan(j, P_CHILD);
    double sign = static_cast<double>(s.plan(j, P_SIGN));
    idx b = sign > 0 ? c : s.plan(j, P_PARENT);
    double* wrench = v.wrench + 6 * j;
    if (s.dense == 0) {
      // the tree child's balance: load = M^ a - f^ (articulated)
      const double* mh = v.mhat + 36 * c;
      const double* acc = v.acc + 6 * c;
      for (int k = 0; k < 6; ++k) {
        double total = -v.fhat[6 * c + k];
        for (int i = 0; i < 6; ++i) total += mh[6 * k + i] * acc[i];
        wrench[k] = total;
      }
    }
    const double* rf = s.rows_f.row(s.plan(j, P_ROW));
    V3 rho0 = rotate(v.rot + 9 * b, rf[6], rf[7], rf[8]);
    const double* cb = y + state::position(s.n(), b);
    const double* cc = y + state::position(s.n(), c);
    V3 rho = {rho0.x + cb[0] - cc[0], rho0.y + cb[1] - cc[1], rho0.z + cb[2] - cc[2]};
    V3 f = {sign * wrench[0], sign * wrench[1], sign * wrench[2]};
    V3 arm = cross(rho, f);
    for (int k = 0; k < 3; ++k) {
      force[3 * j + k] = f[k];
      moment[3 * j + k] = sign * wrench[3 + k] - arm[k];
    }
  }
  return true;
}

int sample_outputs(const double* y, const System& s, const Work& v, const idx* order, idx k,
                   double* out, idx size) {
  const idx n = s.n();
  for (idx i = 0; i < n; ++i) {
    idx o = sample::BODY * i, q = state::quaternion(n, i);
    double norm = std::sqrt(y[q] * y[q] + y[q + 1] * y[q + 1] + y[q + 2] * y[q + 2]
                            + y[q + 3] * y[q + 3]);
    Products p = products(y[q] / norm, y[q + 1] / norm, y[q + 2] / norm, y[q + 3] / norm);
    // R^T v with R the body-to-world matrix of the unit quaternion; its first entry, R's
    // first column . v, summed as the earlier kernel rounded it (dot_yx, algebra.hpp)
    const double* cg_velocity = y + state::velocity(n, i);
    V3 velocity = {cg_velocity[0], cg_velocity[1], cg_velocity[2]};
    V3 body = unit_turn(p, velocity.x, velocity.y, velocity.z, true);
    body.x = dot_yx({1 - 2 * (p.yy + p.zz), 2 * (p.xy + p.wz), 2 * (p.xz - p.wy)}, velocity);
    for (int c = 0; c < 3; ++c) {
      out[o + sample::O_POSITION + c] = y[state::position(n, i) + c];
      out[o + sample::O_RATES + c] = y[state::rates(n, i) + c];
    }
    for (int c = 0; c < 4; ++c) out[o + sample::O_QUATERNION + c] = y[q + c];
    out[o + sample::O_VELOCITY] = body.x;
    out[o + sample::O_VELOCITY + 1] = body.y;
    out[o + sample::O_VELOCITY + 2] = body.z;
  }
  if (s.loads.rows > n)  // the scheduled wrenches' applied loads, after the joints'
    loads::sample_applied(y, s.bodies, s.loads, out + sample::BODY * n + sample::JOINT * k,
                          v.sample_rot, v.sample_wrench);
  if (motion::any(s.bodies)) motion::sample_relative(y, s.bodies, out, size);  // last
  if (k == 0) return REACHED;
  if (!joint_loads(y, s, v, v.force, v.moment)) return SINGULAR;
  for (idx j = 0; j < k; ++j) {
    idx o = sample::BODY * n + sample::JOINT * j;
    for (int c = 0; c < 3; ++c) {
      out[o + sample::O_FORCE + c] = v.force[3 * order[j] + c];
      out[o + sample::O_MOMENT + c] = v.moment[3 * order[j] + c];
    }
  }
  // the state is finite (every step checks it); its loads may still not be
  for (idx j = sample::BODY * n; j < sample::BODY * n + sample::JOINT * k; ++j)
    if (!std::isfinite(out[j])) return LOADS_NOT_FINITE;
  return REACHED;
}

idx sample_size(const System& s, idx k) {
  const idx n = s.n();
  idx size = sample::BODY * n + sample::JOINT * k;
  if (s.loads.rows > n) size += loads::applied_size(s.bodies, s.loads);
  if (motion::any(s.bodies))
    for (idx i = 0; i < n; ++i)
      if (s.bodies(i, motion::M_REF) > 0.0) size += sample::BODY;   // motion::sample_relative
  return size;
}

bool project(const double* y, const System& s, const Work& v, double* delta) {
  const idx n = s.n(), m = s.m();
  body_terms(y, s, v, true);
  row_terms(y, s, v, s.dense > 0);
  for (idx k = 0; k < 6 * n; ++k) v.fhat[k] = 0.0;
  for (idx r = 0; r < m; ++r) {
    idx a = s.rows_i(r, 0), b = s.rows_i(r, 1);
    const double* jac = v.jac + 12 * r;
    double total = 0.0;
    for (int k = 0; k < 3; ++k)
      total += jac[k] * y[state::velocity(n, a) + k] + jac[3 + k] * v.omega[3 * a + k]
               + jac[6 + k] * y[state::velocity(n, b) + k] + jac[9 + k] * v.omega[3 * b + k];
    v.rhs[r] = -total;
  }
  if (s.dense > 0) {
    if (!dense_solve(s, v, true)) return false;
  } else {
    for (idx k = 0; k < 6 * n; ++k) v.acc[k] = 0.0;
    if (!tree_solve(y, s, v)) return false;
  }
  for (idx k = 0; k < twist::WIDTH * n; ++k) delta[k] = v.acc[k];   // as acc: layout.hpp
  return true;
}

void row_jacobian(const double* y, const System& s, const Work& v) {
  body_terms(y, s, v, true);
  row_terms(y, s, v, true);
}

}  // namespace cfem
