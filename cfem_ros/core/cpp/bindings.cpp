// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The extension module cfem_ros.core._kernel (pybind11): numpy arrays are taken
// without copies, their dtype, order, shape and writability checked once per call
// (a TypeError or ValueError naming the argument), and the GIL released around
// every call that computes.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "aeroshapes.hpp"
#include "common.hpp"
#include "conditions.hpp"
#include "dynamics.hpp"
#include "events.hpp"
#include "loads.hpp"
#include "metrics.hpp"
#include "motion.hpp"
#include "sampling.hpp"
#include "solve.hpp"
#include "step.hpp"
#include "workspace.hpp"

namespace py = pybind11;
using cfem::idx;

namespace {

// The checked array argument `name`: float64 (or int64), C order, ndim dimensions, writable
// if `write`.
template <typename T>
py::array checked(const py::handle& obj, const char* name, int ndim, bool write) {
  if (!py::isinstance<py::array>(obj))
    throw py::type_error(std::string(name) + ": expected a numpy array, got "
                         + std::string(py::str(py::type::of(obj).attr("__name__"))));
  py::array a = py::reinterpret_borrow<py::array>(obj);
  const char* kind = std::is_same<T, double>::value ? "float64" : "int64";
  if (!a.dtype().is(py::dtype::of<T>()) && !a.dtype().equal(py::dtype::of<T>()))
    throw py::type_error(std::string(name) + ": expected a " + kind + " array, got "
                         + std::string(py::str(a.dtype())));
  if (a.ndim() != ndim)
    throw py::value_error(std::string(name) + ": expected " + std::to_string(ndim)
                          + " dimension(s), got " + std::to_string(a.ndim()));
  if (!(a.flags() & py::array::c_style))
    throw py::value_error(std::string(name) + ": expected a C-contiguous array");
  if (write && !a.writeable())
    throw py::value_error(std::string(name) + ": the array is read-only");
  return a;
}

template <typename T>
T* ptr(const py::array& a) {
  return static_cast<T*>(const_cast<void*>(a.data()));
}

cfem::Mat mat(const py::handle& obj, const char* name, bool write, idx cols = -1) {
  py::array a = checked<double>(obj, name, 2, write);
  if (cols >= 0 && a.shape(1) != cols)
    throw py::value_error(std::string(name) + ": expected " + std::to_string(cols)
                          + " columns, got " + std::to_string(a.shape(1)));
  return {ptr<double>(a), static_cast<idx>(a.shape(0)), static_cast<idx>(a.shape(1))};
}

cfem::IMat imat(const py::handle& obj, const char* name, idx cols) {
  py::array a = checked<idx>(obj, name, 2, false);
  if (a.shape(1) != cols)
    throw py::value_error(std::string(name) + ": expected " + std::to_string(cols)
                          + " columns, got " + std::to_string(a.shape(1)));
  return {ptr<idx>(a), static_cast<idx>(a.shape(0)), static_cast<idx>(a.shape(1))};
}

// A 1-D float64 vector of at least `size` numbers (exactly, if exact).
double* vec(const py::handle& obj, const char* name, bool write, idx size, bool exact = true,
            idx* length = nullptr) {
  py::array a = checked<double>(obj, name, 1, write);
  idx got = static_cast<idx>(a.shape(0));
  if (size >= 0 && (exact ? got != size : got < size))
    throw py::value_error(std::string(name) + ": expected " + (exact ? "" : "at least ")
                          + std::to_string(size) + " numbers, got " + std::to_string(got));
  if (length) *length = got;
  return ptr<double>(a);
}

const idx* ivec(const py::handle& obj, const char* name, idx size, idx* length = nullptr) {
  py::array a = checked<idx>(obj, name, 1, false);
  idx got = static_cast<idx>(a.shape(0));
  if (size >= 0 && got != size)
    throw py::value_error(std::string(name) + ": expected " + std::to_string(size)
                          + " numbers, got " + std::to_string(got));
  if (length) *length = got;
  return ptr<idx>(a);
}

// The system arguments (Topology.kernel_args) and the carved workspace.
struct Bound {
  cfem::System s;
  cfem::Work v;
};

Bound bind(const py::handle& bodies, const py::handle& gravity, const py::handle& loads,
           const py::handle& rows_i, const py::handle& rows_f, const py::handle& plan,
           const py::handle& roots, double eta, idx dense, const py::handle& work) {
  Bound b;
  cfem::System& s = b.s;
  s.bodies = mat(bodies, "bodies", true);
  if (s.bodies.cols < cfem::motion::BODY_COLUMNS)
    throw py::value_error("bodies: expected at least 20 columns, got "
                          + std::to_string(s.bodies.cols));
  idx n = s.bodies.rows;
  s.gravity = vec(gravity, "gravity", false, 3);
  s.loads = mat(loads, "loads", true, cfem::loads::WIDTH);
  if (s.loads.rows < n)
    throw py::value_error("loads: expected at least one row per body");
  s.rows_i = imat(rows_i, "rows_i", 3);
  s.rows_f = mat(rows_f, "rows_f", false, 9);
  if (s.rows_f.rows != s.rows_i.rows)
    throw py::value_error("rows_f: expected as many rows as rows_i");
  s.plan = imat(plan, "plan", 7);
  s.roots = ivec(roots, "roots", n);
  s.eta = eta;
  s.dense = dense;
  idx size = cfem::workspace_size(n, s.m(), s.joints(), dense);
  double* w = vec(work, "work", true, size, false);
  b.v = cfem::carve(w, n, s.m(), s.joints(), dense);
  return b;
}

double* state(const py::handle& y, const char* name, idx n, bool write) {
  return vec(y, name, write, 13 * n);
}

#define SYSTEM_ARGS                                                                       \
  const py::handle &bodies, const py::handle &gravity, const py::handle &loads,          \
      const py::handle &rows_i, const py::handle &rows_f, const py::handle &plan,         \
      const py::handle &roots, double eta, idx dense, const py::handle &work
#define SYSTEM_NAMES \
  py::arg("bodies"), py::arg("gravity"), py::arg("loads"), py::arg("rows_i"), \
      py::arg("rows_f"), py::arg("plan"), py::arg("roots"), py::arg("eta"), py::arg("dense"), \
      py::arg("work")
#define BIND bind(bodies, gravity, loads, rows_i, rows_f, plan, roots, eta, dense, work)

}  // namespace

PYBIND11_MODULE(_kernel, m) {
  m.doc() = "The compiled hot path of cfem_ros (C++17); cfem_ros.core.kernel is its API.";

  m.def("workspace_size", &cfem::workspace_size, py::arg("n"), py::arg("m"), py::arg("nj"),
        py::arg("dense"));
  cfem::bind_aeroshapes(m);   // aerodynamic tables and shape distances, vectorised

  m.def("derivative", [](const py::handle& y, const py::handle& dy, SYSTEM_ARGS) {
    Bound b = BIND;
    const double* yp = state(y, "y", b.s.n(), true);
    double* dyp = state(dy, "dy", b.s.n(), true);
    py::gil_scoped_release free;
    return cfem::derivative(yp, dyp, b.s, b.v, false);
  }, py::arg("y"), py::arg("dy"), SYSTEM_NAMES);

  m.def("rk4_step", [](const py::handle& y, double h, const py::handle& out, SYSTEM_ARGS) {
    Bound b = BIND;
    const double* yp = state(y, "y", b.s.n(), true);
    double* op = state(out, "out", b.s.n(), true);
    py::gil_scoped_release free;
    return cfem::rk4(yp, 13 * b.s.n(), h, op, b.s, b.v, false);
  }, py::arg("y"), py::arg("h"), py::arg("out"), SYSTEM_NAMES);

  m.def("joint_loads", [](const py::handle& y, SYSTEM_ARGS, const py::handle& force,
                          const py::handle& moment) {
    Bound b = BIND;
    const double* yp = state(y, "y", b.s.n(), false);
    cfem::Mat f = mat(force, "force", true, 3), mo = mat(moment, "moment", true, 3);
    if (f.rows != b.s.joints() || mo.rows != b.s.joints())
      throw py::value_error("force, moment: expected one row per plan line");
    py::gil_scoped_release free;
    return cfem::joint_loads(yp, b.s, b.v, f.data, mo.data);
  }, py::arg("y"), SYSTEM_NAMES, py::arg("force"), py::arg("moment"));

  m.def("sample_outputs", [](const py::handle& y, SYSTEM_ARGS, const py::handle& order,
                             const py::handle& out) {
    Bound b = BIND;
    const double* yp = state(y, "y", b.s.n(), false);
    idx k, size;
    const idx* op = ivec(order, "order", -1, &k);
    for (idx j = 0; j < k; ++j)
      if (op[j] < 0 || op[j] >= b.s.joints()) throw py::value_error("order: not a plan line");
    double* outp = vec(out, "out", true, 13 * b.s.n() + 6 * k, false, &size);
    py::gil_scoped_release free;
    return cfem::sample_outputs(yp, b.s, b.v, op, k, outp, size);
  }, py::arg("y"), SYSTEM_NAMES, py::arg("order"), py::arg("out"));

  m.def("row_jacobian", [](const py::handle& y, SYSTEM_ARGS) {
    Bound b = BIND;
    const double* yp = state(y, "y", b.s.n(), false);
    py::gil_scoped_release free;
    cfem::row_jacobian(yp, b.s, b.v);
  }, py::arg("y"), SYSTEM_NAMES);

  m.def("project", [](const py::handle& y, SYSTEM_ARGS, const py::handle& delta) {
    Bound b = BIND;
    const double* yp = state(y, "y", b.s.n(), false);
    cfem::Mat d = mat(delta, "delta", true, 6);
    if (d.rows != b.s.n()) throw py::value_error("delta: expected one row per body");
    py::gil_scoped_release free;
    return cfem::project(yp, b.s, b.v, d.data);
  }, py::arg("y"), SYSTEM_NAMES, py::arg("delta"));

  m.def("conditions", [](const py::handle& y, const py::handle& joints_i,
                         const py::handle& joints_f, const py::handle& watch,
                         const py::handle& out) {
    idx size, count;
    const double* yp = vec(y, "y", false, -1, true, &size);
    cfem::IMat ji = imat(joints_i, "joints_i", 2);
    cfem::Mat jf = mat(joints_f, "joints_f", false, 10);
    const idx* wp = ivec(watch, "watch", -1, &count);
    cfem::Mat o = mat(out, "out", true);
    if (o.rows != count || o.cols < 2)
      throw py::value_error("out: expected one row per watched joint, at least 2 columns");
    py::gil_scoped_release free;
    cfem::conditions(yp, size, ji, jf, wp, count, o.data, o.cols);
  }, py::arg("y"), py::arg("joints_i"), py::arg("joints_f"), py::arg("watch"), py::arg("out"));

  m.def("advance", [](const py::handle& y, const py::handle& info, double t_target, double due,
                      double limit, double dt, SYSTEM_ARGS, const py::handle& joints_i,
                      const py::handle& joints_f, const py::handle& watch,
                      const py::handle& limits, const py::handle& watch_plan,
                      const py::handle& grid, const py::handle& order,
                      const py::handle& samples) {
    Bound b = BIND;
    double* yp = state(y, "y", b.s.n(), true);
    double* ip = vec(info, "info", true, 6, false);
    cfem::Watch w;
    w.joints_i = imat(joints_i, "joints_i", 2);
    w.joints_f = mat(joints_f, "joints_f", false, 10);
    w.watch = ivec(watch, "watch", -1, &w.count);
    w.limits = mat(limits, "limits", false, 3);
    w.lines = ivec(watch_plan, "watch_plan", w.count);
    if (w.limits.rows != w.count) throw py::value_error("limits: one row per watched joint");
    cfem::Grid g;
    g.grid = vec(grid, "grid", true, 3);
    g.order = ivec(order, "order", -1, &g.order_count);
    g.samples = mat(samples, "samples", true);
    if (g.samples.cols > 0 && g.samples.cols < 13 * b.s.n() + 6 * g.order_count)
      throw py::value_error("samples: too few columns for the outputs");
    py::gil_scoped_release free;
    cfem::advance(yp, 13 * b.s.n(), ip, t_target, due, limit, dt, b.s, b.v, w, g);
  }, py::arg("y"), py::arg("info"), py::arg("t_target"), py::arg("due"), py::arg("limit"),
     py::arg("dt"), SYSTEM_NAMES, py::arg("joints_i"), py::arg("joints_f"), py::arg("watch"),
     py::arg("limits"), py::arg("watch_plan"), py::arg("grid"), py::arg("order"),
     py::arg("samples"));

  m.def("locate", [](const py::handle& y0, double h, const py::handle& y1, const py::handle& ys,
                     SYSTEM_ARGS, const py::handle& joints_i, const py::handle& joints_f,
                     const py::handle& watch, const py::handle& triggers,
                     const py::handle& watch_plan, const py::handle& joints_found,
                     const py::handle& wrenches_found, const py::handle& info) {
    Bound b = BIND;
    idx n = b.s.n();
    double* y0p = state(y0, "y0", n, true);
    double* y1p = state(y1, "y1", n, true);
    double* ysp = state(ys, "ys", n, true);
    cfem::Triggers t;
    t.joints_i = imat(joints_i, "joints_i", 2);
    t.joints_f = mat(joints_f, "joints_f", false, 10);
    t.watch = ivec(watch, "watch", -1, &t.count);
    t.triggers = mat(triggers, "triggers", false, 3);
    t.lines = ivec(watch_plan, "watch_plan", t.count);
    if (t.triggers.rows != t.count) throw py::value_error("triggers: one row per watched joint");
    py::array jf = checked<idx>(joints_found, "joints_found", 2, true);
    if (jf.shape(0) < t.count || (t.count > 0 && jf.shape(1) != 2))
      throw py::value_error("joints_found: expected (len(watch), 2)");
    py::array wf = checked<idx>(wrenches_found, "wrenches_found", 1, true);
    idx scheduled = 0;
    for (idx row = n; row < b.s.loads.rows; ++row)
      if (b.s.loads(row, cfem::loads::S_KIND) == cfem::loads::KIND_SCHEDULED
          || b.s.loads(row, cfem::loads::S_KIND) == cfem::loads::KIND_CONTACT) ++scheduled;
    if (wf.shape(0) < scheduled)
      throw py::value_error("wrenches_found: expected one entry per scheduled wrench and "
                            "contact pair");
    double* ip = vec(info, "info", true, 7);
    py::gil_scoped_release free;
    cfem::locate(y0p, 13 * n, h, y1p, ysp, b.s, b.v, t, ptr<idx>(jf), ptr<idx>(wf), ip);
  }, py::arg("y0"), py::arg("h"), py::arg("y1"), py::arg("ys"), SYSTEM_NAMES,
     py::arg("joints_i"), py::arg("joints_f"), py::arg("watch"), py::arg("triggers"),
     py::arg("watch_plan"), py::arg("joints_found"), py::arg("wrenches_found"), py::arg("info"));

  m.def("loads_set_time", [](const py::handle& loads, idx n, double t) {
    cfem::Mat l = mat(loads, "loads", true, cfem::loads::WIDTH);
    cfem::loads::set_time(l, n, t);
  }, py::arg("loads"), py::arg("n"), py::arg("t"));

  m.def("loads_strokes", [](const py::handle& y, const py::handle& loads, idx n,
                            const py::handle& out) {
    cfem::Mat l = mat(loads, "loads", false, cfem::loads::WIDTH);
    const double* yp = vec(y, "y", false, 13 * n);
    double* op = vec(out, "out", true, l.rows - n, false);
    cfem::loads::strokes(yp, l, n, op);
  }, py::arg("y"), py::arg("loads"), py::arg("n"), py::arg("out"));

  m.def("loads_rotations", [](const py::handle& y, idx n, const py::handle& rot) {
    const double* yp = vec(y, "y", false, 13 * n);
    py::array r = checked<double>(rot, "rot", 3, true);
    if (r.shape(0) != n || r.shape(1) != 3 || r.shape(2) != 3)
      throw py::value_error("rot: expected (n, 3, 3)");
    cfem::loads::rotations(yp, n, ptr<double>(r));
  }, py::arg("y"), py::arg("n"), py::arg("rot"));

  m.def("motion_place", [](const py::handle& y, const py::handle& bodies, double offset) {
    cfem::Mat b = mat(bodies, "bodies", true);
    double* yp = vec(y, "y", true, 13 * b.rows);
    if (b.cols > cfem::motion::BODY_COLUMNS) cfem::motion::place(yp, b, offset);
  }, py::arg("y"), py::arg("bodies"), py::arg("offset"));

  m.def("motion_set_time", [](const py::handle& bodies, double t) {
    cfem::Mat b = mat(bodies, "bodies", true);
    if (b.cols > cfem::motion::BODY_COLUMNS) cfem::motion::set_time(b, t);
  }, py::arg("bodies"), py::arg("t"));

  m.def("clearance", [](const py::handle& pos_a, const py::handle& quat_a,
                        const py::handle& points_a, const py::handle& pos_b,
                        const py::handle& quat_b, const py::handle& points_b,
                        const py::handle& out) {
    cfem::Mat pa = mat(pos_a, "pos_a", false, 3), qa = mat(quat_a, "quat_a", false, 4);
    cfem::Mat pb = mat(pos_b, "pos_b", false, 3), qb = mat(quat_b, "quat_b", false, 4);
    cfem::Mat ra = mat(points_a, "points_a", false, 3), rb = mat(points_b, "points_b", false, 3);
    if (qa.rows != pa.rows || pb.rows != pa.rows || qb.rows != pa.rows)
      throw py::value_error("pos_a, quat_a, pos_b, quat_b: expected the same samples");
    double* op = vec(out, "out", true, 4, false);
    std::vector<double> wa(3 * ra.rows), wb(3 * rb.rows);
    py::gil_scoped_release free;
    cfem::clearance(pa, qa, ra, pb, qb, rb, op, wa.data(), wb.data());
  }, py::arg("pos_a"), py::arg("quat_a"), py::arg("points_a"), py::arg("pos_b"),
     py::arg("quat_b"), py::arg("points_b"), py::arg("out"));

  m.def("inverse", [](const py::handle& a, int k, const py::handle& out) {
    cfem::Mat am = mat(a, "a", false), om = mat(out, "out", true);
    if (k < 0 || k > 3 || am.rows < k || am.cols < k || om.rows < k || om.cols < k)
      throw py::value_error("k: expected 0 to 3, within a and out");
    return cfem::inverse(am.data, am.cols, k, om.data, om.cols);
  }, py::arg("a"), py::arg("k"), py::arg("out"));

  m.def("cholesky", [](const py::handle& a, int k, const py::handle& out) {
    cfem::Mat am = mat(a, "a", false), om = mat(out, "out", true);
    if (k < 0 || am.rows < k || am.cols < k || om.rows < k || om.cols < k)
      throw py::value_error("k: expected at most the sizes of a and out");
    return cfem::cholesky(am.data, am.cols, k, om.data, om.cols);
  }, py::arg("a"), py::arg("k"), py::arg("out"));

  m.attr("REACHED") = int(cfem::REACHED);
  m.attr("CONDITION") = int(cfem::CONDITION);
  m.attr("NOT_FINITE") = int(cfem::NOT_FINITE);
  m.attr("VIOLATION") = int(cfem::VIOLATION);
  m.attr("SINGULAR") = int(cfem::SINGULAR);
  m.attr("ROWS_FULL") = int(cfem::ROWS_FULL);
  m.attr("LOADS_NOT_FINITE") = int(cfem::LOADS_NOT_FINITE);
  m.attr("NAN_VALUE") = int(cfem::NAN_VALUE);
  m.attr("SAME_SIGNS") = int(cfem::SAME_SIGNS);
  m.attr("NO_CONVERGENCE") = int(cfem::NO_CONVERGENCE);
  m.attr("PIVOT_RTOL") = cfem::PIVOT_RTOL;
  m.attr("CROSSING_XTOL") = cfem::CROSSING_XTOL;
  m.attr("CROSSING_RTOL") = cfem::CROSSING_RTOL;
  m.attr("CROSSING_MAXITER") = cfem::CROSSING_MAXITER;
  m.attr("LOADS_WIDTH") = cfem::loads::WIDTH;
  m.attr("BODY_COLUMNS") = cfem::motion::BODY_COLUMNS;
}
