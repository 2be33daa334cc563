// Tracking where it can go wrong:
//  - a single plane observes only 3 of 6 directions (distance and two tilts): those must still be
//    tracked, and the unobservable in-plane translation / rotation about the normal must stay at
//    the prediction instead of following noise (the camera really moves in-plane by 4 cm);
//  - a sudden 30 cm jump of the sensor must be reported lost, not pushed, the last good pose kept,
//    and tracking must resume by itself when the frames return to the old view.
#include <cmath>
#include <vector>

#include "test_tracking_rig.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {
RigBuffers<float> g_buf;
}  // namespace

TEST_GROUP(TrackingRobust){};

TEST(TrackingRobust, ASinglePlaneTracksItsThreeDirectionsAndNeverJumpsInTheOthers) {
  Scene scene;
  const Vec3f n = Vec3f(0.15f, -0.25f, -1.0f).normalized();  // faces the camera, tilted
  const Vec3f on_plane(0.0f, 0.0f, 0.85f);
  scene.add_plane(n, -n.dot(on_plane));
  // In-plane directions and a path: 3 mm in-plane per frame, plus approach and tilt.
  const Vec3f e1 = n.cross(Vec3f(0, 1, 0)).normalized(), e2 = n.cross(e1);
  std::vector<Pose> truth;
  for (int i = 0; i < 10; ++i) {
    const float s = float(i);
    const Vec3f eye = 0.004f * s * e1 + 0.001f * s * e2 - 0.002f * s * n;
    truth.push_back(look_at(eye, on_plane + eye + Vec3f(0.004f * s, -0.003f * s, 0.0f)));
  }
  Rig<float> rig(g_buf, kRigCentre, 0.01f);
  CHECK(rig.tracker.start(truth[0], TrackerParams()) == Status::kOk);
  const float plane_d = -n.dot(on_plane);  // n.x + d = 0
  float worst_dist = 0, worst_tilt = 0, worst_inplane = 0, worst_spin = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    std::vector<uint16_t> depth;
    render(scene, rig.cam, truth[i], depth);
    add_depth_noise(depth, rig.cam.depth_scale, 0.0015f, uint32_t(i));
    TrackResult r;
    CHECK(rig.run_frame(depth, r) == Status::kOk);
    CHECK(r.state != TrackState::kLost);
    const Pose& E = r.T_world_cam;
    const Pose& G = truth[i];
    // Observable: the camera's distance to the plane and the plane's normal in the camera frame.
    const float dist_err = std::fabs((n.dot(E.t) + plane_d) - (n.dot(G.t) + plane_d));
    const float tilt_err =
        std::acos(std::min(1.0f, (E.R.transpose() * n).dot(G.R.transpose() * n))) * 180.0f / float(M_PI);
    // Unobservable: in-plane motion of the estimate from the first pose, and spin about n.
    const Vec3f moved = E.t - truth[0].t;
    const float inplane = (moved - n.dot(moved) * n).norm();
    const Eigen::AngleAxisf spin(Mat3f(E.R * truth[0].R.transpose()));
    const float spin_deg = std::fabs(spin.angle() * spin.axis().dot(n)) * 180.0f / float(M_PI);
    std::printf("\n  frame %2zu: %-8s %d dof (weakest %.1e), distance error %.3f mm, tilt error %.3f deg, "
                "in-plane drift %.2f mm (truth moved %.1f mm), spin %.3f deg",
                i, to_string(r.state), r.icp.observable, r.icp.weakest_ratio, 1e3f * dist_err, tilt_err,
                1e3f * inplane, 1e3f * ((G.t - truth[0].t) - n.dot(G.t - truth[0].t) * n).norm(), spin_deg);
    if (i == 0) continue;
    worst_dist = std::max(worst_dist, dist_err);
    worst_tilt = std::max(worst_tilt, tilt_err);
    worst_inplane = std::max(worst_inplane, inplane);
    worst_spin = std::max(worst_spin, spin_deg);
  }
  std::printf("\n  worst: distance %.3f mm, tilt %.3f deg, in-plane drift %.2f mm, spin %.3f deg", 1e3f * worst_dist,
              worst_tilt, 1e3f * worst_inplane, worst_spin);
  CHECK(worst_dist < 0.001f);
  CHECK(worst_tilt < 0.1f);
  CHECK(worst_inplane < 0.005f);  // the truth moved 4 cm in-plane; the estimate must not wander
  CHECK(worst_spin < 0.3f);
}

TEST(TrackingRobust, ASuddenJumpIsLostNotPushedAndTrackingResumes) {
  const Scene scene = box_sphere_corner();
  std::vector<Pose> truth = known_motion(10);
  const Vec3f jump(0.2f, 0.1f, 0.2f);  // 0.3 m
  for (int i = 4; i <= 6; ++i) truth[std::size_t(i)].t += jump;
  Rig<float> rig(g_buf, kRigCentre, 0.01f);
  CHECK(rig.tracker.start(truth[0], TrackerParams()) == Status::kOk);
  Pose last_good;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    std::vector<uint16_t> depth;
    render(scene, rig.cam, truth[i], depth);
    TrackResult r;
    CHECK(rig.run_frame(depth, r) == Status::kOk);
    float dt, deg;
    pose_error(r.T_world_cam, truth[i], dt, deg);
    std::printf("\n  frame %2zu: %-8s push %d, inliers %.2f, coverage %.2f, rms %.2f mm, tried %d, error %.3f mm %.4f deg",
                i, to_string(r.state), int(r.push), r.icp.inlier_ratio(), r.icp.coverage(), 1e3f * r.icp.rms_m,
                r.attempts, 1e3f * dt, deg);
    if (i >= 4 && i <= 6) {
      CHECK(r.state == TrackState::kLost);
      CHECK(!r.push);
      CHECK(r.T_world_cam.t == last_good.t);
      CHECK(r.T_world_cam.R == last_good.R);
      continue;
    }
    CHECK(r.state != TrackState::kLost);
    CHECK(dt < 0.001f);
    CHECK(deg < 0.1f);
    last_good = r.T_world_cam;
  }
}
