// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Least distances between samples (SPEC section 15; cfem_ros.study.between describes the
// method): a body's cubic Hermite interpolant between its samples (Track), the bound on
// how fast a distance between two bodies changes in a sample interval (interval_rate),
// and the search of a window for the least of a distance (Search: the rate bound prunes
// intervals, PROBES points probe those left, the bound prunes the probed pieces, and
// bounded Brent closes on each least left). The distance is any callable
// (double(idx interval, double time)); between.cpp binds those of two shapes and of two
// sets of points.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "common.hpp"

namespace cfem {
namespace between {

// How close the least found comes to the interpolant's least, m (Brent's time tolerance
// is this over the interval's rate bound).
constexpr double DISTANCE_TOLERANCE = 1e-9;
// A distance between samples replaces the least sample only below it by more than this, m.
constexpr double GAIN = 1e-12;
// Points tried in a sample interval before the bounded minimisation.
constexpr int PROBES = 8;
// Sample times within this of a window's edge are in it, s.
constexpr double EDGE = 0.5e-9;

// One body's samples (n rows of track::WIDTH, layout.hpp) at times t (n,): the cubic
// Hermite interpolant of position and quaternion from their values and rates.
static_assert(track::T_QUATERNION == track::T_POSITION + 3
                  && track::T_VELOCITY == track::T_POSITION + track::RATES
                  && track::T_QUATERNION_RATE == track::T_QUATERNION + track::RATES,
              "a track row: the VALUES values, then their rates in the same order");
struct Track {
  const double* t = nullptr;
  Mat rows;

  // Position (3) and unit quaternion (4, x y z w) at time in [t[k], t[k + 1]] into pose.
  void pose(idx k, double time, double* pose) const {
    const double start = t[k], h = t[k + 1] - t[k];
    const double s = (time - start) / h, s2 = s * s, s3 = s2 * s;
    const double b0 = 2 * s3 - 3 * s2 + 1, b1 = (s3 - 2 * s2 + s) * h, b2 = -2 * s3 + 3 * s2,
                 b3 = (s3 - s2) * h;
    const double *v0 = rows.row(k), *v1 = rows.row(k + 1);
    for (int c = 0; c < track::VALUES; ++c)
      pose[c] = b0 * v0[c] + b1 * v0[track::RATES + c] + b2 * v1[c]
                + b3 * v1[track::RATES + c];
    const double* q = pose + track::T_QUATERNION;
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int c = track::T_QUATERNION; c < track::VALUES; ++c) pose[c] /= norm;
  }
};

// A bound on |d/dt| of the cubic Hermite interpolant of value (columns first .. first + width
// of a's rows, less b's if b is not null) with the rates `rate` columns further on, over
// interval k: its derivative is (1 - s) v0 + s v1 + 6 s (1 - s) (chord / h - (v0 + v1) / 2)
// for s in [0, 1], at most the larger end rate plus 1.5 times that last vector. inf when
// not finite (two samples at one time).
inline double hermite_speed(const Track& a, const Track* b, idx k, int first, int width,
                            int rate) {
  const double h = a.t[k + 1] - a.t[k];
  double bent = 0.0, end0 = 0.0, end1 = 0.0;
  for (int c = first; c < first + width; ++c) {
    double v0 = a.rows(k, c), v1 = a.rows(k + 1, c);
    double r0 = a.rows(k, c + rate), r1 = a.rows(k + 1, c + rate);
    if (b) {
      v0 -= b->rows(k, c), v1 -= b->rows(k + 1, c);
      r0 -= b->rows(k, c + rate), r1 -= b->rows(k + 1, c + rate);
    }
    const double d = (v1 - v0) / h - 0.5 * (r1 + r0);
    bent += d * d, end0 += r0 * r0, end1 += r1 * r1;
  }
  const double found = std::sqrt(std::fmax(end0, end1)) + 1.5 * std::sqrt(bent);
  return std::isfinite(found) ? found : INFINITY;
}

// A bound on |d distance / dt| in interval k, m/s, on the interpolant: the relative CG
// speed, plus each body's rate (2 |q'| / |q|, |q| >= 1 - |q'| h from a unit end) times its
// radius about the CG (m; 0: a point at the CG). A quaternion cubic that strays half its
// length from a unit end gives no useful bound: inf (the interval searched).
inline double interval_rate(const Track& a, const Track& b, double radius_a, double radius_b,
                            idx k) {
  const double h = a.t[k + 1] - a.t[k];
  double out = hermite_speed(a, &b, k, track::T_POSITION, 3, track::RATES);
  const Track* tracks[2] = {&a, &b};
  const double radii[2] = {radius_a, radius_b};
  for (int side = 0; side < 2; ++side) {
    if (!(radii[side] > 0)) continue;
    const double turning = hermite_speed(*tracks[side], nullptr, k, track::T_QUATERNION, 4,
                                         track::RATES);
    out += turning * h < 0.5 ? 2 * turning / (1 - turning * h) * radii[side] : INFINITY;
  }
  return out;
}

// The least a distance can reach over a piece of length `length` (s) between its values
// first and second, changing at most at `rate` (m/s): (first + second - rate length) / 2;
// -inf where the ends are further apart than the rate allows (the bound does not hold:
// searched).
inline double lower_bound(double first, double second, double rate, double length) {
  const double reach = rate * length;
  return std::fabs(second - first) <= reach * (1 + 1e-9) + 1e-15
             ? 0.5 * (first + second - reach) : -INFINITY;
}

// The least (value, time) found, and the sample interval of its time (-1: a sample).
struct Found {
  double value;
  double time;
  idx interval = -1;
};

// scipy.optimize.minimize_scalar(method='bounded') (fminbound: Brent's parabolic steps
// and golden sections, the ends never evaluated), operation for operation, on f over
// [low, high] with the variable the time from low, to xatol (s).
template <class F>
Found bounded_brent(const F& f, double low, double high, double xatol) {
  const double sqrt_eps = std::sqrt(2.2e-16), golden_mean = 0.5 * (3.0 - std::sqrt(5.0));
  auto sign = [](double v) { return v > 0 ? 1.0 : (v < 0 ? -1.0 : (v == 0 ? 0.0 : v)); };
  double a = 0.0, b = high - low;
  double fulc = a + golden_mean * (b - a), nfc = fulc, xf = fulc, rat = 0.0, e = 0.0;
  double x = xf, fx = f(low + x), ffulc = fx, fnfc = fx;
  int num = 1;
  double xm = 0.5 * (a + b), tol1 = sqrt_eps * std::fabs(xf) + xatol / 3.0, tol2 = 2.0 * tol1;
  while (std::fabs(xf - xm) > tol2 - 0.5 * (b - a)) {
    bool golden = true;
    if (std::fabs(e) > tol1) {   // a parabola through the three best
      golden = false;
      double r = (xf - nfc) * (fx - ffulc), q = (xf - fulc) * (fx - fnfc);
      double p = (xf - fulc) * q - (xf - nfc) * r;
      q = 2.0 * (q - r);
      if (q > 0.0) p = -p;
      q = std::fabs(q);
      r = e;
      e = rat;
      if (std::fabs(p) < std::fabs(0.5 * q * r) && p > q * (a - xf) && p < q * (b - xf)) {
        rat = (p + 0.0) / q;
        x = xf + rat;
        if (x - a < tol2 || b - x < tol2) rat = tol1 * (sign(xm - xf) + (xm - xf == 0));
      } else {
        golden = true;
      }
    }
    if (golden) {
      e = xf >= xm ? a - xf : b - xf;
      rat = golden_mean * e;
    }
    x = xf + (sign(rat) + (rat == 0)) * std::fmax(std::fabs(rat), tol1);
    const double fu = f(low + x);
    ++num;
    if (fu <= fx) {
      (x >= xf ? a : b) = xf;
      fulc = nfc, ffulc = fnfc, nfc = xf, fnfc = fx, xf = x, fx = fu;
    } else {
      (x < xf ? a : b) = x;
      if (fu <= fnfc || nfc == xf) {
        fulc = nfc, ffulc = fnfc, nfc = x, fnfc = fu;
      } else if (fu <= ffulc || fulc == xf || fulc == nfc) {
        fulc = x, ffulc = fu;
      }
    }
    xm = 0.5 * (a + b);
    tol1 = sqrt_eps * std::fabs(xf) + xatol / 3.0;
    tol2 = 2.0 * tol1;
    if (num >= 500) break;
  }
  return {fx, low + xf, -1};
}

// The search of one window: times t (n,), the distance sampled there (n,), the rate bound
// of each interval (rate(k), m/s) and the distance between samples (f(k, time)).
template <class F, class R>
class Search {
 public:
  Search(const double* t, const double* sampled, idx n, const R& rate, const F& f)
      : t_(t), sampled_(sampled), n_(n), rate_(rate), f_(f) {}

  // The least (value, time) over [start, end], between samples included (between if
  // `between`, else the samples alone); NaN, NaN when no sample lies in the window and no
  // interval meets it.
  Found least(double start, double end, bool between) const {
    Found best{NAN, NAN};
    for (idx k = 0; k < n_; ++k)   // the least sample, the first if several tie
      if (t_[k] >= start - EDGE && t_[k] <= end + EDGE
          && (std::isnan(best.time) || sampled_[k] < best.value))
        best = {sampled_[k], t_[k], -1};
    if (!between || n_ < 2) return best;
    const double lo = std::fmax(start, t_[0]), hi = std::fmin(end, t_[n_ - 1]);
    std::vector<Interval> kept;
    for (idx k = 0; k < n_ - 1; ++k) {
      if (!(t_[k + 1] > lo && t_[k] < hi)) continue;
      const double rate = rate_(k);
      // the bound over the whole interval holds over the part of it in the window
      const double bound = lower_bound(sampled_[k], sampled_[k + 1], rate, t_[k + 1] - t_[k]);
      if (!std::isnan(best.value) && !(bound < best.value - DISTANCE_TOLERANCE)) continue;
      Interval i;
      i.k = k, i.rate = rate;
      const double a = std::fmax(t_[k], lo), b = std::fmin(t_[k + 1], hi);
      if (!(b > a)) continue;
      for (int p = 0; p <= PROBES; ++p) i.times[p] = a + (b - a) * (p * (1.0 / PROBES));
      kept.push_back(i);
    }
    if (kept.empty()) return best;
    Found lowest{NAN, NAN};
    for (Interval& i : kept) {   // every interval left probed
      i.least = 0;
      for (int p = 0; p <= PROBES; ++p) {
        i.values[p] = f_(i.k, i.times[p]);
        if (i.values[p] < i.values[i.least]) i.least = p;
      }
      if (std::isnan(lowest.time) || i.values[i.least] < lowest.value)
        lowest = {i.values[i.least], i.times[i.least], i.k};
    }
    if (std::isnan(best.value) || lowest.value < best.value - GAIN) best = lowest;
    // each probed piece bounded as the interval was: what cannot go DISTANCE_TOLERANCE
    // below the best is done
    for (Interval& i : kept) {
      i.bound = INFINITY;
      const double piece = (i.times[PROBES] - i.times[0]) / PROBES;
      for (int p = 0; p < PROBES; ++p)
        i.bound = std::fmin(i.bound, lower_bound(i.values[p], i.values[p + 1], i.rate, piece));
    }
    auto key = [](double bound) { return std::isnan(bound) ? INFINITY : bound; };
    std::stable_sort(kept.begin(), kept.end(), [&](const Interval& x, const Interval& y) {
      return key(x.bound) < key(y.bound);
    });
    for (const Interval& i : kept) {
      if (i.bound >= best.value - DISTANCE_TOLERANCE) break;
      const Found found = around(i, best.value);
      if (found.value < best.value - GAIN) best = found;
    }
    return best;
  }

 private:
  struct Interval {
    idx k;
    double rate, bound;
    int least;
    double times[PROBES + 1], values[PROBES + 1];
  };

  // The least (value, time) near an interval's least probe (near_probe), in the interval.
  Found around(const Interval& i, double best) const {
    // no rate bound (inf): the time to 1e-13 s; below 1e-3 m/s, 1e-6 s (within the
    // distance tolerance still, and a search that ends)
    const double tolerance = std::fmin(
        std::fmax(DISTANCE_TOLERANCE / std::fmax(i.rate, 1e-300), 1e-13), 1e-6);
    Found found = near_probe(i, best, tolerance);
    found.interval = i.k;
    return found;
  }

  // The least near an interval's least probe: Brent about it, to `tolerance` (s). A least
  // probe at an end (a window's edge, or a distance still falling at the interval's end)
  // is approached first at distances from it shrinking by 1 / PROBES down to where the
  // rate bound leaves no more than DISTANCE_TOLERANCE below it: Brent would take some 30
  // golden sections to close on an end, where a minimum inside needs about ten.
  Found near_probe(const Interval& i, double best, double tolerance) const {
    const int j = i.least;
    auto single = [&](double time) { return f_(i.k, time); };
    if (0 < j && j < PROBES) return bounded_brent(single, i.times[j - 1], i.times[j + 1],
                                                  tolerance);
    const double end = i.times[j], inner = j == 0 ? i.times[1] : i.times[PROBES - 1];
    const double width = std::fabs(inner - end);
    // the piece next to the end 1 / PROBES ** count of it, at most the time tolerance
    const int count = std::max(1, std::min(16, static_cast<int>(std::ceil(
        std::log(std::fmax(width / tolerance, 2.0)) / std::log(double(PROBES))))));
    double near[18], found[18];   // from the end inwards
    near[0] = end, found[0] = i.values[j];
    for (int c = 1; c <= count; ++c) {
      near[c] = end + (inner - end) * std::pow(double(PROBES), -double(count + 1 - c));
      found[c] = single(near[c]);
    }
    near[count + 1] = inner, found[count + 1] = i.values[j == 0 ? 1 : PROBES - 1];
    const int size = count + 2;
    int m = 0;
    for (int c = 1; c < size; ++c)
      if (found[c] < found[m]) m = c;
    const double least = std::isnan(best) ? best : std::fmin(best, found[m]);
    double bound = INFINITY;
    for (int c = 0; c + 1 < size; ++c)
      bound = std::fmin(bound, lower_bound(found[c], found[c + 1], i.rate,
                                           std::fabs(near[c + 1] - near[c])));
    if (bound >= least - DISTANCE_TOLERANCE) return {found[m], near[m], -1};
    const double x = near[std::max(m - 1, 0)], y = near[std::min(m + 1, size - 1)];
    const Found searched = bounded_brent(single, std::fmin(x, y), std::fmax(x, y), tolerance);
    return searched.value < found[m] ? searched : Found{found[m], near[m], -1};
  }

  const double* t_;
  const double* sampled_;
  idx n_;
  const R& rate_;
  const F& f_;
};

}  // namespace between
}  // namespace cfem
