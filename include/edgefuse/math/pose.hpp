// Rigid transforms (SE(3)) with fixed-size Eigen types.
//
// Convention (whole project): `T_a_b` maps points from frame b to frame a: p_a = T_a_b * p_b.
// A sensor pose in the world is T_world_sensor (sensor-to-world), as in TUM's groundtruth.txt.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace edgefuse {

using Vec3f = Eigen::Matrix<float, 3, 1>;
using Mat3f = Eigen::Matrix<float, 3, 3>;
using Mat4f = Eigen::Matrix<float, 4, 4>;
using Vec6f = Eigen::Matrix<float, 6, 1>;

struct Pose {
  Mat3f R = Mat3f::Identity();  //!< rotation (orthonormal, det +1)
  Vec3f t = Vec3f::Zero();      //!< translation in metres

  static Pose identity() { return Pose{}; }
  //! From a translation and a unit quaternion (Hamilton, scalar last as in TUM files).
  static Pose from_tq(float tx, float ty, float tz, float qx, float qy, float qz, float qw) {
    Pose p;
    p.R = Eigen::Quaternionf(qw, qx, qy, qz).normalized().toRotationMatrix();
    p.t = Vec3f(tx, ty, tz);
    return p;
  }
  //! From a row-major 4x4 homogeneous matrix (last row ignored).
  static Pose from_matrix(const Mat4f& m) {
    Pose p;
    p.R = m.block<3, 3>(0, 0);
    p.t = m.block<3, 1>(0, 3);
    return p;
  }
  Mat4f matrix() const {
    Mat4f m = Mat4f::Identity();
    m.block<3, 3>(0, 0) = R;
    m.block<3, 1>(0, 3) = t;
    return m;
  }
  //! Unit quaternion of R with w >= 0.
  Eigen::Quaternionf quaternion() const {
    Eigen::Quaternionf q(R);
    q.normalize();
    if (q.w() < 0) q.coeffs() = -q.coeffs();
    return q;
  }
  Pose inverse() const {
    Pose p;
    p.R = R.transpose();
    p.t = -(p.R * t);
    return p;
  }
  Vec3f operator*(const Vec3f& x) const { return R * x + t; }
  Pose operator*(const Pose& o) const {
    Pose p;
    p.R = R * o.R;
    p.t = R * o.t + t;
    return p;
  }
  //! Rotation angle in radians (0..pi).
  float angle_rad() const {
    const float c = 0.5f * (R.trace() - 1.0f);
    return std::acos(c > 1.0f ? 1.0f : (c < -1.0f ? -1.0f : c));
  }
};

//! The pose a fraction s of the way from a to b at constant velocity: the translation on the line
//! through a.t and b.t, the rotation on the geodesic from a.R to b.R (in a's frame). s = 0 gives
//! a, s = 1 gives b; s outside [0, 1] extrapolates at the same velocity (the relative rotation
//! from a to b must be below 180 degrees, as between two frames of one sensor).
//! \param a pose at s = 0  \param b pose at s = 1  \param s fraction (time between them, scaled)
inline Pose interpolate(const Pose& a, const Pose& b, float s) {
  const Eigen::AngleAxisf step(Mat3f(a.R.transpose() * b.R));
  Pose p;
  p.R = a.R * Eigen::AngleAxisf(s * step.angle(), step.axis()).toRotationMatrix();
  p.t = a.t + s * (b.t - a.t);
  return p;
}

}  // namespace edgefuse
