// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// _kernel.System: a model's arrays and the rows, plan, watched joints and workspace of
// one set of active joints, checked once when it is made (as MuJoCo's mjModel and
// mjData, Pinocchio's Model and Data); the solves take it and the state. It keeps the
// caller's arrays alive and points into them (no copy): the engine writes the held
// loads, the switches and the trajectories into them between calls.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "common.hpp"
#include "dynamics.hpp"
#include "events.hpp"
#include "pyargs.hpp"
#include "sampling.hpp"
#include "step.hpp"
#include "workspace.hpp"

namespace py = pybind11;

namespace cfem {

namespace {

using args::check_indices;
using args::checked;
using args::imat;
using args::ivec;
using args::mat;
using args::ptr;
using args::vec;

class BoundSystem {
 public:
  BoundSystem(const py::object& bodies, const py::object& gravity, const py::object& loads,
              const py::object& rows_i, const py::object& rows_f, const py::object& plan,
              const py::object& roots, double eta, idx dense, const py::object& joints_i,
              const py::object& joints_f, const py::object& watch, const py::object& limits,
              const py::object& triggers, const py::object& watch_plan,
              const py::object& order)
      : keep_{bodies, gravity, loads, rows_i, rows_f, plan, roots, joints_i, joints_f,
              watch, limits, triggers, watch_plan, order} {
    s.bodies = mat(bodies, "bodies", true);
    if (s.bodies.cols < motion::BODY_COLUMNS)
      throw py::value_error("bodies: expected at least " + std::to_string(motion::BODY_COLUMNS)
                            + " columns, got " + std::to_string(s.bodies.cols));
    idx n = s.bodies.rows;
    s.gravity = vec(gravity, "gravity", false, 3);
    s.loads = mat(loads, "loads", true, loads::WIDTH);
    if (s.loads.rows < n) throw py::value_error("loads: expected at least one row per body");
    s.rows_i = imat(rows_i, "rows_i", rows_i::WIDTH);
    s.rows_f = mat(rows_f, "rows_f", false, rows_f::WIDTH);
    if (s.rows_f.rows != s.rows_i.rows)
      throw py::value_error("rows_f: expected as many rows as rows_i");
    s.plan = imat(plan, "plan", plan_layout::WIDTH);
    s.roots = ivec(roots, "roots", n);
    s.eta = eta;
    // the watched joints: Watch for the step loop (limits), Triggers for the in-step search
    w.joints_i = t.joints_i = imat(joints_i, "joints_i", joints_i::WIDTH);
    w.joints_f = t.joints_f = mat(joints_f, "joints_f", false, joints_f::WIDTH);
    w.watch = t.watch = ivec(watch, "watch", -1, &w.count);
    t.count = w.count;
    w.limits = mat(limits, "limits", false, 3);
    t.triggers = mat(triggers, "triggers", false, 3);
    if (w.limits.rows != w.count) throw py::value_error("limits: one row per watched joint");
    if (t.triggers.rows != w.count)
      throw py::value_error("triggers: one row per watched joint");
    w.lines = t.lines = ivec(watch_plan, "watch_plan", w.count);
    order_ = ivec(order, "order", -1, &order_count_);
    // once, here: the solves and the step loop trust every index from now on
    check_indices(s, w.joints_i, w.watch, w.lines, w.count, order_, order_count_);
    outputs_ = sample_size(s, order_count_);
    for (idx row = n; row < s.loads.rows; ++row) {
      double kind = s.loads(row, loads::S_KIND);
      if (kind == loads::KIND_SCHEDULED || kind == loads::KIND_AERO
          || kind == loads::KIND_CONTACT || kind == loads::KIND_BRACE) ++scheduled_;
    }
    set_dense(dense);
  }

  // The solve: 0 tree, 1 dense, 2 least squares; a workspace of its size (a tree's has no
  // m x m parts), zeroed when it is made.
  void set_dense(idx dense) {
    if (dense < 0 || dense > 2)
      throw py::value_error("dense: expected 0 (tree), 1 (dense) or 2 (least squares), got "
                            + std::to_string(dense));
    idx n = s.n(), size = workspace_size(n, s.m(), s.joints(), dense);
    if (!carved_ || work_.size() != size) {
      work_ = py::array_t<double>(size);
      std::fill(work_.mutable_data(), work_.mutable_data() + size, 0.0);
      v = carve(work_.mutable_data(), n, s.m(), s.joints(), dense);
      carved_ = true;
    }
    s.dense = dense;
  }

  // The state argument `name` of 13 n numbers.
  double* state(const py::handle& y, const char* name, bool write) const {
    return vec(y, name, write, 13 * s.n());
  }

  System s;
  Work v;
  Watch w;
  Triggers t;
  const idx* order_ = nullptr;
  idx order_count_ = 0;
  idx scheduled_ = 0;   // scheduled wrenches, aero rows, contact pairs, braces (wrenches_found)
  idx outputs_ = 0;     // the numbers a sample takes (sample_size)
  py::array_t<double> work_;

 private:
  bool carved_ = false;
  std::vector<py::object> keep_;   // the arrays s, w and t point into
};

}  // namespace

void bind_system(py::module_& m, py::module_& testing) {
  py::class_<BoundSystem>(m, "System", R"doc(
A model's arrays and one set of active joints, checked once (kernel.py's docstring).

System(bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, joints_i, joints_f,
watch, limits, triggers, watch_plan, order): float64 arrays (int64 for rows_i, plan, roots,
joints_i, watch, watch_plan, order) in C order, kept and used without copies.
)doc")
      .def(py::init<const py::object&, const py::object&, const py::object&, const py::object&,
                    const py::object&, const py::object&, const py::object&, double, idx,
                    const py::object&, const py::object&, const py::object&, const py::object&,
                    const py::object&, const py::object&, const py::object&>(),
           py::arg("bodies"), py::arg("gravity"), py::arg("loads"), py::arg("rows_i"),
           py::arg("rows_f"), py::arg("plan"), py::arg("roots"), py::arg("eta"),
           py::arg("dense"), py::arg("joints_i"), py::arg("joints_f"), py::arg("watch"),
           py::arg("limits"), py::arg("triggers"), py::arg("watch_plan"), py::arg("order"))
      .def_property("dense", [](const BoundSystem& b) { return b.s.dense; },
                    &BoundSystem::set_dense)
      .def_property_readonly("n", [](const BoundSystem& b) { return b.s.n(); })
      .def_property_readonly("m", [](const BoundSystem& b) { return b.s.m(); })
      .def_property_readonly("joints", [](const BoundSystem& b) { return b.s.joints(); })
      .def_property_readonly("watched", [](const BoundSystem& b) { return b.w.count; })
      .def_property_readonly("scheduled", [](const BoundSystem& b) { return b.scheduled_; })
      .def_property_readonly("outputs", [](const BoundSystem& b) { return b.outputs_; })
      .def_property_readonly("work", [](const BoundSystem& b) { return b.work_; });

  // y is written by derivative and rk4_step (the kinematic bodies' states at the time)
  m.def("derivative", [](BoundSystem& b, const py::handle& y, const py::handle& dy) {
    const double* yp = b.state(y, "y", true);
    double* dyp = b.state(dy, "dy", true);
    py::gil_scoped_release free;
    return derivative(yp, dyp, b.s, b.v, false);
  }, py::arg("system"), py::arg("y"), py::arg("dy"));

  testing.def("rk4_step", [](BoundSystem& b, const py::handle& y, double h, const py::handle& out) {
    const double* yp = b.state(y, "y", true);
    double* op = b.state(out, "out", true);
    py::gil_scoped_release free;
    return rk4(yp, 13 * b.s.n(), h, op, b.s, b.v, false);
  }, py::arg("system"), py::arg("y"), py::arg("h"), py::arg("out"));

  m.def("joint_loads", [](BoundSystem& b, const py::handle& y, const py::handle& force,
                          const py::handle& moment) {
    const double* yp = b.state(y, "y", false);
    Mat f = mat(force, "force", true, 3), mo = mat(moment, "moment", true, 3);
    if (f.rows != b.s.joints() || mo.rows != b.s.joints())
      throw py::value_error("force, moment: expected one row per plan line");
    py::gil_scoped_release free;
    return joint_loads(yp, b.s, b.v, f.data, mo.data);
  }, py::arg("system"), py::arg("y"), py::arg("force"), py::arg("moment"));

  m.def("sample_outputs", [](BoundSystem& b, const py::handle& y, const py::handle& out) {
    const double* yp = b.state(y, "y", false);
    idx size;
    double* outp = vec(out, "out", true, b.outputs_, false, &size);
    py::gil_scoped_release free;
    return sample_outputs(yp, b.s, b.v, b.order_, b.order_count_, outp, size);
  }, py::arg("system"), py::arg("y"), py::arg("out"));

  m.def("row_jacobian", [](BoundSystem& b, const py::handle& y) {
    const double* yp = b.state(y, "y", false);
    py::gil_scoped_release free;
    row_jacobian(yp, b.s, b.v);
  }, py::arg("system"), py::arg("y"));

  m.def("project", [](BoundSystem& b, const py::handle& y, const py::handle& delta) {
    const double* yp = b.state(y, "y", false);
    Mat d = mat(delta, "delta", true, twist::WIDTH);
    if (d.rows != b.s.n()) throw py::value_error("delta: expected one row per body");
    py::gil_scoped_release free;
    return project(yp, b.s, b.v, d.data);
  }, py::arg("system"), py::arg("y"), py::arg("delta"));

  m.def("advance", [](BoundSystem& b, const py::handle& y, const py::handle& info,
                      double t_target, double due, double limit, double dt,
                      const py::handle& grid, const py::handle& samples) {
    double* yp = b.state(y, "y", true);
    double* ip = vec(info, "info", true, advance_info::WIDTH);
    Grid g;
    g.grid = vec(grid, "grid", true, 3);
    g.order = b.order_;
    g.order_count = b.order_count_;
    g.samples = mat(samples, "samples", true);
    if (g.samples.cols > 0 && g.samples.cols < b.outputs_)
      throw py::value_error("samples: " + std::to_string(g.samples.cols) + " columns, a "
                            "sample takes " + std::to_string(b.outputs_) + " (System.outputs)");
    // the next sample's row: a float the caller keeps, read here once per call
    double taken = g.grid[2];
    if (!(taken >= 0.0 && taken <= static_cast<double>(g.samples.rows))
        || taken != std::floor(taken))
      throw py::value_error("grid[2] = " + std::to_string(taken) + ": not the row of samples "
                            "the next sample goes to; expected an integer from 0 to "
                            + std::to_string(g.samples.rows));
    py::gil_scoped_release free;
    advance(yp, 13 * b.s.n(), ip, t_target, due, limit, dt, b.s, b.v, b.w, g);
  }, py::arg("system"), py::arg("y"), py::arg("info"), py::arg("t_target"), py::arg("due"),
     py::arg("limit"), py::arg("dt"), py::arg("grid"), py::arg("samples"));

  m.def("locate", [](BoundSystem& b, const py::handle& y0, double h, const py::handle& y1,
                     const py::handle& ys, const py::handle& joints_found,
                     const py::handle& wrenches_found, const py::handle& info) {
    double* y0p = b.state(y0, "y0", true);
    double* y1p = b.state(y1, "y1", true);
    double* ysp = b.state(ys, "ys", true);
    py::array jf = checked<idx>(joints_found, "joints_found", 2, true);
    if (jf.shape(0) < b.t.count || (b.t.count > 0 && jf.shape(1) != 2))
      throw py::value_error("joints_found: expected (len(watch), 2)");
    py::array wf = checked<idx>(wrenches_found, "wrenches_found", 1, true);
    if (wf.shape(0) < b.scheduled_)
      throw py::value_error("wrenches_found: expected one entry per scheduled wrench, aero "
                            "table and contact pair");
    double* ip = vec(info, "info", true, locate_info::WIDTH);
    py::gil_scoped_release free;
    locate(y0p, 13 * b.s.n(), h, y1p, ysp, b.s, b.v, b.t, ptr<idx>(jf), ptr<idx>(wf), ip);
  }, py::arg("system"), py::arg("y0"), py::arg("h"), py::arg("y1"), py::arg("ys"),
     py::arg("joints_found"), py::arg("wrenches_found"), py::arg("info"));
}

}  // namespace cfem
