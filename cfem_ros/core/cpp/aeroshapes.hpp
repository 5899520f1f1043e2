// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The vectorised aerodynamic-table and shape-distance functions of _kernel
// (multilinear, isa, aero_wrench, distance; aeroshapes.cpp).
#pragma once

#include <pybind11/pybind11.h>

namespace cfem {

void bind_aeroshapes(pybind11::module_& m);

}  // namespace cfem
