#include "edgefuse/tracking/se3.hpp"

#include <cmath>

namespace edgefuse {

namespace {
Mat3f skew(const Vec3f& w) {
  Mat3f s;
  s << 0.0f, -w.z(), w.y(), w.z(), 0.0f, -w.x(), -w.y(), w.x(), 0.0f;
  return s;
}
}  // namespace

Pose se3_exp(const Vec6f& xi) {
  const Vec3f w = xi.head<3>();
  const Vec3f v = xi.tail<3>();
  const float theta2 = w.squaredNorm();
  const Mat3f W = skew(w);
  const Mat3f W2 = W * W;
  float a, b, c;  // sin t / t, (1 - cos t) / t^2, (t - sin t) / t^3
  if (theta2 < 1e-8f) {
    a = 1.0f - theta2 / 6.0f;
    b = 0.5f - theta2 / 24.0f;
    c = 1.0f / 6.0f - theta2 / 120.0f;
  } else {
    const float t = std::sqrt(theta2);
    a = std::sin(t) / t;
    b = (1.0f - std::cos(t)) / theta2;
    c = (t - std::sin(t)) / (theta2 * t);
  }
  Pose p;
  p.R = Mat3f::Identity() + a * W + b * W2;
  p.t = (Mat3f::Identity() + b * W + c * W2) * v;
  return p;
}

Mat3f orthonormalise(const Mat3f& R) { return Eigen::Quaternionf(R).normalized().toRotationMatrix(); }

void pose_distance(const Pose& a, const Pose& b, float& dt_m, float& angle_rad) {
  dt_m = (b.t - a.t).norm();
  // From the quaternion's vector part: accurate for small angles, where acos of the trace is not
  // (float resolution of the trace alone limits acos to ~0.02 degrees).
  const Eigen::Quaternionf q(Mat3f(a.R.transpose() * b.R));
  angle_rad = 2.0f * std::atan2(q.vec().norm(), std::fabs(q.w()));
}

}  // namespace edgefuse
