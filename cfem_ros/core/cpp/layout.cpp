// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The layout tables of layout.hpp and workspace.hpp as Python reads them:
// _kernel.LAYOUT[array] = {name: (group, first column, width) or a number}, and
// _kernel.workspace_parts(n, m, nj, dense) = [(name, offset, shape), ...].
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "layout.hpp"
#include "workspace.hpp"

namespace py = pybind11;

namespace cfem {

void bind_layout(py::module_& m) {
  py::dict layout;
#define CFEM_EXPORT_COLUMN(group, name, first, width) \
  table[#name] = py::make_tuple(#group, first, width);
#define CFEM_EXPORT_NUMBER(type, name, value) table[#name] = py::cast(static_cast<type>(value));
#define CFEM_EXPORT(array, TABLE) \
  {                               \
    py::dict table;               \
    TABLE(CFEM_EXPORT_COLUMN, CFEM_EXPORT_NUMBER) layout[array] = table; \
  }
  CFEM_EXPORT("bodies", CFEM_BODIES_LAYOUT)
  CFEM_EXPORT("loads", CFEM_LOADS_LAYOUT)
  CFEM_EXPORT("aero_table", CFEM_AERO_TABLE_LAYOUT)
  CFEM_EXPORT("plan", CFEM_PLAN_LAYOUT)
  CFEM_EXPORT("rows_i", CFEM_ROWS_I_LAYOUT)
  CFEM_EXPORT("rows_f", CFEM_ROWS_F_LAYOUT)
  CFEM_EXPORT("joints_i", CFEM_JOINTS_I_LAYOUT)
  CFEM_EXPORT("joints_f", CFEM_JOINTS_F_LAYOUT)
  CFEM_EXPORT("advance_info", CFEM_ADVANCE_INFO_LAYOUT)
  CFEM_EXPORT("locate_info", CFEM_LOCATE_INFO_LAYOUT)
  CFEM_EXPORT("sample", CFEM_SAMPLE_LAYOUT)
  CFEM_EXPORT("odometry", CFEM_ODOMETRY_LAYOUT)
  CFEM_EXPORT("aero_air", CFEM_AERO_AIR_LAYOUT)
  CFEM_EXPORT("trajectory", CFEM_TRAJECTORY_LAYOUT)
  CFEM_EXPORT("shape", CFEM_SHAPE_LAYOUT)
  CFEM_EXPORT("twist", CFEM_TWIST_LAYOUT)
  CFEM_EXPORT("closest", CFEM_CLOSEST_LAYOUT)
  CFEM_EXPORT("track", CFEM_TRACK_LAYOUT)
  CFEM_EXPORT("least", CFEM_LEAST_LAYOUT)
  CFEM_EXPORT("state", CFEM_STATE_LAYOUT)
#undef CFEM_EXPORT
#undef CFEM_EXPORT_NUMBER
#undef CFEM_EXPORT_COLUMN
  m.attr("LAYOUT") = layout;
  m.def("workspace_size", &workspace_size, py::arg("n"), py::arg("m"), py::arg("nj"),
        py::arg("dense"));
  m.def("workspace_parts", [](idx n, idx m_, idx nj, idx dense) {
    py::list out;
    for (const Part& p : workspace_parts(n, m_, nj, dense))
      out.append(py::make_tuple(p.name, p.offset, py::tuple(py::cast(p.shape))));
    return out;
  }, py::arg("n"), py::arg("m"), py::arg("nj"), py::arg("dense"));
}

}  // namespace cfem
