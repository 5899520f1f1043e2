// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The extension module cfem_ros.core._kernel (pybind11): numpy arrays are taken
// without copies, their dtype, order, shape and writability checked (a TypeError or
// ValueError naming the argument; pyargs.hpp), and the GIL released around every call
// that computes (the small per-row functions: from MANY_ROWS rows on). The System and its solves: system.cpp; the layout: layout.cpp; the
// vectorised tables and shapes: aeroshapes.cpp. What only the tests call (a reference
// search's pieces, the small factorizations' pivot thresholds) is kept apart, in the
// submodule _kernel.testing, out of the API (kernel.py never reads it).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "aeroshapes.hpp"
#include "common.hpp"
#include "conditions.hpp"
#include "events.hpp"
#include "loads.hpp"
#include "metrics.hpp"
#include "motion.hpp"
#include "pyargs.hpp"
#include "recorded.hpp"
#include "solve.hpp"

namespace py = pybind11;
using cfem::idx;

using cfem::args::checked;
using cfem::args::imat;
using cfem::args::ivec;
using cfem::args::mat;
using cfem::args::ptr;
using cfem::args::ReleasedFor;
using cfem::args::vec;

namespace {

// n, the bodies' rows of loads: within loads.
void bodies_in(idx n, const cfem::Mat& loads) {
  if (n < 0 || n > loads.rows)
    throw py::value_error("n = " + std::to_string(n) + ": expected the number of bodies, 0 to "
                          + std::to_string(loads.rows) + " (the rows of loads)");
}

}  // namespace

PYBIND11_MODULE(_kernel, m) {
  m.doc() = "The compiled hot path of cfem_ros (C++17); cfem_ros.core.native.kernel is its API.";

  py::module_ testing = m.def_submodule(
      "testing", "Functions only cfem_ros's tests call: not the API (kernel.py's docstring).");
  cfem::bind_layout(m);                // LAYOUT, workspace_size, workspace_parts
  cfem::bind_system(m, testing);       // System and the solves that take it
  cfem::bind_aeroshapes(m, testing);   // aerodynamic tables and shape distances, vectorised
  cfem::bind_recorded(m);              // the kernel's formulas over recorded arrays
  cfem::bind_between(m, testing);      // least distances between samples

  testing.def("conditions", [](const py::handle& y, const py::handle& joints_i,
                         const py::handle& joints_f, const py::handle& watch,
                         const py::handle& out) {
    idx size, count;
    const double* yp = vec(y, "y", false, -1, true, &size);
    cfem::IMat ji = imat(joints_i, "joints_i", cfem::joints_i::WIDTH);
    cfem::Mat jf = mat(joints_f, "joints_f", false, cfem::joints_f::WIDTH);
    const idx* wp = ivec(watch, "watch", -1, &count);
    cfem::Mat o = mat(out, "out", true);
    if (o.rows != count || o.cols < 2)
      throw py::value_error("out: expected one row per watched joint, at least 2 columns");
    for (idx k = 0; k < count; ++k)
      if (wp[k] < 0 || wp[k] >= ji.rows)
        throw py::value_error("watch[" + std::to_string(k) + "] = " + std::to_string(wp[k])
                              + ": not a joint of joints_i");
    for (idx k = 0; k < ji.rows; ++k)
      for (idx side = 0; side < 2; ++side)
        if (ji(k, side) < 0 || cfem::state::BODY * ji(k, side) >= size)
          throw py::value_error("joints_i[" + std::to_string(k) + ", " + std::to_string(side)
                                + "] = " + std::to_string(ji(k, side)) + ": not a body of y");
    py::gil_scoped_release free;
    cfem::conditions(yp, size, ji, jf, wp, count, o.data, o.cols);
  }, py::arg("y"), py::arg("joints_i"), py::arg("joints_f"), py::arg("watch"), py::arg("out"));

  m.def("loads_set_time", [](const py::handle& loads, idx n, double t) {
    cfem::Mat l = mat(loads, "loads", true, cfem::loads::WIDTH);
    bodies_in(n, l);
    ReleasedFor free(l.rows - n);
    cfem::loads::set_time(l, n, t);
  }, py::arg("loads"), py::arg("n"), py::arg("t"));

  testing.def("loads_strokes", [](const py::handle& y, const py::handle& loads, idx n,
                                  const py::handle& out) {
    cfem::Mat l = mat(loads, "loads", false, cfem::loads::WIDTH);
    bodies_in(n, l);
    const double* yp = vec(y, "y", false, cfem::state::size(n));
    double* op = vec(out, "out", true, l.rows - n, false);
    ReleasedFor free(l.rows - n);
    cfem::loads::strokes(yp, l, n, op);
  }, py::arg("y"), py::arg("loads"), py::arg("n"), py::arg("out"));

  m.def("loads_aero_axes", [](const py::handle& y, const py::handle& loads, idx n, idx row,
                              const py::handle& out) {
    cfem::Mat l = mat(loads, "loads", false, cfem::loads::WIDTH);
    const double* yp = vec(y, "y", false, cfem::state::size(n));
    if (row < n || row >= l.rows || l(row, cfem::loads::S_KIND) != cfem::loads::KIND_AERO)
      throw py::value_error("row: an aerodynamic row of loads expected");
    py::array o = checked<double>(out, "out", 2, true);
    if (o.shape(0) != 4 || o.shape(1) != cfem::loads::AERO_SLOTS)
      throw py::value_error("out: expected (4, AERO_SLOTS)");
    double* op = ptr<double>(o);
    const idx k = cfem::loads::AERO_SLOTS;
    py::gil_scoped_release free;
    cfem::loads::aero_axes(yp, l, row, n, op, op + k, op + 2 * k, op + 3 * k);
  }, py::arg("y"), py::arg("loads"), py::arg("n"), py::arg("row"), py::arg("out"));

  m.def("loads_rotations", [](const py::handle& y, idx n, const py::handle& rot) {
    const double* yp = vec(y, "y", false, cfem::state::size(n));
    py::array r = checked<double>(rot, "rot", 3, true);
    if (r.shape(0) != n || r.shape(1) != 3 || r.shape(2) != 3)
      throw py::value_error("rot: expected (n, 3, 3)");
    double* rp = ptr<double>(r);
    ReleasedFor free(n);
    cfem::loads::rotations(yp, n, rp);
  }, py::arg("y"), py::arg("n"), py::arg("rot"));

  m.def("motion_place", [](const py::handle& y, const py::handle& bodies, double offset) {
    cfem::Mat b = mat(bodies, "bodies", true);
    double* yp = vec(y, "y", true, cfem::state::size(b.rows));
    ReleasedFor free(b.rows);
    if (b.cols > cfem::motion::BODY_COLUMNS) cfem::motion::place(yp, b, offset);
  }, py::arg("y"), py::arg("bodies"), py::arg("offset"));

  m.def("motion_set_time", [](const py::handle& bodies, double t) {
    cfem::Mat b = mat(bodies, "bodies", true);
    ReleasedFor free(b.rows);
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

  testing.def("inverse", [](const py::handle& a, int k, const py::handle& out) {
    cfem::Mat am = mat(a, "a", false), om = mat(out, "out", true);
    if (k < 0 || k > 3 || am.rows < k || am.cols < k || om.rows < k || om.cols < k)
      throw py::value_error("k: expected 0 to 3, within a and out");
    return cfem::inverse(am.data, am.cols, k, om.data, om.cols);
  }, py::arg("a"), py::arg("k"), py::arg("out"));

  testing.def("cholesky", [](const py::handle& a, int k, const py::handle& out) {
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
}
