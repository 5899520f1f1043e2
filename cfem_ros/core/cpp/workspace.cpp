// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
#include "workspace.hpp"

#include <initializer_list>

namespace cfem {

namespace {

idx product(std::initializer_list<idx> shape) {
  idx size = 1;
  for (idx d : shape) size *= d;
  return size;
}

}  // namespace

std::vector<Part> workspace_parts(idx n, idx m, idx nj, idx dense) {
  std::vector<Part> parts;
  idx offset = 0;
#define CFEM_WORK_ADD(name, ...)                 \
  parts.push_back({#name, offset, {__VA_ARGS__}}); \
  offset += product({__VA_ARGS__});
  CFEM_WORK_PARTS(CFEM_WORK_ADD)
#undef CFEM_WORK_ADD
  return parts;
}

idx workspace_size(idx n, idx m, idx nj, idx dense) {
  idx size = 0;
#define CFEM_WORK_SIZE(name, ...) size += product({__VA_ARGS__});
  CFEM_WORK_PARTS(CFEM_WORK_SIZE)
#undef CFEM_WORK_SIZE
  return size;
}

Work carve(double* work, idx n, idx m, idx nj, idx dense) {
  Work w;
  double* o = work;
#define CFEM_WORK_CUT(name, ...) \
  w.name = o;                    \
  o += product({__VA_ARGS__});
  CFEM_WORK_PARTS(CFEM_WORK_CUT)
#undef CFEM_WORK_CUT
  return w;
}

}  // namespace cfem
