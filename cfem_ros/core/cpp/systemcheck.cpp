// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Every index a System's arrays hold, checked once when the System is made: a body, a
// row, a plan line, a joint or a packed table that is not there is a ValueError naming
// the argument, its row and column, the value and the range that would do, never a
// read or write outside the arrays (the step loop checks nothing: MuJoCo's mj_step
// trusts mjModel once mj_compile has made it, as this loop trusts the System).
#include <pybind11/pybind11.h>

#include <cmath>
#include <sstream>
#include <string>

#include "aero.hpp"
#include "distance.hpp"
#include "pyargs.hpp"

namespace py = pybind11;

namespace cfem {
namespace args {

namespace {

// "name[row, COLUMN]" of a value.
std::string at(const char* name, idx row, const char* column) {
  return std::string(name) + "[" + std::to_string(row) + ", " + column + "]";
}

std::string shown(double value) {
  std::ostringstream out;
  out.precision(17);
  out << value;
  return out.str();
}

[[noreturn]] void refuse(const std::string& where, const std::string& value,
                         const std::string& what, idx low, idx high) {
  throw py::value_error(where + " = " + value + ": " + what + "; expected an integer from "
                        + std::to_string(low) + " to " + std::to_string(high));
}

// An integer index in [low, high].
void within(idx value, const std::string& where, const char* what, idx low, idx high) {
  if (value < low || value > high) refuse(where, std::to_string(value), what, low, high);
}

// A float column holding an index: an integer in [low, high] (compared before the cast,
// which is undefined for NaN or beyond the integers). Returns it.
idx index_in(double value, const std::string& where, const char* what, idx low, idx high) {
  if (!(value >= static_cast<double>(low) && value <= static_cast<double>(high))
      || value != std::floor(value))
    refuse(where, shown(value), what, low, high);
  return static_cast<idx>(value);
}

// A packed table or shape kept in ``loads`` from row first on: the rows it takes fit
// before the scratch row. length: its length in numbers (AERO_ROW numbers a row).
void fits(idx first, double length, const std::string& where, const char* what, idx end) {
  double rows = std::ceil(length / loads::AERO_ROW);
  if (!(length >= 1.0 && first + rows <= end))
    throw py::value_error(where + " = " + std::to_string(first) + ": " + what + " of "
                          + shown(length) + " numbers does not fit in rows "
                          + std::to_string(first) + " to " + std::to_string(end - 1)
                          + " of loads (the scratch row excluded)");
}

void check_rows(const System& s) {
  const idx n = s.n(), m = s.m();
  for (idx r = 0; r < m; ++r) {
    within(s.rows_i(r, rows_i::R_PARENT), at("rows_i", r, "R_PARENT"), "not a body", 0, n - 1);
    within(s.rows_i(r, rows_i::R_CHILD), at("rows_i", r, "R_CHILD"), "not a body", 0, n - 1);
    idx kind = s.rows_i(r, rows_i::R_KIND);
    within(kind, at("rows_i", r, "R_KIND"), "not a row kind (KIND_ROTATION, "
           "KIND_TRANSLATION, KIND_SAME_POINT)", 0, 2);
    if (kind == rows_i::KIND_SAME_POINT
        && (r == 0 || s.rows_i(r - 1, rows_i::R_KIND) == rows_i::KIND_ROTATION))
      throw py::value_error(at("rows_i", r, "R_KIND") + " = KIND_SAME_POINT: the row before "
                            "is not a translation row whose joint point it could share");
  }
}

void check_plan(const System& s) {
  const idx n = s.n(), m = s.m();
  for (idx j = 0; j < s.joints(); ++j) {
    idx first = s.plan(j, P_ROW);
    within(first, at("plan", j, "P_ROW"), "not a row of rows_i", 0, m - 1);
    within(s.plan(j, P_NT), at("plan", j, "P_NT"), "not a number of translation rows", 0, 3);
    within(s.plan(j, P_NR), at("plan", j, "P_NR"), "not a number of rotation rows", 0, 3);
    within(first + s.plan(j, P_NT) + s.plan(j, P_NR), at("plan", j, "P_ROW + P_NT + P_NR"),
           "the joint's rows run past rows_i", first, m);
    within(s.plan(j, P_CHILD), at("plan", j, "P_CHILD"), "not a body", 0, n - 1);
    within(s.plan(j, P_PARENT), at("plan", j, "P_PARENT"), "not a body", 0, n - 1);
    idx sign = s.plan(j, P_SIGN);
    if (sign != 1 && sign != -1)
      throw py::value_error(at("plan", j, "P_SIGN") + " = " + std::to_string(sign)
                            + ": expected +1 or -1");
  }
  for (idx i = 0; i < n; ++i)
    within(s.roots[i], "roots[" + std::to_string(i) + "]", "not a root kind (-1 fixed, 0 "
           "held, 1 a tree's root, 2 free)", -1, 2);
}

void check_joints(const IMat& joints_i, idx n) {
  for (idx k = 0; k < joints_i.rows; ++k) {
    within(joints_i(k, joints_i::J_PARENT), at("joints_i", k, "J_PARENT"), "not a body", 0,
           n - 1);
    within(joints_i(k, joints_i::J_CHILD), at("joints_i", k, "J_CHILD"), "not a body", 0,
           n - 1);
  }
}

// The kinematic bodies' trajectories (motion.cpp): their kind, reference and lengths.
void check_motion(const Mat& bodies) {
  if (bodies.cols <= motion::BODY_COLUMNS) return;
  const idx n = bodies.rows;
  for (idx i = 0; i < n; ++i) {
    double kind = bodies(i, motion::M_KIND);
    index_in(kind, at("bodies", i, "M_KIND"), "not a trajectory kind", 0, 3);
    index_in(bodies(i, motion::M_REF), at("bodies", i, "M_REF"), "not 1 + a body", 0, n);
    idx needed = motion::M_DATA;
    if (kind == motion::KIND_CONSTANT || kind == motion::KIND_ARC) {
      needed += trajectory::CONSTANT;
    } else if (kind == motion::KIND_TABLE) {
      double most = (static_cast<double>(bodies.cols) - motion::M_DATA - 2)
                    / (trajectory::SEGMENT + 1);
      idx count = index_in(bodies(i, motion::M_DATA), at("bodies", i, "M_DATA"),
                           "not a number of segments the row holds", 1,
                           static_cast<idx>(std::floor(most)));
      needed += 2 + (trajectory::SEGMENT + 1) * count;
    }
    if (needed > bodies.cols)
      throw py::value_error(at("bodies", i, "M_DATA") + ": its trajectory takes "
                            + std::to_string(needed) + " columns, bodies has "
                            + std::to_string(bodies.cols));
  }
}

// The rows of ``loads`` after the bodies' (layout.hpp): every body, carrier, frame,
// table and packed shape they name.
void check_loads(const Mat& l, idx n) {
  if (l.rows == n) return;
  const idx end = l.rows - 1;   // the scratch row
  if (l(end, loads::S_KIND) != loads::KIND_SCRATCH)
    throw py::value_error(at("loads", end, "S_KIND") + " = " + shown(l(end, loads::S_KIND))
                          + ": the last row of loads past the bodies' is the scratch row "
                          "(KIND_SCRATCH = " + shown(loads::KIND_SCRATCH) + ")");
  idx aero_last = -1;   // sample_applied reads the aero rows as one run of rows
  for (idx row = n; row < end; ++row) {
    double kind = l(row, loads::S_KIND);
    if (kind == loads::KIND_TABLE || kind == loads::KIND_SCRATCH) break;   // as the loops
    if (kind == loads::KIND_AERO) {
      if (aero_last >= 0 && aero_last != row - 1)
        throw py::value_error(at("loads", row, "S_KIND") + " = KIND_AERO: the aerodynamic "
                              "rows are one run of rows, the last before it is row "
                              + std::to_string(aero_last));
      aero_last = row;
    }
    if (kind == loads::KIND_SCHEDULED) {
      index_in(l(row, loads::S_BODY), at("loads", row, "S_BODY"), "not a body", 0, n - 1);
      index_in(l(row, loads::S_REACT), at("loads", row, "S_REACT"), "not a body or -1", -1,
               n - 1);
      index_in(l(row, loads::S_FRAME), at("loads", row, "S_FRAME"), "not a body or -1", -1,
               n - 1);
      idx table = index_in(l(row, loads::S_TABLE), at("loads", row, "S_TABLE"),
                           "not a table kind", loads::TABLE_NONE, loads::TABLE_STROKE);
      if (table == loads::TABLE_NONE) continue;
      idx first = index_in(l(row, loads::S_FIRST), at("loads", row, "S_FIRST"),
                           "not a row of loads past the bodies'", n, end - 1);
      index_in(l(row, loads::S_COUNT), at("loads", row, "S_COUNT"),
               "not a number of table rows before the scratch row", 1, end - first);
    } else if (kind == loads::KIND_AERO) {
      index_in(l(row, loads::A_BODY), at("loads", row, "A_BODY"), "not a body", 0, n - 1);
      index_in(l(row, loads::A_CARRIER), at("loads", row, "A_CARRIER"), "not a body or -1",
               -1, n - 1);
      idx first = index_in(l(row, loads::A_FIRST), at("loads", row, "A_FIRST"),
                           "not a row of loads past the bodies'", n, end - 1);
      Rows table{l.row(first)};   // AERO_ROW numbers a row
      double total = table[aero_table::TOTAL];
      if (!(total >= aero_table::WIDTH))
        throw py::value_error(at("loads", row, "A_FIRST") + " = " + std::to_string(first)
                              + ": no packed aerodynamic table there (its TOTAL is "
                              + shown(total) + ")");
      fits(first, total, at("loads", row, "A_FIRST"), "the packed aerodynamic table", end);
      if (aero::packed_length(table, static_cast<long>(total)) != total)
        throw py::value_error(at("loads", row, "A_FIRST") + " = " + std::to_string(first)
                              + ": the packed aerodynamic table's header (grid sizes, "
                              "proximity axes) does not give its TOTAL of " + shown(total)
                              + " numbers");
    } else if (kind == loads::KIND_CONTACT) {
      index_in(l(row, loads::C_A), at("loads", row, "C_A"), "not a body", 0, n - 1);
      index_in(l(row, loads::C_B), at("loads", row, "C_B"), "not a body", 0, n - 1);
      for (int side = 0; side < 2; ++side) {
        const char* column = side ? "C_SHAPE_B" : "C_SHAPE_A";
        idx first = index_in(l(row, side ? loads::C_SHAPE_B : loads::C_SHAPE_A),
                             at("loads", row, column), "not a row of loads past the bodies'",
                             n, end - 1);
        long room = static_cast<long>((end - first) * loads::AERO_ROW);
        if (shapes::checked_length(Rows{l.row(first)}, room) < 0)
          throw py::value_error(at("loads", row, column) + " = " + std::to_string(first)
                                + ": no packed shape fits there before the scratch row");
      }
    } else if (kind == loads::KIND_BRACE) {
      index_in(l(row, loads::BR_BODY), at("loads", row, "BR_BODY"), "not a body", 0, n - 1);
      index_in(l(row, loads::BR_CARRIER), at("loads", row, "BR_CARRIER"), "not a body", 0,
               n - 1);
    }
  }
}

}  // namespace

void check_indices(const System& s, const IMat& joints_i, const idx* watch, const idx* lines,
                   idx watched, const idx* order, idx ordered) {
  check_rows(s);
  check_plan(s);
  check_joints(joints_i, s.n());
  for (idx k = 0; k < watched; ++k) {
    within(watch[k], "watch[" + std::to_string(k) + "]", "not a joint of joints_i", 0,
           joints_i.rows - 1);
    within(lines[k], "watch_plan[" + std::to_string(k) + "]", "not a plan line", 0,
           s.joints() - 1);
  }
  for (idx j = 0; j < ordered; ++j)
    within(order[j], "order[" + std::to_string(j) + "]", "not a plan line", 0, s.joints() - 1);
  check_motion(s.bodies);
  check_loads(s.loads, s.n());
}

}  // namespace args
}  // namespace cfem
