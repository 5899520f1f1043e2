// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// What is measured at a state: the joints' loads, a sample's outputs, the
// velocity projection onto the joints and the Jacobian blocks.
#pragma once

#include "common.hpp"
#include "workspace.hpp"

namespace cfem {

// Each active joint's load on its child at y into force, moment (J, 3; world axes, N and
// N m about the joint point, plan order); false if singular.
bool joint_loads(const double* y, const System& s, const Work& v, double* force,
                 double* moment);

// What a sample publishes at y into out (size numbers); REACHED, SINGULAR or
// LOADS_NOT_FINITE. order: plan lines of the joints sampled (count k).
int sample_outputs(const double* y, const System& s, const Work& v, const idx* order, idx k,
                   double* out, idx size);

// The numbers a sample of k joints' loads takes (sample_outputs's size at least).
idx sample_size(const System& s, idx k);

// The mass-weighted velocity correction that satisfies the joints at y into delta (n,
// twist::WIDTH; layout.hpp).
bool project(const double* y, const System& s, const Work& v, double* delta);

// The workspace's J and J M^-1 blocks at y.
void row_jacobian(const double* y, const System& s, const Work& v);

}  // namespace cfem
