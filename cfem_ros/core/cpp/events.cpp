// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Compiled with -ffp-contract=off (setup.py): see events.hpp. Includes no inline
// arithmetic of the other files (algebra.hpp): it calls their compiled functions.
#include "events.hpp"

#include <cmath>
#include <vector>

#include "braces.hpp"
#include "conditions.hpp"
#include "loads.hpp"
#include "sampling.hpp"
#include "step.hpp"

namespace cfem {

using locate_info::L_VIOLATION, locate_info::L_CODE, locate_info::L_VALUE,
    locate_info::L_CROSSING, locate_info::L_JOINTS, locate_info::L_STROKE,
    locate_info::L_WRENCHES;

namespace {

// What the search needs besides the system: the step's start, its scratch state and the
// values of the watched joints.
struct Search {
  const double* y0;
  const double* y1;  // the step's end (where an aero row's body ends up)
  double* ys;
  idx size;
  const System& s;
  const Work& v;
  const Triggers& t;
  double* values;  // (count, 3)
  double* info;
};

// Angle, distance and force of watched joints first .. first + count at y, into values
// (the release conditions' values); REACHED, SINGULAR or LOADS_NOT_FINITE.
int release_values(const Search& q, const double* y, idx first, idx count) {
  const Triggers& t = q.t;
  conditions(y, q.size, t.joints_i, t.joints_f, t.watch + first, count, q.values + 3 * first, 3);
  bool need = false;
  for (idx w = first; w < first + count; ++w) {
    q.values[3 * w + 2] = 0.0;
    if (std::isfinite(t.triggers(w, 2))) need = true;
  }
  if (!need) return REACHED;
  if (!joint_loads(y, q.s, q.v, q.v.force, q.v.moment)) return SINGULAR;
  for (idx j = 0; j < q.s.joints(); ++j)
    for (int k = 0; k < 3; ++k)
      if (!(std::isfinite(q.v.force[3 * j + k]) && std::isfinite(q.v.moment[3 * j + k])))
        return LOADS_NOT_FINITE;
  for (idx w = first; w < first + count; ++w) {
    const double* f = q.v.force + 3 * t.lines[w];
    q.values[3 * w + 2] = std::sqrt((f[0] * f[0] + f[1] * f[1]) + f[2] * f[2]);
  }
  return REACHED;
}

// The excess of a condition at rk4(y0, s) over its limit, and a code. col 0-2: watched
// joint which's angle, distance or force; col 3: scheduled row which's stroke. Each RK4
// raises the largest stage violation info[L_VIOLATION]. col 4: contact row which's
// CONTACT_GAP less the distance between its shapes. col 5: aero row which's crossing of
// its tables' ends (loads::aero_crossing). col 6: brace row which's change of contact
// (braces.hpp).
double excess(const Search& q, double s, idx which, int col, int* code) {
  const double* state = q.y0;
  *code = REACHED;
  if (s != 0.0) {
    double worst = rk4(q.y0, q.size, s, q.ys, q.s, q.v, false);
    if (worst < 0.0) {
      *code = SINGULAR;
      return NAN;
    }
    if (worst > q.info[L_VIOLATION]) q.info[L_VIOLATION] = worst;
    state = q.ys;
  }
  if (col == 3) {
    return loads::point_and_stroke(state, q.s.loads, which, q.s.n(), nullptr)
           - q.s.loads(which, loads::S_STROKE);
  }
  if (col == 5) return loads::aero_crossing(state, q.y1, q.s.loads, which, q.s.n());
  if (col == 4) {   // a contact pair: >= 0 once its shapes are within CONTACT_GAP
    return loads::CONTACT_GAP - loads::contact_gap(state, q.s.loads, which, q.s.n(), nullptr);
  }
  if (col == 6) return braces::excess(state, q.s.loads, which, q.s.n());   // a brace's pad
  *code = release_values(q, state, which, 1);
  if (*code != REACHED) return NAN;
  return q.values[3 * which + col] - q.t.triggers(which, col);
}

// The root in [0, h] of ``excess`` as scipy's brentq finds it (its brentq.c, operation
// for operation, with the crossing's tolerances); the code NAN_VALUE, SAME_SIGNS or
// NO_CONVERGENCE for its errors (the abscissa it names), or a failure of the excess.
double brentq(const Search& q, double h, idx which, int col, int* code) {
  const double xtol = CROSSING_XTOL, rtol = CROSSING_RTOL;
  double xpre = 0.0, xcur = h;
  double xblk = 0.0, fblk = 0.0, spre = 0.0, scur = 0.0;
  double fpre = excess(q, xpre, which, col, code);
  if (*code != REACHED) return xpre;
  if (std::isnan(fpre)) {
    *code = NAN_VALUE;
    return xpre;
  }
  double fcur = excess(q, xcur, which, col, code);
  if (*code != REACHED) return xcur;
  if (std::isnan(fcur)) {
    *code = NAN_VALUE;
    return xcur;
  }
  if (fpre * fcur > 0) {
    *code = SAME_SIGNS;
    return xcur;
  }
  if (fpre == 0) return xpre;
  if (fcur == 0) return xcur;
  for (int iter = 0; iter < CROSSING_MAXITER; ++iter) {
    if (fpre * fcur < 0) {
      xblk = xpre, fblk = fpre;
      spre = scur = xcur - xpre;
    }
    if (std::fabs(fblk) < std::fabs(fcur)) {
      // Python's xpre, xcur, xblk = xcur, xblk, xcur (and the same for f)
      double x_old = xcur, f_old = fcur;
      xpre = x_old, xcur = xblk, xblk = x_old;
      fpre = f_old, fcur = fblk, fblk = f_old;
    }
    double delta = (xtol + rtol * std::fabs(xcur)) / 2;
    double sbis = (xblk - xcur) / 2;
    if (fcur == 0 || std::fabs(sbis) < delta) return xcur;
    if (std::fabs(spre) > delta && std::fabs(fcur) < std::fabs(fpre)) {
      double stry;
      if (xpre == xblk) {
        stry = -fcur * (xcur - xpre) / (fcur - fpre);  // interpolate
      } else {
        double dpre = (fpre - fcur) / (xpre - xcur);  // extrapolate
        double dblk = (fblk - fcur) / (xblk - xcur);
        stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre));
      }
      double bound = std::fabs(spre);  // Python's min(abs(spre), 3 |sbis| - delta)
      if (3 * std::fabs(sbis) - delta < bound) bound = 3 * std::fabs(sbis) - delta;
      if (2 * std::fabs(stry) < bound) {
        spre = scur, scur = stry;  // good short step
      } else {
        spre = scur = sbis;  // bisect
      }
    } else {
      spre = scur = sbis;  // bisect
    }
    xpre = xcur, fpre = fcur;
    if (std::fabs(scur) > delta) {
      xcur += scur;
    } else {
      xcur += sbis > 0 ? delta : -delta;
    }
    fcur = excess(q, xcur, which, col, code);
    if (*code != REACHED) return xcur;
    if (std::isnan(fcur)) {
      *code = NAN_VALUE;
      return xcur;
    }
  }
  *code = NO_CONVERGENCE;
  return xcur;
}

}  // namespace

void locate(double* y0, idx size, double h, double* y1, double* ys, const System& s,
            const Work& v, const Triggers& t, idx* joints_found, idx* wrenches_found,
            double* info) {
  const idx n = s.n();
  std::vector<double> values(3 * t.count, 0.0);
  Search q{y0, y1, ys, size, s, v, t, values.data(), info};
  info[L_CODE] = REACHED;
  info[L_CROSSING] = NAN;
  info[L_JOINTS] = 0.0;
  info[L_STROKE] = NAN;
  info[L_WRENCHES] = 0.0;
  double worst = rk4(y0, size, h, y1, s, v, false);
  if (worst < 0.0) {
    info[L_CODE] = SINGULAR;
    return;
  }
  if (worst > info[L_VIOLATION]) info[L_VIOLATION] = worst;
  int code;
  // the release conditions
  if (t.count > 0) {
    code = release_values(q, y1, 0, t.count);
    if (code != REACHED) {
      info[L_CODE] = code;
      return;
    }
    std::vector<char> reached(3 * t.count);
    bool anything = false;
    for (idx w = 0; w < t.count; ++w) {
      for (int col = 0; col < 3; ++col) {
        reached[3 * w + col] = values[3 * w + col] >= t.triggers(w, col);
        anything = anything || reached[3 * w + col];
      }
    }
    if (anything) {
      double best = h;
      idx count = 0;
      for (idx w = 0; w < t.count; ++w) {
        for (int col = 0; col < 3; ++col) {
          if (!reached[3 * w + col]) continue;
          double at0 = excess(q, 0.0, w, col, &code);
          if (code != REACHED) {
            info[L_CODE] = code;
            info[L_VALUE] = 0.0;
            return;
          }
          double at = 0.0;
          if (!(at0 >= 0.0)) {
            at = brentq(q, h, w, col, &code);
            if (code == SAME_SIGNS) continue;  // not reached by the search's own values
            if (code != REACHED) {
              info[L_CODE] = code;
              info[L_VALUE] = at;
              return;
            }
          }
          if (at < best - 1e-15) {
            best = at, count = 1;
            joints_found[0] = t.watch[w], joints_found[1] = col;
          } else if (std::fabs(at - best) <= 1e-15) {
            bool known = false;
            for (idx i = 0; i < count; ++i) known = known || joints_found[2 * i] == t.watch[w];
            if (!known) {
              joints_found[2 * count] = t.watch[w], joints_found[2 * count + 1] = col;
              ++count;
            }
          }
        }
      }
      if (count > 0) info[L_CROSSING] = best, info[L_JOINTS] = static_cast<double>(count);
    }
  }
  // the ejectors' stroke ends, the contacts of armed pairs (ScheduledLoads.arm), the
  // tables' ends (aero rows) and the braces' pads touching or letting go, all reported by
  // row in wrenches_found
  double best = h;
  idx count = -1;
  for (idx row = n; row < s.loads.rows; ++row) {
    double kind = s.loads(row, loads::S_KIND);
    if (kind == loads::KIND_TABLE || kind == loads::KIND_SCRATCH) break;  // the tables
    int col;
    if (kind == loads::KIND_SCHEDULED) {
      double limit = s.loads(row, loads::S_STROKE);
      if (!(s.loads(row, loads::S_ON) > 0.0 && std::isfinite(limit)
            && loads::point_and_stroke(y1, s.loads, row, n, nullptr) >= limit))
        continue;
      col = 3;
    } else if (kind == loads::KIND_CONTACT) {
      if (!(s.loads(row, loads::S_ON) > 0.0
            && loads::contact_gap(y1, s.loads, row, n, nullptr) <= loads::CONTACT_GAP))
        continue;
      col = 4;
    } else if (kind == loads::KIND_AERO) {
      if (!loads::aero_moved(y1, s.loads, row, n)) continue;
      col = 5;
    } else if (kind == loads::KIND_BRACE) {
      if (!braces::switched(y1, s.loads, row, n)) continue;
      col = 6;
    } else {
      continue;
    }
    double at0 = excess(q, 0.0, row, col, &code);
    double at = 0.0;
    if (!(at0 >= 0.0)) {
      at = brentq(q, h, row, col, &code);
      // A contact's distance starts from the last one's guess, so that at the step's end it
      // can differ in the last bits from the check above: a grazing touch that the search
      // does not find at h is not reached in this step (the next step's start tells).
      if (code == SAME_SIGNS) continue;
      if (code != REACHED) {
        info[L_CODE] = code;
        info[L_VALUE] = at;
        return;
      }
    }
    if (count < 0) count = 0;
    if (at < best - 1e-15) {
      best = at, count = 1;
      wrenches_found[0] = row - n;
    } else if (std::fabs(at - best) <= 1e-15) {
      wrenches_found[count] = row - n;
      ++count;
    }
  }
  if (count >= 0) info[L_STROKE] = best, info[L_WRENCHES] = static_cast<double>(count);
  // the state where the step is cut: the stroke end, unless a release comes first
  double release = info[L_CROSSING], stroke = info[L_STROKE];
  double cut = (!std::isnan(stroke) && !(release < stroke)) ? stroke : release;
  if (cut < h) {
    worst = rk4(y0, size, cut, ys, s, v, false);
    if (worst < 0.0) {
      info[L_CODE] = SINGULAR;
      info[L_VALUE] = cut;
      return;
    }
    if (worst > info[L_VIOLATION]) info[L_VIOLATION] = worst;
  }
}

}  // namespace cfem
