// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Python bindings of the kernel's formulas over many samples, added to
// cfem_ros.core._kernel by bind_recorded (bindings.cpp calls it): the same functions the
// step and the sample call (motion.hpp, aero.hpp, distance.hpp), so that Python keeps no
// copy of them. Arguments float64 in C order, taken as they are (noconvert; kernel.py's
// wrappers convert in the open), shapes checked once per call, the GIL released around
// the loops.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>

#include "aero.hpp"
#include "distance.hpp"
#include "layout.hpp"
#include "motion.hpp"
#include "pyargs.hpp"
#include "recorded.hpp"

namespace py = pybind11;
using cfem::args::Array;
using cfem::args::need;
using cfem::args::need_rows;
using cfem::args::need_shape;

namespace {

// (k, sample::BODY): each body's pose and twist relative to its reference (motion.hpp)
Array py_relative_states(Array position, Array velocity, Array quaternion, Array rates,
                         Array ref_position, Array ref_velocity, Array ref_quaternion,
                         Array ref_rates) {
  py::ssize_t k = position.ndim() == 2 ? position.shape(0) : -1;
  need_rows(position, "position", 3, k);
  need_rows(velocity, "velocity", 3, k);
  need_rows(quaternion, "quaternion", 4, k);
  need_rows(rates, "rates", 3, k);
  need_rows(ref_position, "ref_position", 3, k);
  need_rows(ref_velocity, "ref_velocity", 3, k);
  need_rows(ref_quaternion, "ref_quaternion", 4, k);
  need_rows(ref_rates, "ref_rates", 3, k);
  Array out({k, py::ssize_t(cfem::sample::BODY)});
  double* o = out.mutable_data();
  {
    py::gil_scoped_release release;
    for (py::ssize_t j = 0; j < k; ++j)
      cfem::motion::relative_state(position.data() + 3 * j, velocity.data() + 3 * j,
                                   quaternion.data() + 4 * j, rates.data() + 3 * j,
                                   ref_position.data() + 3 * j, ref_velocity.data() + 3 * j,
                                   ref_quaternion.data() + 4 * j, ref_rates.data() + 3 * j,
                                   o + cfem::sample::BODY * j);
  }
  return out;
}

// (k,) Pa: aero.hpp's dynamic pressure of densities and speeds (k,)
Array py_dynamic_pressure(Array density, Array speed) {
  py::ssize_t k = density.ndim() == 1 ? density.shape(0) : -1;
  need(k >= 0, "density: a 1-d array expected");
  need(speed.ndim() == 1 && speed.shape(0) == k,
       "speed: shape (" + std::to_string(k) + ",) expected (as density)");
  Array out(k);
  double* o = out.mutable_data();
  {
    py::gil_scoped_release release;
    for (py::ssize_t j = 0; j < k; ++j)
      o[j] = cfem::aero::dynamic_pressure(density.data()[j], speed.data()[j]);
  }
  return out;
}

}  // namespace

namespace cfem {

void bind_recorded(py::module_& m) {
  auto arg = [](const char* name) { return py::arg(name).noconvert(); };
  m.def("relative_states", &py_relative_states, arg("position"), arg("velocity"),
        arg("quaternion"), arg("rates"), arg("ref_position"), arg("ref_velocity"),
        arg("ref_quaternion"), arg("ref_rates"));
  m.def("dynamic_pressure", &py_dynamic_pressure, arg("density"), arg("speed"));
  // a packed convex shape's reach about its centre, without the whole shape checked (a
  // compound's parts are packed with it); a packed shape's bounding radius about the CG
  m.def("shape_reach", [](Array convex) {
    need(convex.ndim() == 1 && convex.shape(0) >= shapes::kShapeHeader
             && shapes::convex_length(Flat{convex.data()}) == convex.shape(0)
             && static_cast<int>(convex.data()[shapes::kKind]) != shapes::kCompound,
         "convex: a packed convex shape expected");
    return shapes::reach(Flat{convex.data()});
  }, arg("convex"));
  m.def("bounding_radius", [](Array shape) {
    need_shape(shape, "shape");
    return shapes::bounding_radius(Flat{shape.data()});
  }, arg("shape"));
}

}  // namespace cfem
