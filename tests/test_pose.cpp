// SE(3) poses: composition, inverse, quaternion round trips, convention T_a_b * p_b = p_a.
#include <cmath>

#include "edgefuse/math/pose.hpp"
#include "test_support.hpp"

using namespace edgefuse;

TEST_GROUP(Pose){};

TEST(Pose, InverseAndCompositionCancel) {
  const Pose T = Pose::from_tq(0.1f, -0.2f, 0.3f, 0.1f, 0.2f, -0.3f, 0.9f);
  const Pose I = T * T.inverse();
  CHECK(I.R.isIdentity(1e-6f));
  CHECK(I.t.norm() < 1e-6f);
  const Vec3f p(0.5f, -1.0f, 2.0f);
  CHECK((T.inverse() * (T * p) - p).norm() < 1e-6f);
}

TEST(Pose, ConventionMapsChildToParent) {
  // T_world_cam for a camera 1 m up the world z axis, looking down (-z): camera z = world -z.
  const Pose T_world_cam = Pose::from_tq(0, 0, 1, 1, 0, 0, 0);  // 180 deg about x
  const Vec3f p_cam(0, 0, 0.5f);                                 // half a metre in front
  CHECK((T_world_cam * p_cam - Vec3f(0, 0, 0.5f)).norm() < 1e-6f);
  const Pose T_a_b = Pose::from_tq(1, 0, 0, 0, 0, 0, 1), T_b_c = Pose::from_tq(0, 2, 0, 0, 0, 0, 1);
  CHECK(((T_a_b * T_b_c).t - Vec3f(1, 2, 0)).norm() < 1e-6f);
}

TEST(Pose, QuaternionRoundTripKeepsWNonNegative) {
  const Pose T = Pose::from_tq(0, 0, 0, -0.5f, -0.5f, -0.5f, -0.5f);
  const Eigen::Quaternionf q = T.quaternion();
  CHECK(q.w() >= 0);
  DOUBLES_EQUAL(0.5, q.x(), 1e-6);
  const Pose back = Pose::from_tq(0, 0, 0, q.x(), q.y(), q.z(), q.w());
  CHECK((back.R - T.R).norm() < 1e-6f);
  DOUBLES_EQUAL(2.0 * M_PI / 3.0, T.angle_rad(), 1e-5);
  const Pose M = Pose::from_matrix(T.matrix());
  CHECK((M.R - T.R).norm() < 1e-7f);
}

TEST(Pose, InterpolateFollowsConstantVelocity) {
  // 30 degrees about a tilted axis and 6 cm between a and b.
  const Vec3f axis = Vec3f(1, 2, 3).normalized();
  const float angle = float(M_PI / 6.0);
  Pose a = Pose::from_tq(0.1f, -0.2f, 0.7f, 0.1f, 0.2f, -0.3f, 0.9f);
  Pose step;
  step.R = Eigen::AngleAxisf(angle, axis).toRotationMatrix();
  step.t = Vec3f(0.02f, -0.04f, 0.04f);
  const Pose b = a * step;
  // The ends, and an exact midpoint: half the rotation about the same axis, halfway between.
  CHECK((interpolate(a, b, 0.0f).R - a.R).norm() < 1e-6f);
  CHECK((interpolate(a, b, 1.0f).R - b.R).norm() < 1e-5f);
  CHECK((interpolate(a, b, 1.0f).t - b.t).norm() < 1e-7f);
  const Pose mid = interpolate(a, b, 0.5f);
  CHECK((mid.R - a.R * Eigen::AngleAxisf(0.5f * angle, axis).toRotationMatrix()).norm() < 1e-5f);
  CHECK((mid.t - 0.5f * (a.t + b.t)).norm() < 1e-7f);
  // Extrapolation: s = 2 is one more step of the same rotation.
  const Pose after = interpolate(a, b, 2.0f);
  CHECK((after.R - b.R * step.R).norm() < 1e-5f);
  CHECK((after.t - (2.0f * b.t - a.t)).norm() < 1e-6f);
  // Still a rotation, and no motion when a = b.
  DOUBLES_EQUAL(1.0, mid.R.determinant(), 1e-5);
  CHECK((mid.R * mid.R.transpose()).isIdentity(1e-5f));
  CHECK((interpolate(a, a, 0.7f).R - a.R).norm() < 1e-6f);
}
