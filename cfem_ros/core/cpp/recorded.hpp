// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The kernel's formulas that Python also needs outside a step, vectorised over many
// samples (recorded arrays, a model's shapes): relative_states, dynamic_pressure,
// shape_reach and bounding_radius of _kernel (recorded.cpp).
#pragma once

#include <pybind11/pybind11.h>

namespace cfem {

// m: relative_states, dynamic_pressure, shape_reach, bounding_radius.
void bind_recorded(pybind11::module_& m);

}  // namespace cfem
