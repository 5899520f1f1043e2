// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// What the binding files share: numpy arrays taken without copies, their dtype, order,
// shape and writability checked (a TypeError or ValueError naming the argument), and
// the functions that add each file's part to the module.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <optional>
#include <string>

#include "common.hpp"

namespace cfem {

// Each file's part of the module m, and of its submodule testing (what only tests call).
void bind_layout(pybind11::module_& m);                                 // layout.cpp
void bind_system(pybind11::module_& m, pybind11::module_& testing);     // system.cpp
void bind_between(pybind11::module_& m, pybind11::module_& testing);    // between.cpp

namespace args {
// Every index the System's arrays hold, in range (systemcheck.cpp); a ValueError naming
// the argument, row, column and value if not.
void check_indices(const System& s, const IMat& joints_i, const idx* watch, const idx* lines,
                   idx watched, const idx* order, idx ordered);
}  // namespace args

namespace args {

namespace py = pybind11;

// From this many rows on, a call of the small per-row functions (times, rotations,
// trajectories) releases the GIL: a release and its re-acquire cost about 40 ns, as much
// as their work on a few bodies, and no other thread gains from so short a gap.
constexpr idx MANY_ROWS = 64;

// The GIL released, while this lives, for work on `rows` rows if they are MANY_ROWS or more.
class ReleasedFor {
 public:
  explicit ReleasedFor(idx rows) {
    if (rows >= MANY_ROWS) free_.emplace();
  }

 private:
  std::optional<py::gil_scoped_release> free_;
};

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

inline cfem::Mat mat(const py::handle& obj, const char* name, bool write, idx cols = -1) {
  py::array a = checked<double>(obj, name, 2, write);
  if (cols >= 0 && a.shape(1) != cols)
    throw py::value_error(std::string(name) + ": expected " + std::to_string(cols)
                          + " columns, got " + std::to_string(a.shape(1)));
  return {ptr<double>(a), static_cast<idx>(a.shape(0)), static_cast<idx>(a.shape(1))};
}

inline cfem::IMat imat(const py::handle& obj, const char* name, idx cols) {
  py::array a = checked<idx>(obj, name, 2, false);
  if (a.shape(1) != cols)
    throw py::value_error(std::string(name) + ": expected " + std::to_string(cols)
                          + " columns, got " + std::to_string(a.shape(1)));
  return {ptr<idx>(a), static_cast<idx>(a.shape(0)), static_cast<idx>(a.shape(1))};
}

// A 1-D float64 vector of at least `size` numbers (exactly, if exact).
inline double* vec(const py::handle& obj, const char* name, bool write, idx size, bool exact = true,
            idx* length = nullptr) {
  py::array a = checked<double>(obj, name, 1, write);
  idx got = static_cast<idx>(a.shape(0));
  if (size >= 0 && (exact ? got != size : got < size))
    throw py::value_error(std::string(name) + ": expected " + (exact ? "" : "at least ")
                          + std::to_string(size) + " numbers, got " + std::to_string(got));
  if (length) *length = got;
  return ptr<double>(a);
}

// A float64 array in C order, as the vectorised bindings (aeroshapes.cpp, recorded.cpp)
// take it: noconvert, never a copy (cfem_ros.core.native.kernel's wrappers convert).
using Array = py::array_t<double, py::array::c_style>;

// A ValueError saying message, unless ok.
inline void need(bool ok, const std::string& message) {
  if (!ok) throw py::value_error(message);
}

// a of shape (rows, width), or a ValueError naming it and that shape.
inline void need_rows(const Array& a, const char* name, py::ssize_t width, py::ssize_t rows) {
  need(a.ndim() == 2 && a.shape(1) == width && a.shape(0) == rows,
       std::string(name) + ": shape (" + std::to_string(rows) + ", " + std::to_string(width) +
           ") expected");
}

// s a whole packed shape (contacts.pack_shape), or a ValueError naming it (aeroshapes.cpp).
void need_shape(const Array& s, const char* name);

inline const idx* ivec(const py::handle& obj, const char* name, idx size, idx* length = nullptr) {
  py::array a = checked<idx>(obj, name, 1, false);
  idx got = static_cast<idx>(a.shape(0));
  if (size >= 0 && got != size)
    throw py::value_error(std::string(name) + ": expected " + std::to_string(size)
                          + " numbers, got " + std::to_string(got));
  if (length) *length = got;
  return ptr<idx>(a);
}

}  // namespace args
}  // namespace cfem
