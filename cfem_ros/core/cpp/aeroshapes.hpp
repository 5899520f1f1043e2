// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The vectorised aerodynamic-table and shape-distance functions of _kernel
// (isa, aero_wrench, distance; multilinear in _kernel.testing; aeroshapes.cpp).
#pragma once

#include <pybind11/pybind11.h>

namespace cfem {

// m: isa, aero_wrench, distance; testing: multilinear.
void bind_aeroshapes(pybind11::module_& m, pybind11::module_& testing);

}  // namespace cfem
