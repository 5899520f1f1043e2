// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
#include "conditions.hpp"

#include <cmath>

#include "algebra.hpp"

namespace cfem {

void conditions(const double* y, idx size, const IMat& joints_i, const Mat& joints_f,
                const idx* watch, idx count, double* out, idx stride) {
  const idx n = size / state::BODY;
  double rot[9];
  for (idx w = 0; w < count; ++w) {
    idx k = watch[w];
    idx a = joints_i(k, 0), b = joints_i(k, 1);
    const double* qa = y + state::quaternion(n, a);
    const double* qb = y + state::quaternion(n, b);
    double na = std::sqrt(qa[0] * qa[0] + qa[1] * qa[1] + qa[2] * qa[2] + qa[3] * qa[3]);
    double nb = std::sqrt(qb[0] * qb[0] + qb[1] * qb[1] + qb[2] * qb[2] + qb[3] * qb[3]);
    // relative = conj(q0) * conj(qa) * qb, angle = 2 atan2(|v|, |w|)
    Q4 r = qmul(-qa[0] / na, -qa[1] / na, -qa[2] / na, qa[3] / na, qb[0] / nb, qb[1] / nb,
                qb[2] / nb, qb[3] / nb);
    const double* jf = joints_f.row(k);
    r = qmul(-jf[6], -jf[7], -jf[8], jf[9], r.x, r.y, r.z, r.w);
    out[w * stride] = 2.0 * std::atan2(std::sqrt(r.x * r.x + r.y * r.y + r.z * r.z), std::fabs(r.w));
    quat_matrix(qa[0], qa[1], qa[2], qa[3], rot);
    V3 pa = rotate(rot, jf[0], jf[1], jf[2]);
    quat_matrix(qb[0], qb[1], qb[2], qb[3], rot);
    V3 pb = rotate(rot, jf[3], jf[4], jf[5]);
    double total = 0.0;
    for (int i = 0; i < 3; ++i) {
      double gap = y[state::position(n, b) + i] + pb[i] - y[state::position(n, a) + i] - pa[i];
      total += gap * gap;
    }
    out[w * stride + 1] = std::sqrt(total);
  }
}

}  // namespace cfem
