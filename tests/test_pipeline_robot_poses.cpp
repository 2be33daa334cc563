// The robot's poses in the map (edgefused's tracking.poses = robot | robot+icp) on the rendered
// corner scene (test_tracking_rig.hpp's box_sphere_corner, 160x120, a 64^3 space of 1 cm): the
// camera moves along a smooth path (~4 mm and ~0.4 degrees a frame at 31.25 fps, 0.12 m/s) on a
// flange with a hand-eye mounting; the robot streams its flange poses at 250 Hz into a
// StampedPoseHistory; each frame's pose is runtime::robot_camera_pose (the flange pose at the
// frame's stamp plus the latency offset, interpolated, times the mounting), as the device pipeline
// computes it:
//   - exact robot poses with the exact mounting: "robot" places every frame at the truth (the
//     interpolation is exact here) and "robot+icp" keeps it within a tenth of a voxel (~0.3 mm:
//     ICP's floor against a map of 1 cm voxels);
//   - a robot with errors as a moving controller reports them (0.5-1 mm and 0.05-0.1 degrees on each
//     update, its stamps 10 ms late of which the configured latency offset knows 6 ms; at rest, for
//     the first frame, only its repeatability of 0.05 mm / 0.005 degrees): "robot+icp" places the
//     frames closer to the truth than "robot" (median and worst frame: 0.3 against 0.6 mm, 0.4
//     against 1 mm), within 0.05 voxel, and its map's raycast agrees better with the rendered scene;
//   - a frame outside the robot's poses (none yet at its stamp) has no pose;
//   - the steady-state step (the robot's pose and the mapping) allocates nothing.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "alloc_counter.hpp"
#include "edgefuse/pipeline/mapper.hpp"
#include "edgefuse/pipeline/pose_history.hpp"
#include "edgefuse/runtime/flange_pose_source.hpp"
#include "test_tracking_rig.hpp"
#include "pipeline_fixture.hpp"

using namespace edgefuse;
using namespace edgefuse_test;
using namespace pipeline_test;

namespace {

constexpr float kDeg = 3.14159265f / 180.0f;
constexpr int kFrames = 24;
constexpr uint64_t kFramePeriodUs = 32000;   // 31.25 fps: every 8th robot update falls on a frame
constexpr uint64_t kUpdatePeriodUs = 4000;   // the robot streams at 250 Hz
constexpr uint64_t kFirstFrameUs = 1000000;

CentreScratch g_centre;

// The flange's pose at a time: the camera path's poses at the frame stamps times the mounting's
// inverse, interpolated between them (at rest before the first frame and after the last).
struct FlangePath {
  std::vector<Pose> T_base_flange;  // at the frame stamps

  Pose at(double t_us) const {
    const double k = (t_us - double(kFirstFrameUs)) / double(kFramePeriodUs);
    if (k <= 0) return T_base_flange.front();
    const std::size_t i = std::size_t(k);
    if (i + 1 >= T_base_flange.size()) return T_base_flange.back();
    return interpolate(T_base_flange[i], T_base_flange[i + 1], float(k - double(i)));
  }
};

// How the robot reports its flange: each update moved by a random translation and turned about a
// random axis (magnitudes uniform in the ranges), describing the flange `late_us` before its stamp.
struct RobotErrors {
  float move_m[2] = {0, 0};
  float turn_deg[2] = {0, 0};
  float rest_move_m = 0, rest_turn_deg = 0;  // while at rest (before the path starts)
  uint64_t late_us = 0;
};

struct Lcg {
  uint32_t state = 12345u;
  float uniform() {
    state = state * 1664525u + 1013904223u;
    return (float(state >> 8) + 0.5f) * (1.0f / 16777216.0f);
  }
  Vec3f direction() {
    const float z = 2 * uniform() - 1, a = 6.2831853f * uniform(), r = std::sqrt(1 - z * z);
    return Vec3f(r * std::cos(a), r * std::sin(a), z);
  }
};

Pose disturbance(Lcg& rng, float move_m, float turn_deg) {
  Pose d;
  d.t = rng.direction() * move_m;
  d.R = Eigen::AngleAxisf(turn_deg * kDeg, rng.direction()).toRotationMatrix();
  return d;
}

// The robot's stream as the robot session keeps it.
class StreamedRobot final : public runtime::FlangePoseSource {
 public:
  StreamedRobot(const FlangePath& path, const RobotErrors& e) {
    Lcg rng;
    const uint64_t end_us = kFirstFrameUs + kFrames * kFramePeriodUs + 100000;
    for (uint64_t s = kFirstFrameUs - 100000; s <= end_us; s += kUpdatePeriodUs) {
      const double described_us = double(s) - double(e.late_us);
      const bool at_rest = described_us <= double(kFirstFrameUs);
      const float mix = rng.uniform(), mix2 = rng.uniform();
      const Pose d = at_rest ? disturbance(rng, e.rest_move_m, e.rest_turn_deg)
                             : disturbance(rng, e.move_m[0] + mix * (e.move_m[1] - e.move_m[0]),
                                           e.turn_deg[0] + mix2 * (e.turn_deg[1] - e.turn_deg[0]));
      const Pose T = path.at(described_us);
      Pose reported;
      reported.R = d.R * T.R;
      reported.t = T.t + d.t;
      CHECK(history_.record(s, reported));
    }
  }
  bool flange_pose_at(uint64_t stamp_us, Pose& T_base_flange) const override {
    return history_.pose_at(stamp_us, T_base_flange);
  }

 private:
  StampedPoseHistory history_;
};

// The camera's mounting on the flange: 6 cm ahead, 3 cm aside, turned by 12 degrees.
Pose hand_eye() {
  Pose T_flange_cam;
  T_flange_cam.t = Vec3f(0.03f, -0.01f, 0.06f);
  T_flange_cam.R = Eigen::AngleAxisf(12.0f * kDeg, Vec3f(0.2f, 1.0f, 0.1f).normalized()).toRotationMatrix();
  return T_flange_cam;
}

struct Outcome {
  std::vector<float> dt_m, deg;  // per frame, against the truth
  float median_m = 0, worst_m = 0, median_deg = 0, worst_deg = 0;
  DepthAgreement map;  // the map's raycast against the rendered scene at the last frame's truth
  long allocations = 0;  // in the steady-state steps (the robot's pose and the mapping)
};

float median(std::vector<float> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Maps every frame with its pose from the robot (PoseMode::kKnown: "robot", kPrior: "robot+icp").
Outcome map_with_robot(PoseMode mode, const RobotErrors& errors, int64_t latency_us) {
  const PinholeIntrinsics cam = small_camera();
  TsdfVolume volume;
  init_space(volume, kRigCentre - Vec3f::Constant(0.5f * kSpaceDim * kSpaceVoxelM));
  CameraSlot ref;
  bind_camera(ref, 0, cam);
  Mapper mapper;
  MapperParams mp;
  mp.poses = mode;
  mp.tracker.push.every_frame = true;
  CHECK(mapper.init(volume, KernelRunners(), spare_image(cam.width, cam.height), g_centre.view(), mp) == Status::kOk);
  mapper.new_map_in_place();

  const Scene scene = box_sphere_corner();
  const std::vector<Pose> truth = known_motion(kFrames);
  const Pose T_flange_cam = hand_eye();
  FlangePath path;
  for (const Pose& T : truth) path.T_base_flange.push_back(T * T_flange_cam.inverse());
  const StreamedRobot robot(path, errors);

  Outcome out;
  std::vector<uint16_t> depth;
  for (int i = 0; i < kFrames; ++i) {
    render(scene, cam, truth[i], depth);
    const uint64_t stamp_us = kFirstFrameUs + uint64_t(i) * kFramePeriodUs;
    Pose given;
    ReferenceStep step;
    if (i >= 2) alloc_count_start();
    CHECK(runtime::robot_camera_pose(robot, stamp_us, latency_us, T_flange_cam, given));
    CHECK(mapper.map_reference(ref, sensor_frame(depth, cam, stamp_us), &given, Pose(), step) == Status::kOk);
    if (i >= 2) out.allocations += alloc_count();
    CHECK(step.has_pose && step.integrated);
    float dt, deg;
    pose_distance(step.T_world_cam, truth[i], dt, deg);
    out.dt_m.push_back(dt);
    out.deg.push_back(deg);
  }
  out.median_m = median(out.dt_m);
  out.median_deg = median(out.deg);
  out.worst_m = *std::max_element(out.dt_m.begin(), out.dt_m.end());
  out.worst_deg = *std::max_element(out.deg.begin(), out.deg.end());
  CHECK(raycast_frame<real_t>(nullptr, volume, cam, truth.back(), ref.maps) == Status::kOk);
  render(scene, cam, truth.back(), depth);
  out.map = compare_depth(ref.maps.depth_m, depth, cam, truth.back(), volume, 2 * kSpaceVoxelM);
  return out;
}

void report(const char* what, const Outcome& o) {
  std::printf("\n  %-28s pose error median %.3f mm %.4f deg, worst %.3f mm %.4f deg; map vs scene: median %.3f mm,"
              " p90 %.3f mm, mean signed %+.3f mm",
              what, 1e3f * o.median_m, o.median_deg, 1e3f * o.worst_m, o.worst_deg, 1e3f * o.map.median_abs_m,
              1e3f * o.map.p90_abs_m, 1e3f * o.map.mean_signed_m);
}

}  // namespace

TEST_GROUP(PipelineRobotPoses){};

TEST(PipelineRobotPoses, ExactRobotPosesGiveTheTruth) {
  const RobotErrors exact;
  const Outcome robot = map_with_robot(PoseMode::kKnown, exact, 0);
  const Outcome corrected = map_with_robot(PoseMode::kPrior, exact, 0);
  report("exact robot:", robot);
  report("exact robot + icp:", corrected);
  // Robot updates fall on every frame stamp: the pose is the truth up to float rounding.
  LONGS_EQUAL(0, robot.allocations);
  LONGS_EQUAL(0, corrected.allocations);
  CHECK(robot.worst_m < 1e-5f);
  CHECK(robot.worst_deg < 0.005f);
  // ICP against a map of 1 cm voxels from exact priors: within a tenth of a voxel.
  CHECK(corrected.worst_m < 0.1f * kSpaceVoxelM);
  CHECK(corrected.worst_deg < 0.1f);
}

TEST(PipelineRobotPoses, IcpCorrectsARobotsErrors) {
  RobotErrors e;
  e.move_m[0] = 0.0005f;
  e.move_m[1] = 0.001f;
  e.turn_deg[0] = 0.05f;
  e.turn_deg[1] = 0.1f;
  e.rest_move_m = 0.00005f;
  e.rest_turn_deg = 0.005f;
  e.late_us = 10000;
  const int64_t latency_us = 6000;  // the configured offset knows 6 of the 10 ms
  const Outcome robot = map_with_robot(PoseMode::kKnown, e, latency_us);
  const Outcome corrected = map_with_robot(PoseMode::kPrior, e, latency_us);
  report("robot (errors):", robot);
  report("robot + icp (errors):", corrected);
  // The robot's own errors: at least its smallest update error on the median frame.
  CHECK(robot.median_m > 0.0004f);
  CHECK(robot.median_deg > 0.04f);
  // ICP keeps every frame near its floor with exact priors (~0.3 mm against the 1 cm voxels' map):
  // within 0.05 voxel, and better than the robot on the median and the worst frame.
  CHECK(corrected.median_m < robot.median_m && corrected.worst_m < robot.worst_m);
  CHECK(corrected.median_deg < robot.median_deg && corrected.worst_deg < robot.worst_deg);
  CHECK(corrected.worst_m < 0.05f * kSpaceVoxelM);
  CHECK(corrected.worst_deg < 0.05f);
  // The map: its raycast agrees with the rendered scene at least as well (median |difference|).
  CHECK(corrected.map.median_abs_m <= robot.map.median_abs_m);
}

TEST(PipelineRobotPoses, NoRobotPoseOutsideTheStream) {
  const FlangePath path{{Pose::identity(), Pose::identity()}};
  const StreamedRobot robot(path, RobotErrors());
  Pose T;
  CHECK(runtime::robot_camera_pose(robot, kFirstFrameUs, 0, Pose::identity(), T));
  CHECK_FALSE(runtime::robot_camera_pose(robot, kFirstFrameUs - 200000, 0, Pose::identity(), T));  // too old
  CHECK_FALSE(runtime::robot_camera_pose(robot, kFirstFrameUs + 10000000, 0, Pose::identity(), T));  // not yet
  CHECK_FALSE(runtime::robot_camera_pose(robot, 1000, -2000, Pose::identity(), T));  // before the clock's start
}
