// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Applied loads from the packed ``loads`` array (layout.hpp; loads.py fills it): held
// wrenches at points, scheduled wrenches and their tables, aerodynamic tables.
// A new load kind: a KIND_ value and its columns in layout.hpp, a branch in add_scheduled and in
// sample_applied (and its outputs in ScheduledLoads.sources). Sway braces (KIND_BRACE)
// are braces.hpp's.
#pragma once

#include "common.hpp"
#include "layout.hpp"

namespace cfem {
namespace loads {

// The columns of a packed row and its kinds: layout.hpp (CFEM_LOADS_LAYOUT). A contact
// row's C_SEEN is the distance GJK found at the step end it last ran (m; 0 none yet) and
// C_POSE body A's pose in body B's axes then (CG (3), quaternion (4)), from which a later
// step end bounds the distance from below without GJK (stroke_reached). A contact is
// reached when the shapes are CONTACT_GAP close (GJK's own tolerance, 1e-12 m, is below
// it: the time it costs is this over the approach speed).
// An aerodynamic row keeps in A_STATUS (AERO_SLOTS columns) where its body was on each
// axis of its tables the last time it was told (-1 below the grid, 0 on it, 1 above;
// aero.hpp's slots); a sample holds sample::AIR numbers per aerodynamic row after the
// applied loads: alpha, beta (deg), Mach, dynamic pressure (Pa), density (kg/m^3),
// airspeed (m/s), CX, CY, CZ, and Cl, Cm, Cn about the CG.

// The held torque of body i plus r x F (world axes), r its point turned by rot (3x3).
inline void held_moment(const double* rot, const Mat& loads, idx i, const double* force,
                        double* torque) {
  const double* row = loads.row(i);
  double px = row[H_POINT], py = row[H_POINT + 1], pz = row[H_POINT + 2];
  if (px == 0.0 && py == 0.0 && pz == 0.0) return;
  double r0 = rot[0] * px + rot[1] * py + rot[2] * pz;
  double r1 = rot[3] * px + rot[4] * py + rot[5] * pz;
  double r2 = rot[6] * px + rot[7] * py + rot[8] * pz;
  double t0 = torque[0] + r1 * force[2] - r2 * force[1];
  double t1 = torque[1] + r2 * force[0] - r0 * force[2];
  double t2 = torque[2] + r0 * force[1] - r1 * force[0];
  torque[0] = t0;
  torque[1] = t1;
  torque[2] = t2;
}

// The scheduled row's point (world, out[0:3]) and its stroke so far, m (returned).
double point_and_stroke(const double* y, const Mat& loads, idx row, idx n, double* point);

// Add the scheduled wrenches that are on, their reactions and aero loads to fhat (world).
void add_scheduled(const double* y, const double* rot, const Mat& bodies, const Mat& loads,
                   double* fhat);

// Write the time of the step's start (and of its evaluation) into the scheduled rows.
void set_time(const Mat& loads, idx n, double t);

// Write the RK4 stage's time, the step's start plus offset, into the scheduled rows.
void stage_time(const Mat& loads, idx n, double offset);

// Rotation matrices of the n bodies at y into rot (n, 3, 3).
void rotations(const double* y, idx n, double* rot);

// Each scheduled row's stroke so far at y into out (rows n.., -1 for the others).
void strokes(const double* y, const Mat& loads, idx n, double* out);

// True if a scheduled wrench that is on has reached its stroke at y, or an armed contact
// pair touches (a pair that is not armed is armed when its shapes are apart at y), or a body
// with aero tables has left or come back to a table's range (aero_moved).
bool stroke_reached(const double* y, const Mat& loads, idx n);

// The distance between the shapes of contact row `row` at y, m (distance.hpp); the
// closest points (world) into points (closest::WIDTH numbers, layout.hpp) if points is
// not null, and the closest parts of compound shapes into parts[0:2] if parts is not null.
double contact_gap(const double* y, const Mat& loads, idx row, idx n, double* points,
                   int* parts = nullptr);

// Each scheduled wrench's (and aero table's) load at y into out, 6 a source, then the air
// of each aero row (sample::AIR numbers); rot (n, 3, 3) and w (18) scratch.
void sample_applied(const double* y, const Mat& bodies, const Mat& loads, double* out,
                    double* rot, double* w);

// The numbers sample_applied writes (the rows' indices checked: systemcheck.cpp).
idx applied_size(const Mat& bodies, const Mat& loads);

// The values at y of the axes of aero row `row`'s tables (aero.hpp's slots; rad, Mach,
// m) into values, and where the body is on each (-1 below, 0 on the grid, 1 above; 0 for an
// axis with one grid value) into status, the grids' ends into low and high.
void aero_axes(const double* y, const Mat& loads, idx row, idx n, double* values,
               double* status, double* low, double* high);

// True if aero row `row`'s body is elsewhere at y than its A_STATUS columns say.
bool aero_moved(const double* y, const Mat& loads, idx row, idx n);

// The crossing of aero row `row` at y toward where the body is at y1: the largest, over the
// axes on which the body is elsewhere at y1 than A_STATUS says, of the signed distance
// past the grid's end it crosses (>= 0 once crossed).
double aero_crossing(const double* y, const double* y1, const Mat& loads, idx row, idx n);

}  // namespace loads
}  // namespace cfem
