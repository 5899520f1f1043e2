// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Least distances between samples, bound to cfem_ros.core._kernel by bind_between
// (bindings.cpp calls it): the search of between.hpp over a window, one call per window
// and pair of bodies, of the distance between two packed shapes (distance.hpp) or
// between two sets of points (metrics.hpp's world_points), the GIL released. The
// search's pieces on their own (the interpolant, the rate bound, the search of any
// Python function) are in _kernel.testing, for the tests.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "algebra.hpp"
#include "between.hpp"
#include "distance.hpp"
#include "metrics.hpp"
#include "pyargs.hpp"

namespace py = pybind11;
using cfem::idx;
using cfem::Mat;
using cfem::between::Found;
using cfem::between::Track;

namespace {

// A track argument: (n, track::WIDTH) at the n times, or (0, track::WIDTH): no twists
// recorded (the samples alone).
Track track_of(const py::handle& obj, const char* name, const double* t, idx n) {
  Mat rows = cfem::args::mat(obj, name, false, cfem::track::WIDTH);
  if (rows.rows != n && rows.rows != 0)
    throw py::value_error(std::string(name) + ": expected " + std::to_string(n)
                          + " rows (one per time) or none, got " + std::to_string(rows.rows));
  return {t, rows};
}

// The rate bound of each interval of two tracks.
struct Rates {
  const Track& a;
  const Track& b;
  double radius_a, radius_b;
  double operator()(idx k) const {
    return cfem::between::interval_rate(a, b, radius_a, radius_b, k);
  }
};

// The signed distance between two packed shapes on the tracks' interpolants (m).
struct ShapeGap {
  const double* shape_a;
  const double* shape_b;
  const Track& a;
  const Track& b;
  double operator()(idx k, double time) const {
    double pose_a[cfem::track::VALUES], pose_b[cfem::track::VALUES];
    a.pose(k, time, pose_a);
    b.pose(k, time, pose_b);
    double rot_a[9], rot_b[9], pa[3], pb[3];
    const double* q = pose_a + cfem::track::T_QUATERNION;
    cfem::quat_matrix(q[0], q[1], q[2], q[3], rot_a);
    q = pose_b + cfem::track::T_QUATERNION;
    cfem::quat_matrix(q[0], q[1], q[2], q[3], rot_b);
    return cfem::shapes::any_distance(cfem::Flat{shape_a}, rot_a,
                                      pose_a + cfem::track::T_POSITION, cfem::Flat{shape_b},
                                      rot_b, pose_b + cfem::track::T_POSITION, pa, pb);
  }
};

// The least distance between two sets of body-axis points on the tracks' interpolants (m),
// and the pair (the first in order on ties).
struct PointGap {
  Mat points_a, points_b;
  const Track& a;
  const Track& b;
  mutable std::vector<double> world_a, world_b;
  double operator()(idx k, double time, idx* pair = nullptr) const {
    double pose_a[cfem::track::VALUES], pose_b[cfem::track::VALUES];
    a.pose(k, time, pose_a);
    b.pose(k, time, pose_b);
    return at(pose_a, pose_b, pair);
  }
  double at(const double* pose_a, const double* pose_b, idx* pair = nullptr) const {
    cfem::world_points(pose_a + cfem::track::T_POSITION, pose_a + cfem::track::T_QUATERNION,
                       points_a, world_a.data());
    cfem::world_points(pose_b + cfem::track::T_POSITION, pose_b + cfem::track::T_QUATERNION,
                       points_b, world_b.data());
    double best = INFINITY;
    for (idx i = 0; i < points_a.rows; ++i) {
      for (idx j = 0; j < points_b.rows; ++j) {
        const double dx = world_a[3 * i] - world_b[3 * j];
        const double dy = world_a[3 * i + 1] - world_b[3 * j + 1];
        const double dz = world_a[3 * i + 2] - world_b[3 * j + 2];
        const double d = std::sqrt(dx * dx + dy * dy + dz * dz);
        if (d < best) {
          best = d;
          if (pair) pair[0] = i, pair[1] = j;
        }
      }
    }
    return best;
  }
};

// The radius about the CG of the farthest of a set of body-axis points (m).
double reach(const Mat& points) {
  double most = 0.0;
  for (idx i = 0; i < points.rows; ++i)
    most = std::fmax(most, std::sqrt(points(i, 0) * points(i, 0) + points(i, 1) * points(i, 1)
                                     + points(i, 2) * points(i, 2)));
  return most;
}

// out (least::WIDTH): the found least, and the poses there (the sample's rows, or the
// interpolant's between samples; NaN without tracks).
void write(const Found& found, const Track& a, const Track& b, double* out) {
  namespace L = cfem::least;
  out[L::L_DISTANCE] = found.value;
  out[L::L_TIME] = found.time;
  out[L::L_POINT_A] = out[L::L_POINT_B] = -1.0;
  for (int c = 0; c < cfem::track::VALUES; ++c)
    out[L::L_POSE_A + c] = out[L::L_POSE_B + c] = NAN;
  if (found.interval >= 0) {
    a.pose(found.interval, found.time, out + L::L_POSE_A);
    b.pose(found.interval, found.time, out + L::L_POSE_B);
  }
}

// A body's track (n, track::WIDTH) from its samples into out: each quaternion on the side of
// the one before, the CG velocity turned from body axes into world, and the quaternion's
// rate of change q (w, 0) / 2 from the body rates w.
void make_track(const Mat& position, const Mat& quaternion, const Mat& velocity,
                const Mat& rates, Mat& out) {
  namespace T = cfem::track;
  double sign = 1.0;
  for (idx k = 0; k < out.rows; ++k) {
    const double* q = quaternion.row(k);
    if (k > 0) {
      const double* before = quaternion.row(k - 1);
      if (q[0] * before[0] + q[1] * before[1] + q[2] * before[2] + q[3] * before[3] < 0)
        sign = -sign;
    }
    double* row = out.row(k);
    for (int c = 0; c < 3; ++c) row[T::T_POSITION + c] = position(k, c);
    double* turned = row + T::T_QUATERNION;
    for (int c = 0; c < 4; ++c) turned[c] = sign * q[c];
    const double norm = std::sqrt(turned[0] * turned[0] + turned[1] * turned[1]
                                  + turned[2] * turned[2] + turned[3] * turned[3]);
    cfem::Products p = cfem::products(turned[0] / norm, turned[1] / norm, turned[2] / norm,
                                      turned[3] / norm);
    const double* v = velocity.row(k);
    cfem::V3 world = cfem::unit_turn(p, v[0], v[1], v[2], false);
    row[T::T_VELOCITY] = world.x, row[T::T_VELOCITY + 1] = world.y;
    row[T::T_VELOCITY + 2] = world.z;
    const double* w = rates.row(k);
    cfem::Q4 rate = cfem::qmul(turned[0], turned[1], turned[2], turned[3], w[0], w[1], w[2], 0.0);
    double* dq = row + T::T_QUATERNION_RATE;
    dq[0] = 0.5 * rate.x, dq[1] = 0.5 * rate.y, dq[2] = 0.5 * rate.z, dq[3] = 0.5 * rate.w;
  }
}

}  // namespace

namespace cfem {

void bind_between(py::module_& m, py::module_& testing) {
  m.attr("BETWEEN_DISTANCE_TOLERANCE") = between::DISTANCE_TOLERANCE;
  m.attr("BETWEEN_GAIN") = between::GAIN;
  m.attr("BETWEEN_PROBES") = between::PROBES;
  m.def("track", [](const py::handle& position, const py::handle& quaternion,
                    const py::handle& velocity, const py::handle& rates, const py::handle& out) {
    Mat p = args::mat(position, "position", false, 3), q = args::mat(quaternion, "quaternion",
                                                                     false, 4);
    Mat v = args::mat(velocity, "velocity", false, 3), w = args::mat(rates, "rates", false, 3);
    Mat o = args::mat(out, "out", true, track::WIDTH);
    if (q.rows != p.rows || v.rows != p.rows || w.rows != p.rows || o.rows != p.rows)
      throw py::value_error("position, quaternion, velocity, rates, out: expected the same "
                            "samples (rows)");
    args::ReleasedFor free(p.rows);
    make_track(p, q, v, w, o);
  }, py::arg("position"), py::arg("quaternion"), py::arg("velocity"), py::arg("rates"),
     py::arg("out"));

  m.def("least_shape_distance", [](const py::handle& time, const py::handle& sampled,
                                   const py::handle& track_a, const py::handle& track_b,
                                   const py::handle& shape_a, const py::handle& shape_b,
                                   double start, double end, const py::handle& out) {
    idx n, size_a, size_b;
    const double* t = args::vec(time, "time", false, -1, true, &n);
    const double* s = args::vec(sampled, "sampled", false, n);
    Track a = track_of(track_a, "track_a", t, n), b = track_of(track_b, "track_b", t, n);
    if ((a.rows.rows == 0) != (b.rows.rows == 0))
      throw py::value_error("track_a, track_b: expected both tracks or neither");
    const double* sa = args::vec(shape_a, "shape_a", false, -1, true, &size_a);
    const double* sb = args::vec(shape_b, "shape_b", false, -1, true, &size_b);
    if (shapes::checked_length(sa, size_a) != size_a)
      throw py::value_error("shape_a: a shape from cfem_ros.core.native.contacts.pack_shape "
                            "expected");
    if (shapes::checked_length(sb, size_b) != size_b)
      throw py::value_error("shape_b: a shape from cfem_ros.core.native.contacts.pack_shape "
                            "expected");
    double* o = args::vec(out, "out", true, least::WIDTH);
    py::gil_scoped_release free;
    Rates rates{a, b, shapes::bounding_radius(Flat{sa}), shapes::bounding_radius(Flat{sb})};
    ShapeGap gap{sa, sb, a, b};
    between::Search<ShapeGap, Rates> search(t, s, n, rates, gap);
    write(search.least(start, end, a.rows.rows > 0), a, b, o);
  }, py::arg("time"), py::arg("sampled"), py::arg("track_a"), py::arg("track_b"),
     py::arg("shape_a"), py::arg("shape_b"), py::arg("start"), py::arg("end"), py::arg("out"));

  m.def("least_point_distance", [](const py::handle& time, const py::handle& track_a,
                                   const py::handle& track_b, const py::handle& points_a,
                                   const py::handle& points_b, double start, double end,
                                   const py::handle& out) {
    idx n;
    const double* t = args::vec(time, "time", false, -1, true, &n);
    Track a = track_of(track_a, "track_a", t, n), b = track_of(track_b, "track_b", t, n);
    if (a.rows.rows != n || b.rows.rows != n)
      throw py::value_error("track_a, track_b: expected one row per time");
    Mat pa = args::mat(points_a, "points_a", false, 3), pb = args::mat(points_b, "points_b",
                                                                       false, 3);
    if (pa.rows == 0 || pb.rows == 0)
      throw py::value_error("points_a, points_b: expected a point or more on each body");
    double* o = args::vec(out, "out", true, least::WIDTH);
    py::gil_scoped_release free;
    PointGap gap{pa, pb, a, b, std::vector<double>(3 * pa.rows),
                 std::vector<double>(3 * pb.rows)};
    std::vector<double> sampled(n);   // at the samples: the clearance metric's own numbers
    for (idx k = 0; k < n; ++k) sampled[k] = gap.at(a.rows.row(k), b.rows.row(k));
    Rates rates{a, b, reach(pa), reach(pb)};
    between::Search<PointGap, Rates> search(t, sampled.data(), n, rates, gap);
    const Found found = search.least(start, end, true);
    write(found, a, b, o);
    if (found.interval >= 0) {
      idx pair[2] = {-1, -1};
      gap.at(o + least::L_POSE_A, o + least::L_POSE_B, pair);
      o[least::L_POINT_A] = static_cast<double>(pair[0]);
      o[least::L_POINT_B] = static_cast<double>(pair[1]);
    }
  }, py::arg("time"), py::arg("track_a"), py::arg("track_b"), py::arg("points_a"),
     py::arg("points_b"), py::arg("start"), py::arg("end"), py::arg("out"));

  testing.def("least_between", [](const py::handle& time, const py::handle& sampled,
                                  const py::handle& rates, double start, double end,
                                  const py::function& distance) {
    idx n;
    const double* t = args::vec(time, "time", false, -1, true, &n);
    const double* s = args::vec(sampled, "sampled", false, n);
    const double* r = args::vec(rates, "rates", false, n > 0 ? n - 1 : 0);
    auto rate = [r](idx k) { return r[k]; };
    auto f = [&distance](idx k, double when) { return distance(k, when).cast<double>(); };
    between::Search<decltype(f), decltype(rate)> search(t, s, n, rate, f);
    const Found found = search.least(start, end, true);
    return py::make_tuple(found.value, found.time);
  }, py::arg("time"), py::arg("sampled"), py::arg("rates"), py::arg("start"), py::arg("end"),
     py::arg("distance"));

  testing.def("interval_rates", [](const py::handle& time, const py::handle& track_a,
                                   const py::handle& track_b, double radius_a,
                                   double radius_b) {
    idx n;
    const double* t = args::vec(time, "time", false, -1, true, &n);
    Track a = track_of(track_a, "track_a", t, n), b = track_of(track_b, "track_b", t, n);
    if (a.rows.rows != n || b.rows.rows != n || n < 2)
      throw py::value_error("track_a, track_b: expected one row per time, two or more");
    py::array_t<double> out(n - 1);
    double* o = out.mutable_data();
    for (idx k = 0; k + 1 < n; ++k) o[k] = between::interval_rate(a, b, radius_a, radius_b, k);
    return out;
  }, py::arg("time"), py::arg("track_a"), py::arg("track_b"), py::arg("radius_a"),
     py::arg("radius_b"));

  testing.def("track_pose", [](const py::handle& time, const py::handle& track, idx k,
                               double when) {
    idx n;
    const double* t = args::vec(time, "time", false, -1, true, &n);
    Track a = track_of(track, "track", t, n);
    if (k < 0 || k + 1 >= a.rows.rows)
      throw py::value_error("k = " + std::to_string(k) + ": expected an interval of track");
    py::array_t<double> out(track::VALUES);
    a.pose(k, when, out.mutable_data());
    return out;
  }, py::arg("time"), py::arg("track"), py::arg("k"), py::arg("t"));
}

}  // namespace cfem
