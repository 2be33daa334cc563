// The tracking pieces on exact data, without the TSDF in between:
//  - ICP against analytic model maps (vertices and normals of the scene itself) recovers a known
//    1.5 degree / 8 mm offset to 0.02 mm and 0.002 degrees, in float and in Q16.16 (this is also the
//    check of the Jacobian's rotation sign: with n x p instead of p x n it diverges);
//  - float and fixed-point ICP agree to 0.05 mm / 0.005 degrees on the same input;
//  - on a single plane only distance and tilt are corrected, the rest stays exactly at the start;
//  - SE(3) exponential, push policy (|t_new - t_last|, not |t_new| - |t_last|), state thresholds,
//    pyramid geometry (intrinsics, block depth consistency, normals).
#include <cmath>
#include <type_traits>
#include <vector>

#include "edgefuse/tracking/icp.hpp"
#include "edgefuse/tracking/observability.hpp"
#include "edgefuse/tracking/push_policy.hpp"
#include "edgefuse/tracking/se3.hpp"
#include "edgefuse/tracking/tracking_state.hpp"
#include "test_tracking_rig.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {

// Exact model maps: every pixel's ray intersected with the scene (sensor frame of T_world_cam).
struct ExactMaps {
  std::vector<float> depth;
  std::vector<Vec3f> vertex, normal;
  RaycastMaps maps;
  ExactMaps(const Scene& scene, const PinholeIntrinsics& c, const Pose& T_world_cam) {
    const std::size_t n = std::size_t(c.width) * c.height;
    depth.assign(n, 0.0f);
    vertex.assign(n, Vec3f::Zero());
    normal.assign(n, Vec3f::Zero());
    for (int v = 0; v < c.height; ++v)
      for (int u = 0; u < c.width; ++u) {
        const Vec3f ray = c.ray(float(u), float(v));
        float t;
        Vec3f nw;
        int item;
        if (!scene.intersect(T_world_cam.t, (T_world_cam.R * ray).normalized(), t, nw, item)) continue;
        const float z = t / ray.norm();
        if (z < c.min_range_m || z > c.max_range_m) continue;
        const std::size_t i = std::size_t(v) * c.width + u;
        depth[i] = z;
        vertex[i] = ray * z;
        normal[i] = T_world_cam.R.transpose() * nw;
      }
    maps.depth_m = ImageView<float>(depth.data(), c.width, c.height);
    maps.vertex = ImageView<Vec3f>(vertex.data(), c.width, c.height);
    maps.normal = ImageView<Vec3f>(normal.data(), c.width, c.height);
  }
};

RigBuffers<float> g_buf_float;
RigBuffers<Fixed> g_buf_fixed;
template <class Real>
RigBuffers<Real>& buffers();
template <>
RigBuffers<float>& buffers<float>() { return g_buf_float; }
template <>
RigBuffers<Fixed>& buffers<Fixed>() { return g_buf_fixed; }

// Aligns a frame rendered at T_world_model * delta against exact maps at T_world_model.
template <class Real>
Pose align_exact(const Scene& scene, const Pose& T_world_model, const Pose& delta, IcpStats& stats,
                 const IcpParams& params = IcpParams()) {
  const PinholeIntrinsics cam = rig_camera();
  const ExactMaps model(scene, cam, T_world_model);
  std::vector<uint16_t> depth;
  render(scene, cam, T_world_model * delta, depth);
  RigBuffers<Real>& b = buffers<Real>();
  FramePyramid<Real> pyr;
  CHECK(bind_pyramid<Real>(cam, b.pyr_vertex, b.pyr_normal, RigBuffers<Real>::kPyr, pyr) == Status::kOk);
  CHECK(build_pyramid<Real>(ImageView<const uint16_t>(depth.data(), cam.width, cam.height), PyramidParams(), pyr) ==
        Status::kOk);
  const IcpWorkspace<Real> ws = IcpWorkspace<Real>::bind(b.icp_rows, sizeof(b.icp_rows));
  Pose T;
  CHECK(icp_align<Real>(pyr, model.maps, cam, Pose::identity(), params, ws, T, stats) == Status::kOk);
  return T;
}

Pose test_offset() {
  Pose d;
  d.R = Eigen::AngleAxisf(1.5f * float(M_PI) / 180.0f, Vec3f(0.3f, -0.8f, 0.5f).normalized()).toRotationMatrix();
  d.t = Vec3f(0.006f, -0.004f, 0.003f);
  return d;
}

template <class Real>
void recovers_known_offset(float tol_m, float tol_deg) {
  const Pose model = look_at(Vec3f(0.01f, -0.01f, 0.0f), Vec3f(0.0f, 0.0f, 0.85f));
  const Pose delta = test_offset();
  IcpStats stats;
  const Pose T = align_exact<Real>(box_sphere_corner(), model, delta, stats);
  float dt, deg;
  pose_error(T, delta, dt, deg);
  std::printf("\n  %s: error %.4f mm %.5f deg, %d dof, inliers %.3f, rms %.3f mm, it %d/%d/%d%s",
              std::is_same<Real, Fixed>::value ? "fixed" : "float",
              1e3f * dt, deg, stats.observable, stats.inlier_ratio(), 1e3f * stats.rms_m, stats.iterations[2],
              stats.iterations[1], stats.iterations[0], stats.converged ? ", converged" : "");
  LONGS_EQUAL(6, stats.observable);
  CHECK(!stats.refused);
  CHECK(dt < tol_m);
  CHECK(deg < tol_deg);
}

}  // namespace

TEST_GROUP(TrackingIcp){};

TEST(TrackingIcp, FloatIcpRecoversAKnownOffsetOnExactMaps) { recovers_known_offset<float>(2e-5f, 0.002f); }

TEST(TrackingIcp, FixedIcpRecoversAKnownOffsetOnExactMaps) { recovers_known_offset<Fixed>(2e-5f, 0.002f); }

TEST(TrackingIcp, FixedAndFloatIcpAgree) {
  const Pose model = look_at(Vec3f(-0.02f, 0.01f, 0.0f), Vec3f(0.02f, 0.0f, 0.85f));
  IcpStats sf, sx;
  const Pose a = align_exact<float>(box_sphere_corner(), model, test_offset(), sf);
  const Pose b = align_exact<Fixed>(box_sphere_corner(), model, test_offset(), sx);
  float dt, deg;
  pose_error(a, b, dt, deg);
  std::printf("\n  fixed vs float: %.4f mm %.5f deg; inliers %d vs %d", 1e3f * dt, deg, sf.correspondences,
              sx.correspondences);
  CHECK(dt < 5e-5f);
  CHECK(deg < 0.005f);
  CHECK(std::abs(sf.correspondences - sx.correspondences) < sf.correspondences / 100);
}

TEST(TrackingIcp, EveryRobustLossRecoversTheOffset) {
  const Pose model = look_at(Vec3f(0.01f, -0.01f, 0.0f), Vec3f(0.0f, 0.0f, 0.85f));
  IcpParams params;
  for (RobustLoss loss : {RobustLoss::kNone, RobustLoss::kHuber, RobustLoss::kTukey}) {
    params.loss = loss;
    params.robust_scale_m = loss == RobustLoss::kTukey ? 0.02f : 0.005f;  // Tukey's c cuts: wider
    IcpStats stats;
    const Pose T = align_exact<float>(box_sphere_corner(), model, test_offset(), stats, params);
    float dt, deg;
    pose_error(T, test_offset(), dt, deg);
    CHECK(dt < 2e-5f);
    CHECK(deg < 0.002f);
  }
}

TEST(TrackingIcp, ASinglePlaneCorrectsDistanceAndTiltOnly) {
  Scene plane;
  const Vec3f n = Vec3f(0.1f, -0.2f, -1.0f).normalized();
  plane.add_plane(n, -n.dot(Vec3f(0, 0, 0.9f)));
  const Pose model = look_at(Vec3f::Zero(), Vec3f(0, 0, 0.9f));
  // The frame is taken 6 mm further along the plane, 4 mm closer and tilted by 0.8 degrees.
  const Vec3f n_cam = model.R.transpose() * n;
  const Vec3f along = n_cam.cross(Vec3f(1, 0, 0)).normalized();
  Pose delta;
  delta.t = 0.006f * along - 0.004f * n_cam;
  delta.R = Eigen::AngleAxisf(0.8f * float(M_PI) / 180.0f, along).toRotationMatrix();
  IcpStats stats;
  const Pose T = align_exact<float>(plane, model, delta, stats);
  LONGS_EQUAL(3, stats.observable);
  CHECK(!stats.refused);
  // Observable: the plane seen from T must be the plane seen from delta (distance and normal).
  const float d_true = n_cam.dot(delta.t), d_est = n_cam.dot(T.t);
  const float tilt = std::acos(std::min(1.0f, (T.R.transpose() * n_cam).dot(delta.R.transpose() * n_cam)));
  std::printf("\n  plane: distance error %.4f mm, tilt error %.4f deg, in-plane move %.4f mm (truth 6 mm)",
              1e3f * std::fabs(d_true - d_est), tilt * 180.0f / float(M_PI),
              1e3f * (T.t - n_cam.dot(T.t) * n_cam).norm());
  CHECK(std::fabs(d_true - d_est) < 2e-5f);
  CHECK(tilt * 180.0f / float(M_PI) < 0.002f);
  // Unobservable: no in-plane translation (the tilt's own lever arm aside: < 0.1 mm), no spin.
  CHECK((T.t - n_cam.dot(T.t) * n_cam).norm() < 1e-4f);
  const Eigen::AngleAxisf spin(T.R);
  CHECK(std::fabs(spin.angle() * spin.axis().dot(n_cam)) < 1e-5f);
}

TEST(TrackingIcp, AnEmptyViewIsRefusedAndLeavesTheStart) {
  Scene nothing;
  nothing.add_plane(Vec3f(0, 0, 1), 5.0f);  // behind the camera: nothing in view
  IcpStats stats;
  const Pose T = align_exact<float>(nothing, Pose::identity(), test_offset(), stats);
  CHECK(stats.refused);
  LONGS_EQUAL(0, stats.observable);
  CHECK(T.t.isZero());
  CHECK(T.R.isIdentity());
}

TEST(TrackingIcp, ObservabilityOfACornerIsSixAndOfAPlaneThree) {
  const PinholeIntrinsics cam = rig_camera();
  const Pose view = look_at(Vec3f::Zero(), Vec3f(0, 0, 0.9f));
  ViewObservability obs;
  const ExactMaps corner(box_sphere_corner(), cam, view);
  CHECK(view_observability(corner.maps, 32, 1e-4f, obs) == Status::kOk);
  LONGS_EQUAL(6, obs.count);
  Scene plane;
  plane.add_plane(Vec3f(0, 0, -1), 0.9f);
  const ExactMaps flat(plane, cam, view);
  CHECK(view_observability(flat.maps, 32, 1e-4f, obs) == Status::kOk);
  LONGS_EQUAL(3, obs.count);
  CHECK(obs.weakest_ratio < 1e-6f);
  CHECK(std::fabs(obs.scale_m - 0.9f) < 1e-3f);
}

TEST(TrackingIcp, Se3ExpMatchesRodriguesAndFirstOrderMotion) {
  Vec6f xi;
  xi << 0.2f, -0.1f, 0.3f, 0.01f, 0.02f, -0.03f;
  const Pose T = se3_exp(xi);
  const Vec3f w = xi.head<3>();
  const Mat3f R = Eigen::AngleAxisf(w.norm(), w.normalized()).toRotationMatrix();
  CHECK((T.R - R).cwiseAbs().maxCoeff() < 1e-6f);
  // exp(-xi) undoes exp(xi).
  const Pose I = se3_exp(-xi) * T;
  CHECK((I.R - Mat3f::Identity()).cwiseAbs().maxCoeff() < 1e-6f);
  CHECK(I.t.norm() < 1e-7f);
  // Small twist: exp(xi) p ~ p + w x p + v (the model the Jacobian linearises).
  Vec6f small = 1e-3f * xi;
  const Vec3f p(0.3f, -0.2f, 0.9f);
  const Vec3f first = p + small.head<3>().cross(p) + small.tail<3>();
  CHECK((se3_exp(small) * p - first).norm() < 1e-6f);
}

TEST(TrackingIcp, PushComparesTheDistanceNotTheNormsOfThePositions) {
  PushPolicy p;
  Pose last, now;
  last.t = Vec3f(1.0f, 0.0f, 0.0f);
  now.t = Vec3f(0.0f, 1.0f, 0.0f);  // same |t|, moved 1.4 m: the authors' watchdog saw no motion
  CHECK(moved_enough_to_push(p, last, now));
  now.t = Vec3f(1.005f, 0.0f, 0.0f);  // 5 mm
  CHECK(!moved_enough_to_push(p, last, now));
  now.t = Vec3f(1.0f, 0.0f, 0.011f);  // 11 mm sideways
  CHECK(moved_enough_to_push(p, last, now));
  now.t = last.t;
  now.R = Eigen::AngleAxisf(0.9f * float(M_PI) / 180.0f, Vec3f(0, 1, 0)).toRotationMatrix();
  CHECK(!moved_enough_to_push(p, last, now));
  now.R = Eigen::AngleAxisf(1.1f * float(M_PI) / 180.0f, Vec3f(0, 1, 0)).toRotationMatrix();
  CHECK(moved_enough_to_push(p, last, now));
  now.R = last.R;
  p.every_frame = true;
  CHECK(moved_enough_to_push(p, last, now));
}

TEST(TrackingIcp, StateFollowsTheDocumentedThresholds) {
  const StateThresholds th;
  IcpStats s;
  s.valid_points = 1000;
  s.candidates = 1000;
  s.correspondences = 950;
  s.rms_m = 0.002f;
  s.observable = 6;
  CHECK(classify_frame(s, 0.01f, 0.01f, th) == TrackState::kOk);
  s.observable = 3;
  CHECK(classify_frame(s, 0.01f, 0.01f, th) == TrackState::kDegraded);
  s.observable = 6;
  s.correspondences = 400;  // below ok, above lost
  CHECK(classify_frame(s, 0.01f, 0.01f, th) == TrackState::kDegraded);
  s.correspondences = 100;  // below lost
  CHECK(classify_frame(s, 0.01f, 0.01f, th) == TrackState::kLost);
  s.correspondences = 950;
  s.rms_m = 0.015f;
  CHECK(classify_frame(s, 0.01f, 0.01f, th) == TrackState::kDegraded);
  s.rms_m = 0.03f;
  CHECK(classify_frame(s, 0.01f, 0.01f, th) == TrackState::kLost);
  s.rms_m = 0.002f;
  CHECK(classify_frame(s, 0.3f, 0.01f, th) == TrackState::kLost);  // 30 cm jump
  CHECK(classify_frame(s, 0.01f, 0.5f, th) == TrackState::kLost);  // 29 degree turn
  s.refused = true;
  CHECK(classify_frame(s, 0.01f, 0.01f, th) == TrackState::kLost);
}

TEST(TrackingIcp, PyramidLevelsKeepPixelCentresAndTheForeground) {
  const PinholeIntrinsics cam = rig_camera();
  const PinholeIntrinsics l1 = level_intrinsics(cam, 1), l2 = level_intrinsics(cam, 2);
  LONGS_EQUAL(160, l1.width);
  LONGS_EQUAL(60, l2.height);
  // A point seen at full-resolution pixel x projects to level-1 pixel (x - 0.5) / 2.
  const Vec3f p(0.1f, -0.05f, 0.8f);
  float u0, v0, u1, v1;
  cam.project(p, u0, v0);
  l1.project(p, u1, v1);
  CHECK(std::fabs(u1 - (u0 - 0.5f) * 0.5f) < 1e-4f);
  CHECK(std::fabs(v1 - (v0 - 0.5f) * 0.5f) < 1e-4f);
  // A fronto-parallel plane at 0.8 m with one far pixel in a block: the coarse pixel keeps 0.8 m.
  std::vector<uint16_t> depth(std::size_t(cam.width) * cam.height, uint16_t(0.8f * cam.depth_scale));
  depth[std::size_t(40) * cam.width + 41] = uint16_t(1.5f * cam.depth_scale);
  RigBuffers<float>& b = g_buf_float;
  FramePyramid<float> pyr;
  CHECK(bind_pyramid<float>(cam, b.pyr_vertex, b.pyr_normal, RigBuffers<float>::kPyr, pyr) == Status::kOk);
  CHECK(build_pyramid<float>(ImageView<const uint16_t>(depth.data(), cam.width, cam.height), PyramidParams(), pyr) ==
        Status::kOk);
  CHECK(std::fabs(pyr.level[1].vertex.at(20, 20).z - 0.8f) < 1e-6f);
  CHECK(std::fabs(pyr.level[2].vertex.at(10, 10).z - 0.8f) < 1e-6f);
  // Normals face the sensor (0, 0, -1) on the plane, also on coarse levels.
  for (int k = 0; k < kPyramidLevels; ++k) {
    const Point3<float> n = pyr.level[k].normal.at(pyr.level[k].intr.width / 3, pyr.level[k].intr.height / 2);
    CHECK(std::fabs(n.z + 1.0f) < 1e-4f);
  }
  // No depth: no vertex, no normal.
  depth.assign(depth.size(), 0);
  CHECK(build_pyramid<float>(ImageView<const uint16_t>(depth.data(), cam.width, cam.height), PyramidParams(), pyr) ==
        Status::kOk);
  CHECK(pyr.level[0].vertex.at(5, 5).z == 0.0f);
  CHECK(pyr.level[2].normal.at(5, 5).z == 0.0f);
}
