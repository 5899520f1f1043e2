// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Sway braces (SPEC section 11): one-sided preloaded spring-dampers between a body and
// its carrier, one row of the packed ``loads`` each (braces.py lays it out). The pad is
// mounted on the carrier: its face point (BR_PAD) and its axis (BR_AXIS, the direction at
// t = 0) are fixed in the carrier's axes. While a pad is in contact (BR_ON = 1) it pushes
// the body's contact point (BR_POINT, body axes) along the axis with
// f = preload + stiffness s + damping ds/dt, s the travel of the contact point along the
// axis towards the carrier since t = 0; out of contact it pushes nothing. A pad touches
// only where the contact point lies within BR_RADIUS of its axis. The force is kept smooth
// inside a step (f as it is, even past zero): the step in which the contact changes is
// cut where it does (events.cpp), and the engine switches the pad there, so that RK4
// never integrates across the kink. A pad that let go touches again only once it pushes
// more than BR_BAND (N) and the point is back inside the radius by RADIUS_BAND of it: the
// instant of a change is located to the last bits, so without this band a pad could let
// go and touch again at one instant forever (chatter).
#pragma once

#include "common.hpp"
#include "layout.hpp"

namespace cfem {
namespace braces {

// Its columns are layout.hpp's (loads::BR_*, KIND_BRACE).

// The part of the pad's radius a point that slid off must come back inside to touch again.
constexpr double RADIUS_BAND = 1e-9;

// The brace's push f at y (N, negative past the loss of contact), the body's world contact
// point into point[0:3], the pad's world axis into direction[0:3] and, unless null, the
// point's distance from that axis (m) into lateral; rot: the bodies' rotation matrices at
// y (n, 3, 3), or null to compute the two it needs.
double push(const double* y, const double* rot, const Mat& loads, idx row, idx n,
            double* point, double* direction, double* lateral);

// The brace's wrench on its body at y into out (world): force (3), moment about the CG
// (3), then the world point (3); zero while it is out of contact. False if out of contact.
// rot as push's.
bool wrench(const double* y, const double* rot, const Mat& loads, idx row, idx n,
            double* out);

// True if the brace's contact changes within the step that ends at y: in contact and
// pulling (f < 0) or off the pad's radius, or out of contact and back on it, pushing.
bool switched(const double* y, const Mat& loads, idx row, idx n);

// The excess (>= 0 once the contact changes) of the brace at y: in contact the larger of
// -f (N) and the point's distance beyond the radius (m); out of it the smaller of
// f - BR_BAND and the distance inside the radius less its band. Only its sign is compared.
double excess(const double* y, const Mat& loads, idx row, idx n);

}  // namespace braces
}  // namespace cfem
