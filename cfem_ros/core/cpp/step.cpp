// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
#include "step.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "algebra.hpp"
#include "conditions.hpp"
#include "dynamics.hpp"
#include "loads.hpp"
#include "motion.hpp"
#include "sampling.hpp"

namespace cfem {

using advance_info::I_T, advance_info::I_STEPS, advance_info::I_VIOLATION,
    advance_info::I_RESULT, advance_info::I_DIVERGENCE, advance_info::I_VALUE;

namespace {

// out = y + c k, number by number (LANES at a time: each lane rounded as one by one).
inline void stage_sum(const double* y, double c, const double* k, idx size, double* out) {
  idx j = 0;
  for (; j + LANES <= size; j += LANES) store(out + j, load(y + j) + c * load(k + j));
  for (; j < size; ++j) out[j] = y[j] + c * k[j];
}

// Whether every number is finite: x - x is 0 for a finite x, NaN for an infinite or NaN
// one, and a sum of them NaN if any is.
inline bool all_finite(const double* x, idx size) {
  Pack sum = {};
  idx j = 0;
  for (; j + LANES <= size; j += LANES) sum += load(x + j) - load(x + j);
  double total = 0.0;
  for (int k = 0; k < LANES; ++k) total += sum[k];
  for (; j < size; ++j) total += x[j] - x[j];
  return total == 0.0;
}

}  // namespace

double rk4(const double* y, idx size, double h, double* out, const System& s, const Work& v,
           bool solved) {
  const idx n = s.n();
  double* stages = v.stages;
  double* stage = stages + 4 * size;
  const bool scheduled = s.loads.rows > n;
  const bool kinematic = motion::any(s.bodies);
  double worst = 0.0;
  for (int k = 0; k < 4; ++k) {
    double offset = k == 0 ? 0.0 : (k < 3 ? 0.5 * h : h);
    if (scheduled) loads::stage_time(s.loads, n, offset);  // stage time of scheduled wrenches
    if (kinematic) motion::place(k == 0 ? const_cast<double*>(y) : stage, s.bodies, offset);
    // the violation is the step's start's: the other stages' is not needed
    double w = derivative(k == 0 ? y : stage, stages + k * size, s, v, solved && k == 0, k == 0);
    if (w < 0.0) return -1.0;
    if (k == 0) worst = w;
    if (k < 3) {
      double c = k < 2 ? 0.5 * h : h;
      stage_sum(y, c, stages + k * size, size, stage);
    }
  }
  const double* k1 = stages;
  const double* k2 = stages + size;
  const double* k3 = stages + 2 * size;
  const double* k4 = stages + 3 * size;
  const double sixth = h / 6.0;
  idx j = 0;
  for (; j + LANES <= size; j += LANES) {
    Pack sum = load(k1 + j) + 2.0 * load(k2 + j) + 2.0 * load(k3 + j) + load(k4 + j);
    store(out + j, load(y + j) + sixth * sum);
  }
  for (; j < size; ++j) out[j] = y[j] + sixth * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
  for (idx i = 0; i < n; ++i) {
    double* q = out + state::quaternion(n, i);
    double scale = 1.0 / std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int k = 0; k < 4; ++k) q[k] *= scale;
  }
  if (kinematic) motion::place(out, s.bodies, h);  // kinematic bodies at the step's end
  return worst;
}

void advance(double* y, idx size, double* info, double t_target, double due, double limit,
             double dt, const System& s, const Work& v, const Watch& watch, const Grid& g) {
  const idx n = s.n();
  double* out = v.stages + 5 * size;
  std::vector<double> values(2 * watch.count);
  bool need_force = false;
  for (idx w = 0; w < watch.count; ++w)
    if (watch.limits(w, 2) < INFINITY) need_force = true;
  double t = info[I_T];
  info[I_RESULT] = REACHED;
  double* grid = g.grid;
  const double rate = grid[0];
  const Mat& samples = g.samples;
  const idx k = g.order_count;
  // the workspace holds the solve at y (a sample's or a force check's joint loads): the
  // next step's first stage uses it instead of solving again
  bool fresh = false;
  while (true) {
    double goal = t_target;
    if (rate > 0.0) {
      double at = grid[1] / rate;
      if (t >= at) {
        idx taken = static_cast<idx>(grid[2]);
        if (taken == samples.rows) {
          info[I_RESULT] = ROWS_FULL;
          return;
        }
        if (samples.cols > 0) {
          int code = sample_outputs(y, s, v, g.order, k, samples.row(taken), samples.cols);
          if (code != REACHED) {
            info[I_RESULT] = code;
            return;
          }
          if (k > 0) {
            // a sample never shows a state beyond the tolerance (the steps check the
            // state they start from, so a sample's would come late)
            double worst = 0.0;
            for (idx r = 0; r < s.m(); ++r) worst = std::max(worst, std::fabs(v.value[r]));
            if (worst > info[I_DIVERGENCE]) {
              info[I_RESULT] = VIOLATION;
              info[I_VALUE] = worst;
              return;
            }
          }
        }
        fresh = samples.cols > 0 && k > 0;
        grid[1] += 1.0;
        grid[2] += 1.0;
        continue;
      }
      goal = std::min(goal, at);
    }
    if (t >= due) return;  // a release is due now, after the samples at t
    if (t >= t_target) return;
    while (t < goal) {
      double remaining = goal - t;
      double h, t_end;
      if (remaining <= dt * (1.0 + 1e-9)) {
        h = remaining, t_end = goal;
      } else {
        h = dt, t_end = t + dt;
      }
      if (due < t_end) h = due - t, t_end = due;
      if (t_end > limit) return;
      double worst = rk4(y, size, h, out, s, v, fresh);
      fresh = false;
      if (worst < 0.0) {
        info[I_RESULT] = SINGULAR;
        return;
      }
      if (watch.count > 0) {
        conditions(out, size, watch.joints_i, watch.joints_f, watch.watch, watch.count,
                   values.data(), 2);
        if (need_force && !joint_loads(out, s, v, v.force, v.moment)) {
          info[I_RESULT] = SINGULAR;
          return;
        }
        for (idx w = 0; w < watch.count; ++w) {
          double magnitude = 0.0;
          if (need_force) {
            const double* f = v.force + 3 * watch.lines[w];
            magnitude = std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
            if (!std::isfinite(magnitude)) {
              info[I_RESULT] = LOADS_NOT_FINITE;
              return;
            }
          }
          if (values[2 * w] >= watch.limits(w, 0) || values[2 * w + 1] >= watch.limits(w, 1)
              || magnitude >= watch.limits(w, 2)) {
            info[I_RESULT] = CONDITION;
            return;
          }
        }
      }
      if (s.loads.rows > n && loads::stroke_reached(out, s.loads, n)) {  // a stroke ends
        info[I_RESULT] = CONDITION;
        return;
      }
      if (!all_finite(out, size)) {
        info[I_RESULT] = NOT_FINITE;
        return;
      }
      if (worst > info[I_DIVERGENCE]) {
        info[I_RESULT] = VIOLATION;
        info[I_VALUE] = worst;
        return;
      }
      info[I_VIOLATION] = std::max(info[I_VIOLATION], worst);
      std::copy(out, out + size, y);
      fresh = need_force;
      t = t_end;
      info[I_T] = t;
      if (s.loads.rows > n) loads::set_time(s.loads, n, t);
      if (motion::any(s.bodies)) motion::set_time(s.bodies, t);
      info[I_STEPS] += 1;
      if (t_end >= due) break;  // the samples at t first (loop top), then back for the release
    }
  }
}

}  // namespace cfem
