// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The state derivative: per-body and per-row terms, the solve of the joints'
// accelerations, and dy/dt.
#pragma once

#include "common.hpp"
#include "workspace.hpp"

namespace cfem {

// Per body: rotation, world rates, mass matrix, free load and (need_inverse) the
// inverse inertia in world axes.
void body_terms(const double* y, const System& s, const Work& v, bool need_inverse);

// Per row: Jacobian blocks J (and J M^-1 if dense), value g, right-hand side. Not full
// (the tree solve's own call): a translation row's rotation columns are left as they
// were unless dense or a body is kinematic (the tree solve reads only its translation
// columns).
void row_terms(const double* y, const System& s, const Work& v, bool dense, bool full = true);

// Accelerations (v.acc) and joint loads at y; false if singular.
bool solve(const double* y, const System& s, const Work& v);

// dy/dt at y into dy; the largest |constraint value| (0 if not largest), -1 if singular.
// solved: the workspace already holds the solve at y (with these loads).
double derivative(const double* y, double* dy, const System& s, const Work& v, bool solved,
                  bool largest = true);

}  // namespace cfem
