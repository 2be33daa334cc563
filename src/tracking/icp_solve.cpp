#include "edgefuse/tracking/icp_solve.hpp"

#include <Eigen/Cholesky>

#include "edgefuse/tracking/observability.hpp"

namespace edgefuse {

bool solve_icp_step(const IcpSystem& s, const ViewObservability& view, Vec6f& xi) {
  xi.setZero();
  if (s.count <= 0 || view.count <= 0) return false;
  const float inv_l = 1.0f / view.scale_m;
  Vec6f scale;
  scale << inv_l, inv_l, inv_l, 1.0f, 1.0f, 1.0f;
  const Mat6f& V = view.basis;
  Mat6f B = V.transpose() * (scale.asDiagonal() * s.A * scale.asDiagonal()) * V;
  Vec6f c = V.transpose() * (scale.asDiagonal() * s.b);
  // Unobservable rows / columns -> identity scaled like the rest (keeps the pivots comparable).
  float pad = 0.0f;
  for (int i = 0; i < 6; ++i)
    if (view.observable[i]) pad += B(i, i);
  pad = pad > 0.0f ? pad / float(view.count) : 1.0f;
  for (int i = 0; i < 6; ++i) {
    if (view.observable[i]) continue;
    B.row(i).setZero();
    B.col(i).setZero();
    B(i, i) = pad;
    c(i) = 0.0f;
  }
  const Eigen::LDLT<Mat6f> ldlt(B);  // fixed size: no heap
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return false;
  // The correspondences must support every observable direction (numerically): a pivot near zero
  // would turn noise into a huge step.
  const Vec6f d = ldlt.vectorD();
  if (!(d.minCoeff() > 1e-6f * d.maxCoeff())) return false;
  const Vec6f y = ldlt.solve(-c);
  if (!y.allFinite()) return false;
  xi = scale.asDiagonal() * (V * y);
  return true;
}

}  // namespace edgefuse
