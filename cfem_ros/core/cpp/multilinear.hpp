// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// Multilinear interpolation on a regular (rectilinear) grid, held at its ends,
// and the fade of a table outside its grid (SPEC section 8). Pure functions
// over flat arrays: no allocation, no checks (the Python side checks once).
#pragma once

#include <cmath>

namespace cfem {

//: Most axes of an interpolated grid (alpha, beta, Mach; or dx .. dpsi, Mach).
constexpr int kMaxAxes = 8;
//: Most numbers per node of an interpolated table (six coefficients).
constexpr int kMaxWidth = 8;

// Reads a packed table: p[k] its k-th number. Flat: a plain array; Rows: the table
// kept in the first kRowData columns of rows of kRowWidth (loads.py's packed loads, whose
// last column says what a row is).
// read(k, count, out): numbers k .. k + count - 1 into out, one index computation.
struct Flat {
  const double* data;
  double operator[](long k) const { return data[k]; }
  void read(long k, int count, double* out) const {
    for (int i = 0; i < count; ++i) out[i] = data[k + i];
  }
};
constexpr long kRowWidth = 24, kRowData = 23;
struct Rows {
  static_assert(kRowWidth == kRowData + 1, "one kind column a row");
  const double* data;
  // row k / kRowData, column k % kRowData: k plus the kind columns of the rows before
  double operator[](long k) const { return data[k + k / kRowData]; }
  void read(long k, int count, double* out) const {
    long column = k % kRowData;
    const double* at = data + k + k / kRowData;
    if (column + count <= kRowData) {   // all in one row
      for (int i = 0; i < count; ++i) out[i] = at[i];
      return;
    }
    for (int i = 0; i < count; ++i) {
      if (column == kRowData) {   // on to the next row, past its kind column
        column = 0;
        ++at;
      }
      out[i] = *at++;
      ++column;
    }
  }
};

// x between grid[at + i] and grid[at + i + 1] at fraction u in [0, 1]; held at the ends
// (u = 0 at the first node or below, u = 1 at the last or above). One node: i = 0, u = 0.
template <class P>
inline void bracket(const P& grid, long at, int count, double x, int& i, double& u) {
  if (count < 2 || !(x > grid[at])) {  // NaN goes to the first node
    i = 0;
    u = 0.0;
    return;
  }
  if (x >= grid[at + count - 1]) {
    i = count - 2;
    u = 1.0;
    return;
  }
  int lo = 0, hi = count - 1;  // grid[lo] < x < grid[hi]
  while (hi - lo > 1) {
    int mid = (lo + hi) / 2;
    if (grid[at + mid] <= x) lo = mid; else hi = mid;
  }
  i = lo;
  u = (x - grid[at + lo]) / (grid[at + lo + 1] - grid[at + lo]);
}

// Interpolate `width` numbers per node at x (one number per axis) into out.
// axes: number of axes (<= kMaxAxes); sizes[d]: nodes along axis d; p[grids ..]: the
// axes' values one after the other (sizes[0] numbers, then sizes[1], ...);
// p[values ..]: width numbers per node, the first axis slowest (C order).
template <class P>
inline void multilinear(int axes, const int* sizes, const P& p, long grids, long values,
                        int width, const double* x, double* out) {
  // the cell once: each corner's weight (the axes' factors multiplied in axis order) and
  // node, built axis by axis over the 2^axes corners (corner bit d: upper side of axis d)
  double weight[1 << kMaxAxes];
  long node[1 << kMaxAxes];
  weight[0] = 1.0;
  node[0] = 0;
  long stride[kMaxAxes];   // nodes from one to the next along axis d
  stride[axes - 1] = 1;
  for (int d = axes - 1; d > 0; --d) stride[d - 1] = stride[d] * sizes[d];
  long grid = grids;
  for (int d = 0; d < axes; ++d) {
    int base;
    double frac;
    bracket(p, grid, sizes[d], x[d], base, frac);
    grid += sizes[d];
    // an axis with one node adds nothing from its upper side (weights are finite, >= 0)
    const double upper = sizes[d] < 2 ? 0.0 : frac, lower = 1.0 - frac;
    const long below = base * stride[d], above = below + stride[d];
    const int half = 1 << d;
    for (int c = 0; c < half; ++c) {
      weight[c + half] = weight[c] * upper;
      node[c + half] = node[c] + above;
      weight[c] *= lower;
      node[c] += below;
    }
  }
  for (int k = 0; k < width; ++k) out[k] = 0.0;
  for (int corner = 0; corner < (1 << axes); ++corner) {
    if (weight[corner] == 0.0) continue;
    double numbers[kMaxWidth];
    p.read(values + node[corner] * width, width, numbers);
    for (int k = 0; k < width; ++k) out[k] += weight[corner] * numbers[k];
  }
}

// Weight of a table at x outside its grid: 1 inside, falling linearly to 0 at
// `fade` (same unit as the axes, m) from the grid's box, the distance measured
// over the axes with position[d] != 0 only. fade <= 0: held (always 1).
template <class P>
inline double fade_weight(int axes, const int* sizes, const P& p, long grids,
                          const int* position, const double* x, double fade) {
  if (!(fade > 0.0)) return 1.0;
  double gap2 = 0.0;
  long grid = grids;
  for (int d = 0; d < axes; ++d) {
    if (position[d]) {
      double lo = p[grid], hi = p[grid + sizes[d] - 1];
      double gap = x[d] < lo ? lo - x[d] : (x[d] > hi ? x[d] - hi : 0.0);
      gap2 += gap * gap;
    }
    grid += sizes[d];
  }
  double w = 1.0 - std::sqrt(gap2) / fade;
  return w > 0.0 ? w : 0.0;
}

}  // namespace cfem
