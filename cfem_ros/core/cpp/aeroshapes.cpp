// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Python bindings of the aerodynamic-table and shape-distance headers, added to
// cfem_ros.core._kernel by bind_aeroshapes (bindings.cpp calls it): vectorised over
// many states for tests, metrics and recordings; shapes and dtypes checked once per
// call, the GIL released around the loops.
#include <pybind11/numpy.h>
#include <cstdint>
#include <pybind11/pybind11.h>

#include <stdexcept>
#include <vector>
#include <string>

#include "aero.hpp"
#include "aeroshapes.hpp"
#include "distance.hpp"
#include "isa.hpp"
#include "multilinear.hpp"
#include "pyargs.hpp"

namespace py = pybind11;
// Arguments are taken as they are, never converted (a copy): float64 in C order, or the
// call is refused (each argument is noconvert; cfem_ros.core.native.kernel's wrappers convert
// in the open, where a caller's array may need it).
using cfem::args::Array;
using cfem::args::need;
using cfem::args::need_rows;
using cfem::args::need_shape;

namespace cfem {
namespace args {

void need_shape(const Array& s, const char* name) {
  need(s.ndim() == 1 && cfem::shapes::checked_length(s.data(), static_cast<long>(s.shape(0)))
                            == static_cast<long>(s.shape(0)),
       std::string(name) + ": a shape from cfem_ros.core.native.contacts.pack_shape expected");
}

}  // namespace args
}  // namespace cfem

namespace {

// values at points: grids (list of 1-D), values (sizes..., width), points (n, axes)
Array py_multilinear(py::list grids, Array values, Array points) {
  int axes = static_cast<int>(grids.size());
  need(axes >= 1 && axes <= cfem::kMaxAxes, "grids: 1 to 8 axes expected");
  need(values.ndim() == axes + 1, "values: one dimension per axis plus the outputs expected");
  std::vector<double> flat;
  int sizes[cfem::kMaxAxes];
  for (int d = 0; d < axes; ++d) {
    need(py::isinstance<Array>(grids[d]), "grids: float64 arrays in C order expected");
    Array g = py::reinterpret_borrow<Array>(grids[d]);
    need(g.ndim() == 1 && g.shape(0) == values.shape(d), "grids: a grid per axis of values");
    sizes[d] = static_cast<int>(g.shape(0));
    flat.insert(flat.end(), g.data(), g.data() + g.shape(0));
  }
  int width = static_cast<int>(values.shape(axes));
  need(width >= 1 && width <= cfem::kMaxWidth, "values: 1 to 8 numbers per node expected");
  need(points.ndim() == 2 && points.shape(1) == axes, "points: shape (n, axes) expected");
  py::ssize_t n = points.shape(0);
  Array out({n, static_cast<py::ssize_t>(width)});
  // one flat array: the grids, then the values
  long values_at = static_cast<long>(flat.size());
  flat.insert(flat.end(), values.data(), values.data() + values.size());
  cfem::Flat grid_data{flat.data()};
  const double* p = points.data();
  double* o = out.mutable_data();
  {
    py::gil_scoped_release release;
    for (py::ssize_t k = 0; k < n; ++k) {
      cfem::multilinear(axes, sizes, grid_data, 0, values_at, width, p + k * axes,
                        o + k * width);
    }
  }
  return out;
}

// density (kg/m^3), speed of sound (m/s), temperature (K) and pressure (Pa)
py::tuple py_isa(double altitude, double temperature_offset) {
  double density, sound, temperature, pressure;   // 0.1 us: the GIL kept (MANY_ROWS)
  cfem::isa(altitude, temperature_offset, density, sound);
  cfem::isa_temperature_pressure(altitude, temperature, pressure);
  return py::make_tuple(density, sound, temperature + temperature_offset, pressure);
}

// the aerodynamic wrench at n states: (n, 6) world force and moment about the CG, and
// (n, aero_air::WIDTH) the air it was computed from (layout.hpp, CFEM_AERO_AIR_LAYOUT)
py::tuple py_aero_wrench(Array packed, Array position, Array velocity, Array rot, Array rates,
                      Array carrier_position, Array carrier_rot) {
  need(packed.ndim() == 1 && packed.shape(0) >= cfem::aero::kHeader &&
           packed.data()[cfem::aero::kTotal] == packed.shape(0) &&
           cfem::aero::packed_length(packed.data(), static_cast<long>(packed.shape(0)))
               == packed.shape(0),
       "packed: a table from cfem_ros.core.engine.aeropack.pack expected");
  py::ssize_t n = position.ndim() == 2 ? position.shape(0) : -1;
  need_rows(position, "position", 3, n);
  need_rows(velocity, "velocity", 3, n);
  need_rows(rot, "rot", 9, n);
  need_rows(rates, "rates", 3, n);
  need_rows(carrier_position, "carrier_position", 3, n);
  need_rows(carrier_rot, "carrier_rot", 9, n);
  Array out({n, py::ssize_t(6)}), air({n, py::ssize_t(cfem::aero_air::WIDTH)});
  double* o = out.mutable_data();
  double* a = air.mutable_data();
  {
    py::gil_scoped_release release;
    for (py::ssize_t k = 0; k < n; ++k) {
      cfem::aero::Air info;
      cfem::aero::wrench(cfem::Flat{packed.data()}, position.data() + 3 * k, velocity.data() + 3 * k,
                         rot.data() + 9 * k, rates.data() + 3 * k,
                         carrier_position.data() + 3 * k, carrier_rot.data() + 9 * k,
                         o + 6 * k, &info);
      double* row = a + cfem::aero_air::WIDTH * k;
      row[cfem::aero_air::W_ALPHA] = info.alpha;
      row[cfem::aero_air::W_BETA] = info.beta;
      row[cfem::aero_air::W_MACH] = info.mach;
      row[cfem::aero_air::W_SPEED] = info.speed;
      row[cfem::aero_air::W_DENSITY] = info.density;
      row[cfem::aero_air::W_ALTITUDE] = info.altitude;
      for (int j = 0; j < 6; ++j) {
        row[cfem::aero_air::W_COEFFICIENTS + j] = info.coefficients[j];
        row[cfem::aero_air::W_INCREMENTS + j] = info.increments[j];
      }
      row[cfem::aero_air::W_PRESSURE] = info.pressure;
      for (int j = 0; j < 3; ++j) row[cfem::aero_air::W_ABOUT_CG + j] = info.about_cg[j];
    }
  }
  return py::make_tuple(out, air);
}

// distances at n pose pairs: (n,) m, (n, 6) the closest points on a and b (world) and
// (n, 2) the closest parts (compound shapes; 0 for a convex one)
py::tuple py_distance(Array shape_a, Array rot_a, Array position_a, Array shape_b, Array rot_b,
                   Array position_b) {
  need_shape(shape_a, "shape_a");
  need_shape(shape_b, "shape_b");
  py::ssize_t n = position_a.ndim() == 2 ? position_a.shape(0) : -1;
  need_rows(position_a, "position_a", 3, n);
  need_rows(position_b, "position_b", 3, n);
  need_rows(rot_a, "rot_a", 9, n);
  need_rows(rot_b, "rot_b", 9, n);
  Array out(n), points({n, py::ssize_t(cfem::closest::WIDTH)});
  py::array_t<std::int64_t> parts({n, py::ssize_t(2)});
  double* o = out.mutable_data();
  double* p = points.mutable_data();
  std::int64_t* which = parts.mutable_data();
  {
    py::gil_scoped_release release;
    for (py::ssize_t k = 0; k < n; ++k) {
      int found[2];
      o[k] = cfem::shapes::any_distance(cfem::Flat{shape_a.data()}, rot_a.data() + 9 * k,
                                        position_a.data() + 3 * k, cfem::Flat{shape_b.data()},
                                        rot_b.data() + 9 * k, position_b.data() + 3 * k,
                                        p + cfem::closest::WIDTH * k + cfem::closest::P_A,
                                        p + cfem::closest::WIDTH * k + cfem::closest::P_B,
                                        nullptr, found);
      which[2 * k] = found[0];
      which[2 * k + 1] = found[1];
    }
  }
  return py::make_tuple(out, points, parts);
}

}  // namespace

namespace cfem {

void bind_aeroshapes(py::module_& m, py::module_& testing) {
  auto arg = [](const char* name) { return py::arg(name).noconvert(); };
  testing.def("multilinear", &py_multilinear, py::arg("grids"), arg("values"), arg("points"));
  m.def("isa", &py_isa, py::arg("altitude"), py::arg("temperature_offset") = 0.0);
  m.def("aero_wrench", &py_aero_wrench, arg("packed"), arg("position"), arg("velocity"),
        arg("rot"), arg("rates"), arg("carrier_position"), arg("carrier_rot"));
  m.def("distance", &py_distance, arg("shape_a"), arg("rot_a"), arg("position_a"),
        arg("shape_b"), arg("rot_b"), arg("position_b"));
}

}  // namespace cfem
