// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Sway braces (SPEC section 11): one-sided preloaded spring-dampers between a body and
// its carrier, one row of the packed ``loads`` each (braces.py lays it out). While a
// pad is in contact (BR_ON = 1) it pushes the body along its direction with
// f = preload + stiffness s + damping ds/dt, s the pad's compression since t = 0; out of
// contact it pushes nothing. The force is kept smooth inside a step (f as it is, even
// past zero): the step in which f changes sign is cut where it does (events.cpp), and
// the engine switches the pad there, so that RK4 never integrates across the kink.
#pragma once

#include "common.hpp"
#include "layout.hpp"

namespace cfem {
namespace braces {

// Its columns are layout.hpp's (loads::BR_*, KIND_BRACE).

// The brace's push f at y (N, negative past the loss of contact), its world point into
// point[0:3] and world direction into direction[0:3]; rot: the bodies' rotation matrices
// at y (n, 3, 3), or null to compute the two it needs.
double push(const double* y, const double* rot, const Mat& loads, idx row, idx n,
            double* point, double* direction);

// The brace's wrench on its body at y into out (world): force (3), moment about the CG
// (3), then the world point (3); zero while it is out of contact. False if out of contact.
// rot as push's.
bool wrench(const double* y, const double* rot, const Mat& loads, idx row, idx n,
            double* out);

// True if the brace's contact changes within the step that ends at y: in contact and
// pulling (f < 0), or out of contact and pushing (f > 0).
bool switched(const double* y, const Mat& loads, idx row, idx n);

// The excess (>= 0 once the contact changes) of the brace at y: -f in contact, f out of it.
double excess(const double* y, const Mat& loads, idx row, idx n);

}  // namespace braces
}  // namespace cfem
