#include "edgefuse/fusion/calibrate_pair.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <cstdio>

#include "edgefuse/tracking/observability.hpp"

namespace edgefuse {
namespace {

// Names the pose directions an unobservable eigenvector (scaled space: rotation * L, translation)
// mostly moves, e.g. "translation along x, rotation about z".
void name_direction(const Vec6f& v, char* buf, int size) {
  static const char* kNames[6] = {"rotation about x", "rotation about y", "rotation about z",
                                  "translation along x", "translation along y", "translation along z"};
  int n = 0;
  buf[0] = 0;
  for (int i = 0; i < 6; ++i)
    if (std::fabs(v(i)) > 0.4f && n < size)
      n += std::snprintf(buf + n, std::size_t(size - n), "%s%s", n ? " + " : "", kNames[i]);
  if (n == 0) std::snprintf(buf, std::size_t(size), "a mixed direction");
}

// Point-to-plane system of B's full-resolution points against the model at the final pose.
template <class Real>
void final_system(const FramePyramid<Real>& frame, const RaycastMaps& model, const PinholeIntrinsics& intr,
                  float max_distance_m, float max_normal_deg, Eigen::Matrix<double, 6, 6>& A, double& rr, int& n) {
  A.setZero();
  rr = 0;
  n = 0;
  const float cos_max = std::cos(max_normal_deg * 3.14159265f / 180.0f);
  const PyramidLevel<Real>& l0 = frame.level[0];
  for (int v = 0; v < l0.vertex.height; ++v)
    for (int u = 0; u < l0.vertex.width; ++u) {
      const Vec3f p = to_vec3f(l0.vertex.at(u, v));
      const Vec3f pn = to_vec3f(l0.normal.at(u, v));
      if (!(p.z() > 0.0f) || pn.squaredNorm() < 0.25f) continue;
      float pu, pv;
      if (!intr.project(p, pu, pv)) continue;
      const int iu = int(pu + 0.5f), iv = int(pv + 0.5f);
      if (iu < 0 || iv < 0 || iu >= intr.width || iv >= intr.height) continue;
      const Vec3f& q = model.vertex.at(iu, iv);
      const Vec3f& nm = model.normal.at(iu, iv);
      if (nm.squaredNorm() < 0.25f || (p - q).norm() > max_distance_m || pn.dot(nm) < cos_max) continue;
      const float r = nm.dot(p - q);
      Eigen::Matrix<double, 6, 1> J;
      const Vec3f c = p.cross(nm);
      J << c.x(), c.y(), c.z(), nm.x(), nm.y(), nm.z();
      A += J * J.transpose();
      rr += double(r) * r;
      ++n;
    }
}

}  // namespace

bool PairCalibrationParams::valid() const {
  if (stages < 1 || stages > kMaxStages || rounds_per_stage < 1 || !(max_rms_m > 0) || !(min_inlier_ratio >= 0) ||
      min_inlier_ratio > 1 || min_correspondences < 6 || !(min_pixel_fraction >= 0) || min_pixel_fraction > 1 ||
      !(max_sigma_m > 0) || !(max_sigma_deg > 0) || !(min_eigen_ratio > 0) || min_eigen_ratio >= 1 ||
      observability_tiles < 1)
    return false;
  for (int i = 0; i < stages; ++i)
    if (!(max_distance_m[i] > 0) || !(max_normal_deg[i] > 0) || max_normal_deg[i] > 90) return false;
  return true;
}

int PairCalibrationParams::required_correspondences(int pixels) const {
  const int scaled = int(std::ceil(double(min_pixel_fraction) * double(pixels)));
  return scaled > min_correspondences ? scaled : min_correspondences;
}

template <class Real>
Status calibrate_pair(const TsdfVolume& volume, const Pose& T_world_a, const Pose& T_a_b_guess,
                      const PinholeIntrinsics& intr_b, const FramePyramid<Real>& frame_b, const RaycastMaps& maps_b,
                      const IcpWorkspace<Real>& ws, const PairCalibrationParams& params,
                      PairCalibrationResult& out, const RowRunner* runner) {
  out = PairCalibrationResult{};
  out.T_a_b = T_a_b_guess;
  if (!params.valid() || maps_b.vertex.empty() || maps_b.normal.empty()) return Status::kInvalidArgument;
  Pose T = T_a_b_guess;
  IcpStats stats;
  const int required = params.required_correspondences(intr_b.width * intr_b.height);
  for (int stage = 0; stage < params.stages; ++stage) {
    IcpParams icp;
    icp.max_distance_m = params.max_distance_m[stage];
    icp.max_normal_angle_deg = params.max_normal_deg[stage];
    icp.robust_scale_m = params.max_distance_m[stage] * 0.5f;
    icp.min_eigen_ratio = params.min_eigen_ratio;
    icp.observability_tiles = params.observability_tiles;
    icp.min_correspondences = required / 4 > 6 ? required / 4 : 6;
    for (int round = 0; round < params.rounds_per_stage; ++round) {
      Status s = raycast<Real>(volume, intr_b, T_world_a * T, maps_b);
      if (s != Status::kOk) return s;
      Pose T_model_frame;
      s = icp_align<Real>(frame_b, maps_b, intr_b, Pose::identity(), icp, ws, T_model_frame, stats, runner);
      if (s != Status::kOk) return s;
      if (stats.refused) break;
      T = T * T_model_frame;
      if (T_model_frame.t.norm() < 1e-5f && T_model_frame.angle_rad() < 1e-5f) break;
    }
  }
  out.T_a_b = T;
  // Final evaluation at the estimate.
  Status s = raycast<Real>(volume, intr_b, T_world_a * T, maps_b);
  if (s != Status::kOk) return s;
  ViewObservability view;
  s = view_observability(maps_b, intr_b.width / params.observability_tiles > 0 ? intr_b.width / params.observability_tiles : 1,
                         params.min_eigen_ratio, view);
  if (s != Status::kOk) return s;
  out.observable = view.count;
  out.weakest_ratio = view.weakest_ratio;
  const int last = params.stages - 1;
  Eigen::Matrix<double, 6, 6> A;
  double rr;
  int n;
  final_system(frame_b, maps_b, intr_b, params.max_distance_m[last], params.max_normal_deg[last], A, rr, n);
  out.correspondences = n;
  out.rms_m = n > 0 ? float(std::sqrt(rr / n)) : 0.0f;
  out.inlier_ratio = stats.inlier_ratio();

  if (view.count < 6) {
    char missing[120] = {};
    int k = 0;
    for (int i = 0; i < 6 && k < int(sizeof(missing)) - 40; ++i)
      if (!view.observable[i]) {
        char d[80];
        name_direction(view.basis.col(i), d, int(sizeof(d)));
        k += std::snprintf(missing + k, sizeof(missing) - std::size_t(k), "%s%s", k ? "; " : "", d);
      }
    if (view.count == 0)
      std::snprintf(out.reason, sizeof(out.reason), "B sees no fused surface at the guessed mounting");
    else if (view.count <= 3)
      std::snprintf(out.reason, sizeof(out.reason),
                    "scene is a single plane (constrains %d of 6 directions; free: %s)", view.count, missing);
    else
      std::snprintf(out.reason, sizeof(out.reason), "scene constrains only %d of 6 directions (free: %s)", view.count,
                    missing);
    return Status::kOk;
  }
  if (stats.refused || stats.observable < 6) {
    std::snprintf(out.reason, sizeof(out.reason), "registration failed (%d correspondences, %d directions solved)",
                  stats.correspondences, stats.observable);
    return Status::kOk;
  }
  if (n < required) {
    std::snprintf(out.reason, sizeof(out.reason), "too little overlap: %d correspondences (< %d for %dx%d)", n,
                  required, intr_b.width, intr_b.height);
    return Status::kOk;
  }
  if (out.rms_m > params.max_rms_m) {
    std::snprintf(out.reason, sizeof(out.reason), "residual too large: rms %.2f mm (> %.2f mm)", 1e3f * out.rms_m,
                  1e3f * params.max_rms_m);
    return Status::kOk;
  }
  if (out.inlier_ratio < params.min_inlier_ratio) {
    std::snprintf(out.reason, sizeof(out.reason), "too few inliers: %.2f (< %.2f)", out.inlier_ratio,
                  params.min_inlier_ratio);
    return Status::kOk;
  }
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(A);
  const Eigen::Matrix<double, 6, 6> cov = (rr / double(n - 6)) * ldlt.solve(Eigen::Matrix<double, 6, 6>::Identity());
  for (int i = 0; i < 6; ++i) out.sigma(i) = float(std::sqrt(cov(i, i) > 0 ? cov(i, i) : 0.0));
  const float sigma_rot_deg = out.sigma.head<3>().maxCoeff() * 57.2957795f;
  const float sigma_trans_m = out.sigma.tail<3>().maxCoeff();
  if (sigma_trans_m > params.max_sigma_m || sigma_rot_deg > params.max_sigma_deg) {
    std::snprintf(out.reason, sizeof(out.reason),
                  "too uncertain: 1-sigma %.2f mm / %.3f deg (> %.2f mm / %.3f deg)", 1e3f * sigma_trans_m,
                  sigma_rot_deg, 1e3f * params.max_sigma_m, params.max_sigma_deg);
    return Status::kOk;
  }
  out.accepted = true;
  return Status::kOk;
}

#define EDGEFUSE_INSTANTIATE(Real)                                                                                 \
  template Status calibrate_pair<Real>(const TsdfVolume&, const Pose&, const Pose&, const PinholeIntrinsics&,     \
                                       const FramePyramid<Real>&, const RaycastMaps&,                            \
                                       const IcpWorkspace<Real>&, const PairCalibrationParams&,                  \
                                       PairCalibrationResult&, const RowRunner*);
EDGEFUSE_INSTANTIATE(float)
EDGEFUSE_INSTANTIATE(Fixed)
#undef EDGEFUSE_INSTANTIATE

}  // namespace edgefuse
