// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The layout of every array the kernel shares with Python, in one place: a table per
// array, from which both the C++ constants below and the extension's LAYOUT (layout.cpp,
// read by cfem_ros.core.native.kernel) are made. A new column is one line here; Python reads
// its index and width from the extension, never a number of its own
// (test/core/test_layout.py walks the tables).
//
// COLUMN(group, name, first column, width): a column of a group of rows (the row kinds
// of ``loads`` share the columns 0 .. WIDTH - 2 and keep their kind in S_KIND, the last).
// A width of 0: from there to the end of the row. NUMBER(type, name, value): a size or
// a value stored in the array.
#pragma once

// ``bodies`` (n, BODY_COLUMNS), then the columns of kinematic bodies (motion.cpp) when the
// model has any: the step's start time, the accelerations at the last time evaluated (CG,
// world; angular, world), 1 + the body whose frame this body is sampled in (0 none), then
// its trajectory (CFEM_TRAJECTORY_LAYOUT below: constant, a steady manoeuvre (arc), or a
// table of segments).
#define CFEM_BODIES_LAYOUT(COLUMN, NUMBER)                                                 \
  COLUMN(body, B_MASS, 0, 1)                                                               \
  COLUMN(body, B_INV_MASS, 1, 1)                                                           \
  COLUMN(body, B_INERTIA, 2, 9)                                                            \
  COLUMN(body, B_INV_INERTIA, 11, 9)                                                       \
  NUMBER(int, BODY_COLUMNS, 20)                                                            \
  COLUMN(motion, M_KIND, 20, 1)                                                            \
  COLUMN(motion, M_T0, 21, 1)                                                              \
  COLUMN(motion, M_ACC, 22, 6)                                                             \
  COLUMN(motion, M_REF, 28, 1)                                                             \
  COLUMN(motion, M_DATA, 29, 0)                                                            \
  NUMBER(double, KIND_NONE, 0.0)                                                           \
  NUMBER(double, KIND_CONSTANT, 1.0)                                                       \
  NUMBER(double, KIND_TABLE, 2.0)                                                          \
  NUMBER(double, KIND_ARC, 3.0)

// ``loads`` (n + rows, WIDTH): per body the held wrench (force, torque, 1.0 if in body
// axes, application point in body axes from the CG); then one row per scheduled wrench
// (S_*), per body with aerodynamic tables (A_*), per watched contact pair (C_*; S_ON is
// 1.0 while armed: its shapes apart), per sway brace (BR_*: body, carrier, 1.0 while its
// pad touches, its point and direction in the body's axes, preload, stiffness, damping,
// the pad's point, its axis in the carrier's axes, its radius and the force band a pad
// that let go must exceed to touch again; braces.hpp); then the rows of their tables (T_*, or AERO_ROW
// numbers a row of a packed aerodynamic table or shape); then one scratch row.
#define CFEM_LOADS_LAYOUT(COLUMN, NUMBER)                                                  \
  NUMBER(int, WIDTH, 24)                                                                   \
  COLUMN(held, H_FORCE, 0, 3)                                                              \
  COLUMN(held, H_TORQUE, 3, 3)                                                             \
  COLUMN(held, H_AXES, 6, 1)                                                               \
  COLUMN(held, H_POINT, 7, 3)                                                              \
  COLUMN(scheduled, S_BODY, 0, 1)                                                          \
  COLUMN(scheduled, S_REACT, 1, 1)                                                         \
  COLUMN(scheduled, S_FRAME, 2, 1)                                                         \
  COLUMN(scheduled, S_ON, 3, 1)                                                            \
  COLUMN(scheduled, S_POINT, 4, 3)                                                         \
  COLUMN(scheduled, S_FORCE, 7, 3)                                                         \
  COLUMN(scheduled, S_MOMENT, 10, 3)                                                       \
  COLUMN(scheduled, S_STROKE, 13, 1)                                                       \
  COLUMN(scheduled, S_ANCHOR, 14, 3)                                                       \
  COLUMN(scheduled, S_TABLE, 17, 1)                                                        \
  COLUMN(scheduled, S_FIRST, 18, 1)                                                        \
  COLUMN(scheduled, S_COUNT, 19, 1)                                                        \
  COLUMN(scheduled, S_T0, 20, 1)                                                           \
  COLUMN(scheduled, S_T, 21, 1)                                                            \
  COLUMN(scheduled, S_START, 22, 1)                                                        \
  COLUMN(kind, S_KIND, 23, 1)                                                              \
  COLUMN(aero, A_BODY, 0, 1)                                                               \
  COLUMN(aero, A_CARRIER, 1, 1)                                                            \
  COLUMN(aero, A_STATUS, 2, 10)                                                            \
  COLUMN(aero, A_FIRST, 12, 1)                                                             \
  COLUMN(contact, C_A, 0, 1)                                                               \
  COLUMN(contact, C_B, 1, 1)                                                               \
  COLUMN(contact, C_SHAPE_A, 4, 1)                                                         \
  COLUMN(contact, C_SHAPE_B, 5, 1)                                                         \
  COLUMN(contact, C_GUESS, 6, 3)                                                           \
  COLUMN(contact, C_RADIUS_A, 9, 1)                                                        \
  COLUMN(contact, C_RADIUS_B, 10, 1)                                                       \
  COLUMN(contact, C_SEEN, 11, 1)                                                           \
  COLUMN(contact, C_POSE, 12, 7)                                                           \
  COLUMN(brace, BR_BODY, 0, 1)                                                             \
  COLUMN(brace, BR_CARRIER, 1, 1)                                                          \
  COLUMN(brace, BR_ON, 3, 1)                                                               \
  COLUMN(brace, BR_POINT, 4, 3)                                                            \
  COLUMN(brace, BR_DIRECTION, 7, 3)                                                        \
  COLUMN(brace, BR_PRELOAD, 10, 1)                                                         \
  COLUMN(brace, BR_STIFFNESS, 11, 1)                                                       \
  COLUMN(brace, BR_DAMPING, 12, 1)                                                         \
  COLUMN(brace, BR_PAD, 14, 3)                                                             \
  COLUMN(brace, BR_AXIS, 17, 3)                                                            \
  COLUMN(brace, BR_RADIUS, 20, 1)                                                          \
  COLUMN(brace, BR_BAND, 21, 1)                                                            \
  COLUMN(table, T_ABSCISSA, 0, 1)                                                          \
  COLUMN(table, T_FORCE, 1, 3)                                                             \
  COLUMN(table, T_MOMENT, 4, 3)                                                            \
  NUMBER(int, AERO_ROW, 23)                                                                \
  NUMBER(int, AERO_SLOTS, 10)                                                              \
  NUMBER(int, TABLE_NONE, 0)                                                               \
  NUMBER(int, TABLE_TIME, 1)                                                               \
  NUMBER(int, TABLE_STROKE, 2)                                                             \
  NUMBER(double, KIND_HELD, 0.0)                                                           \
  NUMBER(double, KIND_SCHEDULED, 1.0)                                                      \
  NUMBER(double, KIND_TABLE, 2.0)                                                          \
  NUMBER(double, KIND_AERO, 3.0)                                                           \
  NUMBER(double, KIND_SCRATCH, 4.0)                                                        \
  NUMBER(double, KIND_CONTACT, 5.0)                                                        \
  NUMBER(double, KIND_BRACE, 6.0)                                                          \
  NUMBER(double, CONTACT_GAP, 1e-10)

// A packed aerodynamic table (aeropack.py packs it, aero.hpp reads it; kept in ``loads``
// from an aero row's A_FIRST on, AERO_ROW numbers a row): a header of WIDTH numbers, then
// the alpha (rad), beta (rad) and Mach grids, the coefficients (CX .. Cn per node, alpha
// slowest), the proximity grids and increments. Header: reference area (m^2) and length
// (m), density (kg/m^3; 0: ISA), ISA altitude of the world origin (m), wind (world, m/s),
// damping derivatives, up (-gravity, unit), grid sizes, proximity axes, fade (m), the CG
// in the carrier's axes at t = 0, each proximity axis's code (AXIS_*) and size, the packed
// length, body, carrier, temperature offset (K), reference point (body axes, from the
// actual CG, m), constant increments of CX .. Cn.
#define CFEM_AERO_TABLE_LAYOUT(COLUMN, NUMBER)                                             \
  NUMBER(int, WIDTH, 56)                                                                   \
  COLUMN(header, AREA, 0, 1)                                                               \
  COLUMN(header, LENGTH, 1, 1)                                                             \
  COLUMN(header, DENSITY, 2, 1)                                                            \
  COLUMN(header, ALTITUDE, 3, 1)                                                           \
  COLUMN(header, WIND, 4, 3)                                                               \
  COLUMN(header, DAMPING, 7, 3)                                                            \
  COLUMN(header, UP, 10, 3)                                                                \
  COLUMN(header, NA, 13, 1)                                                                \
  COLUMN(header, NB, 14, 1)                                                                \
  COLUMN(header, NM, 15, 1)                                                                \
  COLUMN(header, PROX_AXES, 16, 1)                                                         \
  COLUMN(header, FADE, 17, 1)                                                              \
  COLUMN(header, START, 18, 3)                                                             \
  COLUMN(header, PROX_CODE, 21, 7)                                                         \
  COLUMN(header, PROX_SIZE, 28, 7)                                                         \
  COLUMN(header, TOTAL, 35, 1)                                                             \
  COLUMN(header, BODY, 36, 1)                                                              \
  COLUMN(header, CARRIER, 37, 1)                                                           \
  COLUMN(header, TEMPERATURE_OFFSET, 38, 1)                                                \
  COLUMN(header, REFERENCE, 39, 3)                                                         \
  COLUMN(header, DELTA, 42, 6)                                                             \
  NUMBER(int, AXIS_DX, 0)                                                                  \
  NUMBER(int, AXIS_DY, 1)                                                                  \
  NUMBER(int, AXIS_DZ, 2)                                                                  \
  NUMBER(int, AXIS_DPHI, 3)                                                                \
  NUMBER(int, AXIS_DTHETA, 4)                                                              \
  NUMBER(int, AXIS_DPSI, 5)                                                                \
  NUMBER(int, AXIS_MACH, 6)

// ``plan`` (J, 7), one line per active joint, leaves of the joint tree first: its first
// row, translation rows, rotation rows, tree child, tree parent, +1 if the tree child is
// the joint's child (-1 if its parent), model joint index.
#define CFEM_PLAN_LAYOUT(COLUMN, NUMBER)                                                   \
  COLUMN(line, P_ROW, 0, 1)                                                                \
  COLUMN(line, P_NT, 1, 1)                                                                 \
  COLUMN(line, P_NR, 2, 1)                                                                 \
  COLUMN(line, P_CHILD, 3, 1)                                                              \
  COLUMN(line, P_PARENT, 4, 1)                                                             \
  COLUMN(line, P_SIGN, 5, 1)                                                               \
  COLUMN(line, P_JOINT, 6, 1)                                                              \
  NUMBER(int, WIDTH, 7)

// ``rows_i`` (m, WIDTH), a constraint row's ends and kind, grouped by joint: parent
// body, child body, KIND_ROTATION, KIND_TRANSLATION, or KIND_SAME_POINT (a translation row
// at the same joint point as the row before: its terms are computed once).
#define CFEM_ROWS_I_LAYOUT(COLUMN, NUMBER)                                                 \
  COLUMN(row, R_PARENT, 0, 1)                                                              \
  COLUMN(row, R_CHILD, 1, 1)                                                               \
  COLUMN(row, R_KIND, 2, 1)                                                                \
  NUMBER(int, WIDTH, 3)                                                                    \
  NUMBER(int, KIND_ROTATION, 0)                                                            \
  NUMBER(int, KIND_TRANSLATION, 1)                                                         \
  NUMBER(int, KIND_SAME_POINT, 2)

// ``rows_f`` (m, WIDTH), in body axes: a translation row's axis on the parent and the
// joint point on the parent and on the child; a rotation row's vector on the parent and
// vector on the child (perpendicular at t = 0).
#define CFEM_ROWS_F_LAYOUT(COLUMN, NUMBER)                                                 \
  COLUMN(translation, R_AXIS, 0, 3)                                                        \
  COLUMN(translation, R_ANCHOR_A, 3, 3)                                                    \
  COLUMN(translation, R_ANCHOR_B, 6, 3)                                                    \
  COLUMN(rotation, R_VECTOR_A, 0, 3)                                                       \
  COLUMN(rotation, R_VECTOR_B, 3, 3)                                                       \
  NUMBER(int, WIDTH, 9)

// ``joints_i`` (joints, WIDTH) and ``joints_f`` (joints, WIDTH) of the release conditions:
// each joint's parent and child; its point on the parent and on the child (body axes) and
// the child's attitude relative to the parent at t = 0 (quaternion x y z w).
#define CFEM_JOINTS_I_LAYOUT(COLUMN, NUMBER)                                               \
  COLUMN(joint, J_PARENT, 0, 1)                                                            \
  COLUMN(joint, J_CHILD, 1, 1)                                                             \
  NUMBER(int, WIDTH, 2)
#define CFEM_JOINTS_F_LAYOUT(COLUMN, NUMBER)                                               \
  COLUMN(joint, J_ANCHOR_A, 0, 3)                                                          \
  COLUMN(joint, J_ANCHOR_B, 3, 3)                                                          \
  COLUMN(joint, J_RELATIVE, 6, 4)                                                          \
  NUMBER(int, WIDTH, 10)

// ``info`` of advance: the time reached (s), steps taken, the largest constraint
// violation so far, the result code, the violation that counts as divergence, the
// violation that did (VIOLATION).
#define CFEM_ADVANCE_INFO_LAYOUT(COLUMN, NUMBER)                                           \
  COLUMN(info, I_T, 0, 1)                                                                  \
  COLUMN(info, I_STEPS, 1, 1)                                                              \
  COLUMN(info, I_VIOLATION, 2, 1)                                                          \
  COLUMN(info, I_RESULT, 3, 1)                                                             \
  COLUMN(info, I_DIVERGENCE, 4, 1)                                                         \
  COLUMN(info, I_VALUE, 5, 1)                                                              \
  NUMBER(int, WIDTH, 6)

// ``info`` of locate: the largest stage violation (read and raised), the code, where the
// search stopped (a code's value), the crossing's s (NaN none) and the number of joints
// found, the stroke end's s (NaN none) and the number of wrenches and contacts found.
#define CFEM_LOCATE_INFO_LAYOUT(COLUMN, NUMBER)                                            \
  COLUMN(info, L_VIOLATION, 0, 1)                                                          \
  COLUMN(info, L_CODE, 1, 1)                                                               \
  COLUMN(info, L_VALUE, 2, 1)                                                              \
  COLUMN(info, L_CROSSING, 3, 1)                                                           \
  COLUMN(info, L_JOINTS, 4, 1)                                                             \
  COLUMN(info, L_STROKE, 5, 1)                                                             \
  COLUMN(info, L_WRENCHES, 6, 1)                                                           \
  NUMBER(int, WIDTH, 7)

// A kinematic body's trajectory in ``bodies``, from column M_DATA on (motion.py packs it,
// motion.cpp reads it). Constant motion or a steady manoeuvre, CONSTANT numbers: the CG
// at t = 0 (world, m), its velocity (m/s; world, or body axes for a manoeuvre), the
// attitude at t = 0 (x y z w) and the body rates (rad/s). A table: the number of segments
// k, the k + 1 breakpoints (s), then per segment SEGMENT numbers: the cubic coefficients
// of the CG position (3 axes x 4, highest power first: scipy's CubicSpline), the key
// attitude (x y z w) and the cubic coefficients of the rotation vector from it (3 x 4:
// scipy's RotationSpline).
#define CFEM_TRAJECTORY_LAYOUT(COLUMN, NUMBER)                                             \
  COLUMN(constant, D_POSITION, 0, 3)                                                       \
  COLUMN(constant, D_VELOCITY, 3, 3)                                                       \
  COLUMN(constant, D_QUATERNION, 6, 4)                                                     \
  COLUMN(constant, D_RATES, 10, 3)                                                         \
  NUMBER(int, CONSTANT, 13)                                                                \
  COLUMN(table, D_COUNT, 0, 1)                                                             \
  COLUMN(table, D_TIMES, 1, 0)                                                             \
  COLUMN(segment, G_POSITION, 0, 12)                                                       \
  COLUMN(segment, G_KEY, 12, 4)                                                            \
  COLUMN(segment, G_ROTATION, 16, 12)                                                      \
  NUMBER(int, SEGMENT, 28)

// A packed collision shape (contacts.py packs it; shapecore.hpp and distance.hpp read it).
// A convex shape: HEADER numbers, its kind (KIND_*), size (box edges; cylinder radius,
// length; sphere radius; capsule radius, overall length; cylinders and capsules along the
// shape's x axis), the shape's axes in its body's (row-major 3x3), its centre from the CG
// (body axes, m) and the hull's vertex count; then the hull's vertices (3 each, shape
// axes, m). A compound shape (SPEC section 11): HEADER numbers (KIND_COMPOUND, the part
// count, zeros), then per part the radius of a sphere about the part's centre that holds
// it (m) and the part packed as a convex shape.
#define CFEM_SHAPE_LAYOUT(COLUMN, NUMBER)                                                  \
  COLUMN(convex, SH_KIND, 0, 1)                                                            \
  COLUMN(convex, SH_SIZE, 1, 3)                                                            \
  COLUMN(convex, SH_AXES, 4, 9)                                                            \
  COLUMN(convex, SH_CENTRE, 13, 3)                                                         \
  COLUMN(convex, SH_VERTICES, 16, 1)                                                       \
  COLUMN(compound, SH_PARTS, 1, 1)                                                         \
  NUMBER(int, HEADER, 17)                                                                  \
  NUMBER(int, KIND_SPHERE, 0)                                                              \
  NUMBER(int, KIND_CAPSULE, 1)                                                             \
  NUMBER(int, KIND_BOX, 2)                                                                 \
  NUMBER(int, KIND_CYLINDER, 3)                                                            \
  NUMBER(int, KIND_HULL, 4)                                                                \
  NUMBER(int, KIND_COMPOUND, 5)

// ``delta`` of project (n, WIDTH): per body the velocity correction of its CG and of its
// angular velocity (world axes, m/s and rad/s).
#define CFEM_TWIST_LAYOUT(COLUMN, NUMBER)                                                  \
  COLUMN(body, V_LINEAR, 0, 3)                                                             \
  COLUMN(body, V_ANGULAR, 3, 3)                                                            \
  NUMBER(int, WIDTH, 6)

// ``points`` of the shape distance (aeroshapes.cpp's distance, (k, WIDTH); loads.cpp's
// contact_gap): the closest (or, overlapping, deepest) point on shape a, then on b (world,
// m).
#define CFEM_CLOSEST_LAYOUT(COLUMN, NUMBER)                                                \
  COLUMN(pair, P_A, 0, 3)                                                                  \
  COLUMN(pair, P_B, 3, 3)                                                                  \
  NUMBER(int, WIDTH, 6)

// A body's track between its samples (between.hpp; study.between.motion makes it), one row
// per sample: CG position (world, m) and quaternion (x y z w, body to world, each on the
// side of the one before), then their rates in the same order: CG velocity (world, m/s)
// and the quaternion's rate of change (1/s). The cubic Hermite interpolant of the VALUES
// values from them.
#define CFEM_TRACK_LAYOUT(COLUMN, NUMBER)                                                  \
  COLUMN(sample, T_POSITION, 0, 3)                                                         \
  COLUMN(sample, T_QUATERNION, 3, 4)                                                       \
  COLUMN(sample, T_VELOCITY, 7, 3)                                                         \
  COLUMN(sample, T_QUATERNION_RATE, 10, 4)                                                 \
  NUMBER(int, VALUES, 7)                                                                   \
  NUMBER(int, RATES, 7)                                                                    \
  NUMBER(int, WIDTH, 14)

// ``out`` of least_between (between.cpp): the least distance over a window (m) and its
// time (s), both bodies' poses there (CG position, world, m; unit quaternion x y z w) and,
// between sets of points, the pair's indices (-1 between shapes).
#define CFEM_LEAST_LAYOUT(COLUMN, NUMBER)                                                  \
  COLUMN(found, L_DISTANCE, 0, 1)                                                          \
  COLUMN(found, L_TIME, 1, 1)                                                              \
  COLUMN(found, L_POSE_A, 2, 7)                                                            \
  COLUMN(found, L_POSE_B, 9, 7)                                                            \
  COLUMN(found, L_POINT_A, 16, 1)                                                          \
  COLUMN(found, L_POINT_B, 17, 1)                                                          \
  NUMBER(int, WIDTH, 18)

// A sample's outputs (sampling.cpp's sample_outputs; size: sample_size): per body BODY
// numbers: its CG position (world, m), quaternion (x y z w, body to world), CG velocity
// and angular velocity (body axes, m/s and rad/s); then per joint sampled JOINT numbers:
// its force and moment on the child (world axes, N and N m about the joint point); then
// per applied source (a scheduled wrench, its reaction, a brace, an aero table) WRENCH
// numbers: force and moment about the CG of the body it acts on (world axes); then per
// body with aero tables AIR numbers (loads.cpp's sample_applied): alpha, beta (deg),
// Mach, dynamic pressure (Pa), density (kg/m^3), airspeed (m/s), CX, CY, CZ, and Cl, Cm,
// Cn about the CG; then per body sampled in a reference's frame BODY numbers, the same
// columns in the reference's frame and axes (motion.cpp's sample_relative, last).
#define CFEM_SAMPLE_LAYOUT(COLUMN, NUMBER)                                                 \
  COLUMN(body, O_POSITION, 0, 3)                                                           \
  COLUMN(body, O_QUATERNION, 3, 4)                                                         \
  COLUMN(body, O_VELOCITY, 7, 3)                                                           \
  COLUMN(body, O_RATES, 10, 3)                                                             \
  NUMBER(int, BODY, 13)                                                                    \
  COLUMN(joint, O_FORCE, 0, 3)                                                             \
  COLUMN(joint, O_MOMENT, 3, 3)                                                            \
  NUMBER(int, JOINT, 6)                                                                    \
  COLUMN(applied, O_WRENCH_FORCE, 0, 3)                                                    \
  COLUMN(applied, O_WRENCH_MOMENT, 3, 3)                                                   \
  NUMBER(int, WRENCH, 6)                                                                   \
  COLUMN(air, O_ALPHA, 0, 1)                                                               \
  COLUMN(air, O_BETA, 1, 1)                                                                \
  COLUMN(air, O_MACH, 2, 1)                                                                \
  COLUMN(air, O_PRESSURE, 3, 1)                                                            \
  COLUMN(air, O_DENSITY, 4, 1)                                                             \
  COLUMN(air, O_SPEED, 5, 1)                                                               \
  COLUMN(air, O_FORCE_COEFFICIENTS, 6, 3)                                                  \
  COLUMN(air, O_MOMENT_COEFFICIENTS, 9, 3)                                                 \
  NUMBER(int, AIR, 12)

// An odometry input (inputs.py's ``Input.values``, from a nav_msgs/Odometry message,
// REP-105): CG position (world, m), quaternion (x y z w, body to world), CG velocity and
// angular velocity (body axes, m/s and rad/s): a sample's body columns (O_*), in the same
// order. The kernel reads no such vector (engine/carrier.py packs a kinematic body's
// trajectory from its four parts); its table is here so that Python reads its columns
// (kernel.ODOMETRY) from the one file that lays out the others.
#define CFEM_ODOMETRY_LAYOUT(COLUMN, NUMBER)                                               \
  COLUMN(message, D_POSITION, 0, 3)                                                        \
  COLUMN(message, D_QUATERNION, 3, 4)                                                      \
  COLUMN(message, D_VELOCITY, 7, 3)                                                        \
  COLUMN(message, D_RATES, 10, 3)                                                          \
  NUMBER(int, WIDTH, 13)

// ``air`` of the vectorised aerodynamic wrench (aeroshapes.cpp's aero_wrench, (k, WIDTH)):
// alpha, beta (rad), Mach, airspeed (m/s), density (kg/m^3), altitude (m), the
// coefficients CX .. Cn (free stream, increments and delta; moments about the reference
// point), the proximity increments (6), the dynamic pressure (Pa), Cl, Cm, Cn about the
// CG (damping included).
#define CFEM_AERO_AIR_LAYOUT(COLUMN, NUMBER)                                               \
  COLUMN(air, W_ALPHA, 0, 1)                                                               \
  COLUMN(air, W_BETA, 1, 1)                                                                \
  COLUMN(air, W_MACH, 2, 1)                                                                \
  COLUMN(air, W_SPEED, 3, 1)                                                               \
  COLUMN(air, W_DENSITY, 4, 1)                                                             \
  COLUMN(air, W_ALTITUDE, 5, 1)                                                            \
  COLUMN(air, W_COEFFICIENTS, 6, 6)                                                        \
  COLUMN(air, W_INCREMENTS, 12, 6)                                                         \
  COLUMN(air, W_PRESSURE, 18, 1)                                                           \
  COLUMN(air, W_ABOUT_CG, 19, 3)                                                           \
  NUMBER(int, WIDTH, 22)

// The integrator's state y of n bodies (13 n numbers), in blocks of all bodies: a block
// starts at first * n and holds width numbers per body: CG positions (world, m), CG
// velocities (world, m/s), quaternions (x y z w, body to world), angular velocities (body
// axes, rad/s). Body i's numbers of a block are at first * n + width * i.
#define CFEM_STATE_LAYOUT(COLUMN, NUMBER)                                                  \
  COLUMN(block, Y_POSITION, 0, 3)                                                          \
  COLUMN(block, Y_VELOCITY, 3, 3)                                                          \
  COLUMN(block, Y_QUATERNION, 6, 4)                                                        \
  COLUMN(block, Y_RATES, 10, 3)                                                            \
  NUMBER(int, BODY, 13)

#define CFEM_LAYOUT_COLUMN(group, name, first, width) constexpr int name = first;
#define CFEM_LAYOUT_NUMBER(type, name, value) constexpr type name = value;

namespace cfem {
namespace motion {
CFEM_BODIES_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace motion
namespace loads {
CFEM_LOADS_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace loads
namespace aero_table {
CFEM_AERO_TABLE_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace aero_table
namespace plan_layout {
CFEM_PLAN_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace plan_layout
namespace rows_i {
CFEM_ROWS_I_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace rows_i
namespace rows_f {
CFEM_ROWS_F_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace rows_f
namespace joints_i {
CFEM_JOINTS_I_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace joints_i
namespace joints_f {
CFEM_JOINTS_F_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace joints_f
namespace advance_info {
CFEM_ADVANCE_INFO_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace advance_info
namespace locate_info {
CFEM_LOCATE_INFO_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace locate_info
namespace sample {
CFEM_SAMPLE_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace sample
namespace odometry {
CFEM_ODOMETRY_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace odometry
namespace aero_air {
CFEM_AERO_AIR_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace aero_air
namespace trajectory {
CFEM_TRAJECTORY_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace trajectory
namespace shape_layout {
CFEM_SHAPE_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace shape_layout
namespace twist {
CFEM_TWIST_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace twist
namespace closest {
CFEM_CLOSEST_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace closest
namespace track {
CFEM_TRACK_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace track
namespace least {
CFEM_LEAST_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
}  // namespace least
namespace state {
CFEM_STATE_LAYOUT(CFEM_LAYOUT_COLUMN, CFEM_LAYOUT_NUMBER)
// The kernel reads y through these offsets, never a number of its own.
#define CFEM_STATE_WIDTH(group, name, first, width) block == first ? width :
#define CFEM_STATE_SKIP(type, name, value)
// The width of the block that starts at block * n (0: no block starts there).
constexpr int width(int block) {
  return CFEM_STATE_LAYOUT(CFEM_STATE_WIDTH, CFEM_STATE_SKIP) 0;
}
#undef CFEM_STATE_WIDTH
#undef CFEM_STATE_SKIP
// Where body i's numbers of a block (Y_*) start in the state y of n bodies.
template <int block, class N, class I>
constexpr auto at(N n, I i) {
  static_assert(width(block) > 0, "not a block of the state");
  return block * n + width(block) * i;
}
template <class N, class I>
constexpr auto position(N n, I i) { return at<Y_POSITION>(n, i); }
template <class N, class I>
constexpr auto velocity(N n, I i) { return at<Y_VELOCITY>(n, i); }
template <class N, class I>
constexpr auto quaternion(N n, I i) { return at<Y_QUATERNION>(n, i); }
template <class N, class I>
constexpr auto rates(N n, I i) { return at<Y_RATES>(n, i); }
// The state's size for n bodies.
template <class N>
constexpr auto size(N n) { return BODY * n; }
}  // namespace state
}  // namespace cfem

#undef CFEM_LAYOUT_COLUMN
#undef CFEM_LAYOUT_NUMBER
