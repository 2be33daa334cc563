#include "edgefuse/tsdf/register_profiles.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>

#include "edgefuse/tsdf/raycast.hpp"

namespace edgefuse {
namespace {

// D at p as a Euclidean distance (the projective TSDF divided by its gradient's length) and the
// unit gradient.
template <class Real>
bool distance_and_gradient(const TsdfVolume& v, const Vec3f& p, float& d, Vec3f& g) {
  if (!sample_tsdf<Real>(v, p, d)) return false;
  const float h = v.voxel_m();
  for (int a = 0; a < 3; ++a) {
    Vec3f e = Vec3f::Zero();
    e(a) = h;
    float dp, dm;
    if (!sample_tsdf<Real>(v, p + e, dp) || !sample_tsdf<Real>(v, p - e, dm)) return false;
    g(a) = (dp - dm) / (2.0f * h);
  }
  const float n = g.norm();
  if (!(n > 0.1f)) return false;  // flat field: truncated region, no surface direction
  g /= n;
  d /= n > 1.0f ? n : 1.0f;
  return true;
}

}  // namespace

template <class Real>
Status register_profiles(const TsdfVolume& volume, const LineScannerModel& model, const float* ranges_m,
                         const Pose* T_world_sensor, std::size_t count, const ProfileRegistrationParams& params,
                         ProfileRegistrationResult& out) {
  out = ProfileRegistrationResult{};
  if (!volume.initialised()) return Status::kNotInitialised;
  if (model.validate() != Status::kOk || ranges_m == nullptr || T_world_sensor == nullptr || count == 0 ||
      params.iterations < 1 || !(params.max_distance_m > 0) || params.point_step < 1 || params.min_points < 6)
    return Status::kInvalidArgument;
  // Centroid and radius of the patch's points (world frame, before correction).
  Vec3f c = Vec3f::Zero();
  long n = 0;
  for (std::size_t k = 0; k < count; ++k)
    for (int i = 0; i < model.beams; i += params.point_step) {
      const float r = ranges_m[k * std::size_t(model.beams) + std::size_t(i)];
      if (!(r >= model.min_range_m && r <= model.max_range_m)) continue;
      const float th = model.beam_angle_rad(i);
      c += T_world_sensor[k] * Vec3f(r * std::sin(th), 0.0f, r * std::cos(th));
      ++n;
    }
  if (n < params.min_points) return Status::kOk;
  c /= float(n);
  float radius2 = 0;
  for (std::size_t k = 0; k < count; ++k)
    for (int i = 0; i < model.beams; i += params.point_step) {
      const float r = ranges_m[k * std::size_t(model.beams) + std::size_t(i)];
      if (!(r >= model.min_range_m && r <= model.max_range_m)) continue;
      const float th = model.beam_angle_rad(i);
      radius2 += (T_world_sensor[k] * Vec3f(r * std::sin(th), 0.0f, r * std::cos(th)) - c).squaredNorm();
    }
  const float L = std::sqrt(radius2 / float(n)) > 1e-4f ? std::sqrt(radius2 / float(n)) : 1e-4f;

  Pose T;  // correction
  using Mat6d = Eigen::Matrix<double, 6, 6>;
  using Vec6d = Eigen::Matrix<double, 6, 1>;
  for (int it = 0; it < params.iterations; ++it) {
    Mat6d A = Mat6d::Zero();
    Vec6d b = Vec6d::Zero();
    double rr = 0;
    int used = 0;
    for (std::size_t k = 0; k < count; ++k)
      for (int i = 0; i < model.beams; i += params.point_step) {
        const float r = ranges_m[k * std::size_t(model.beams) + std::size_t(i)];
        if (!(r >= model.min_range_m && r <= model.max_range_m)) continue;
        const float th = model.beam_angle_rad(i);
        const Vec3f p = T * (T_world_sensor[k] * Vec3f(r * std::sin(th), 0.0f, r * std::cos(th)));
        float d;
        Vec3f g;
        if (!distance_and_gradient<Real>(volume, p, d, g) || std::fabs(d) > params.max_distance_m) continue;
        const Vec3f x = (p - c) / L;  // rotation columns scaled by the radius
        Vec6d J;
        const Vec3f xg = x.cross(g);
        J << xg.x(), xg.y(), xg.z(), g.x(), g.y(), g.z();
        // Huber weight at half a voxel: TSDF edges and corners are not distance fields.
        const double k = 0.5 * double(volume.voxel_m());
        const double w = std::fabs(d) <= k ? 1.0 : k / std::fabs(d);
        A += w * (J * J.transpose());
        b += w * (J * double(d));
        rr += double(d) * d;
        ++used;
      }
    out.points = used;
    out.rms_m = used > 0 ? float(std::sqrt(rr / used)) : 0.0f;
    if (used < params.min_points) return Status::kOk;
    Vec6d xi = Vec6d::Zero();
    if (params.translation_only) {
      const Eigen::Matrix3d At = A.block<3, 3>(3, 3);
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(At);
      const Eigen::Vector3d lambda = eig.eigenvalues();
      out.observable = 0;
      for (int a = 0; a < 3; ++a) out.observable += lambda(a) >= double(params.min_eigen_ratio) * lambda(2);
      if (out.observable < 3) return Status::kOk;
      xi.tail<3>() = -At.ldlt().solve(b.tail<3>());
    } else {
      const Eigen::SelfAdjointEigenSolver<Mat6d> eig(A);
      const Vec6d lambda = eig.eigenvalues();
      out.observable = 0;
      for (int a = 0; a < 6; ++a) out.observable += lambda(a) >= double(params.min_eigen_ratio) * lambda(5);
      if (out.observable < 6) return Status::kOk;
      xi = -A.ldlt().solve(b);
    }
    // Rotation omega / L about c, then translation.
    const Vec3f omega = Vec3f(float(xi(0)), float(xi(1)), float(xi(2))) / L;
    const Vec3f v(float(xi(3)), float(xi(4)), float(xi(5)));
    Pose step;
    if (omega.norm() > 0.0f) step.R = Eigen::AngleAxisf(omega.norm(), omega.normalized()).toRotationMatrix();
    step.t = c + v - step.R * c;
    T = step * T;
    if (v.norm() < 1e-7f && omega.norm() < 1e-7f) break;
  }
  out.T_correction = T;
  out.accepted = true;
  return Status::kOk;
}

template Status register_profiles<float>(const TsdfVolume&, const LineScannerModel&, const float*, const Pose*,
                                         std::size_t, const ProfileRegistrationParams&, ProfileRegistrationResult&);
template Status register_profiles<Fixed>(const TsdfVolume&, const LineScannerModel&, const float*, const Pose*,
                                         std::size_t, const ProfileRegistrationParams&, ProfileRegistrationResult&);

}  // namespace edgefuse
