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
