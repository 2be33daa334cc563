#include "edgefuse/tracking/observability.hpp"

#include <Eigen/Eigenvalues>

namespace edgefuse {

Status view_observability(const RaycastMaps& model, int tile_px, float min_eigen_ratio, ViewObservability& out) {
  out = ViewObservability{};
  if (tile_px < 1 || !(min_eigen_ratio > 0.0f) || model.vertex.empty() || model.normal.empty() ||
      model.vertex.width != model.normal.width || model.vertex.height != model.normal.height)
    return Status::kInvalidArgument;
  // Tiles of float sums (at most a few thousand pixels each) into a double system.
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
  double z_sum = 0;
  long pixels = 0;
  const int w = model.normal.width, h = model.normal.height;
  for (int ty = 0; ty < h; ty += tile_px)
    for (int tx = 0; tx < w; tx += tile_px) {
      Vec3f p_sum = Vec3f::Zero(), n_sum = Vec3f::Zero();
      int c = 0;
      for (int v = ty; v < ty + tile_px && v < h; ++v)
        for (int u = tx; u < tx + tile_px && u < w; ++u) {
          const Vec3f& n = model.normal.at(u, v);
          if (n.x() == 0.0f && n.y() == 0.0f && n.z() == 0.0f) continue;
          n_sum += n;
          p_sum += model.vertex.at(u, v);
          ++c;
        }
      const float len = n_sum.norm();
      if (c == 0 || !(len > 0.0f)) continue;
      const Vec3f p = p_sum / float(c), n = n_sum / len;
      Eigen::Matrix<double, 6, 1> J;
      J << double(p.y() * n.z() - p.z() * n.y()), double(p.z() * n.x() - p.x() * n.z()),
          double(p.x() * n.y() - p.y() * n.x()), double(n.x()), double(n.y()), double(n.z());
      A += double(c) * (J * J.transpose());
      z_sum += double(c) * double(p.z());
      pixels += c;
    }
  if (pixels == 0 || !(z_sum > 0.0)) return Status::kOk;  // nothing seen: nothing observable
  out.scale_m = float(z_sum / double(pixels));
  const float inv_l = 1.0f / out.scale_m;
  Vec6f s;
  s << inv_l, inv_l, inv_l, 1.0f, 1.0f, 1.0f;
  const Mat6f As = s.asDiagonal() * A.cast<float>() * s.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Mat6f> eig(As);  // fixed size: no heap
  if (eig.info() != Eigen::Success) return Status::kOk;
  const Vec6f& lambda = eig.eigenvalues();  // ascending
  if (!(lambda(5) > 0.0f)) return Status::kOk;
  out.basis = eig.eigenvectors();
  out.weakest_ratio = lambda(0) > 0.0f ? lambda(0) / lambda(5) : 0.0f;
  for (int i = 0; i < 6; ++i) {
    out.observable[i] = lambda(i) >= min_eigen_ratio * lambda(5);
    out.count += out.observable[i];
  }
  return Status::kOk;
}

}  // namespace edgefuse
