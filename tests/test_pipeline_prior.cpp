// The Mapper's robot+icp pose mode (PoseMode::kPrior) on the rendered corner scene
// (test_tracking_rig.hpp's box_sphere_corner) seen by a 160x120 camera from stations 14-24 degrees
// apart, too far for the constant-velocity tracker (its 15-degree jump limit, and ICP's reach):
//   - each station's prior (its true pose moved by 4-8 mm and turned by 0.8-1 degree, like a robot
//     pose times a hand-measured mounting) is corrected by ICP against the map raycast at the prior
//     to within 1 mm / 0.1 degree (the tracked mode's bound, test_pipeline_mapper), in the build's
//     numeric type (float, or Q16.16 in host-fixed);
//   - the first station places the map at its prior, every station is pushed (every_frame);
//   - a prior 20 cm off is lost: not integrated, its pose is the prior, no pose for paired cameras;
//   - align_reference (the correction alone, e.g. every station again against the finished map)
//     corrects the first station's disturbed prior as well, changes neither the map nor its counts,
//     and refuses before anything is mapped;
//   - the steady-state step allocates nothing.
#include <cmath>
#include <cstring>
#include <vector>

#include "alloc_counter.hpp"
#include "edgefuse/pipeline/mapper.hpp"
#include "test_tracking_rig.hpp"
#include "pipeline_fixture.hpp"

using namespace edgefuse;
using namespace edgefuse_test;
using namespace pipeline_test;

namespace {

constexpr float kDeg = 3.14159265f / 180.0f;
constexpr float kTolM = 0.001f, kTolDeg = 0.1f;

CentreScratch g_centre;

// Stations looking into the corner from a ring around the first one, 0.2 m to the side.
std::vector<Pose> stations() {
  const Vec3f target(0.0f, 0.02f, 0.85f);
  return {look_at(Vec3f(0.0f, 0.0f, 0.0f), target), look_at(Vec3f(0.2f, 0.0f, 0.05f), target),
          look_at(Vec3f(0.0f, -0.18f, 0.05f), target), look_at(Vec3f(-0.2f, 0.08f, 0.08f), target),
          look_at(Vec3f(0.12f, 0.15f, 0.03f), target)};
}

// A robot's pose times a hand-measured mounting: some millimetres and about a degree off.
Pose disturbed(const Pose& T, int k) {
  Pose d;
  d.t = Vec3f(0.003f, -0.002f, 0.002f) * float(1 + k % 2);
  d.R = Eigen::AngleAxisf((0.8f + 0.1f * float(k % 3)) * kDeg, Vec3f(1.0f, float(k) - 2.0f, 0.5f).normalized())
            .toRotationMatrix();
  return T * d;
}

struct PriorRig {
  PinholeIntrinsics cam = small_camera();
  TsdfVolume volume;
  CameraSlot ref;
  Mapper mapper;

  PriorRig() {
    init_space(volume, kRigCentre - Vec3f::Constant(0.5f * kSpaceDim * kSpaceVoxelM));
    bind_camera(ref, 0, cam);
    MapperParams mp;
    mp.poses = PoseMode::kPrior;
    mp.tracker.push.every_frame = true;
    CHECK(mapper.init(volume, KernelRunners(), spare_image(cam.width, cam.height), g_centre.view(), mp) == Status::kOk);
    mapper.new_map_in_place();
  }
};

}  // namespace

TEST_GROUP(PipelinePrior){};

TEST(PipelinePrior, EachStationIsCorrectedFromItsPriorAndPushed) {
  PriorRig rig;
  const Scene scene = box_sphere_corner();
  const std::vector<Pose> truth = stations();
  long allocations = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    std::vector<uint16_t> depth;
    render(scene, rig.cam, truth[i], depth);
    // The first station's prior is exact: it places the map, so the others can be held to the truth.
    const Pose prior = i == 0 ? truth[0] : disturbed(truth[i], int(i));
    float dt0, deg0, dt, deg, step_m, step_deg;
    pose_distance(prior, truth[i], dt0, deg0);
    if (i > 0) pose_distance(truth[i - 1], truth[i], step_m, step_deg);
    ReferenceStep step;
    if (i >= 2) alloc_count_start();
    CHECK(rig.mapper.map_reference(rig.ref, sensor_frame(depth, rig.cam, 1000 + i), &prior, Pose(), step) == Status::kOk);
    if (i >= 2) allocations += alloc_count();
    pose_distance(step.T_world_cam, truth[i], dt, deg);
    std::printf("\n  station %zu (%.1f deg from the last): %s, prior off %.2f mm %.3f deg -> %.3f mm %.4f deg", i,
                i > 0 ? step_deg : 0.0f, step.track.first ? "first" : to_string(step.track.state), 1e3f * dt0, deg0,
                1e3f * dt, deg);
    CHECK(step.has_pose && step.integrated && step.track.push);
    CHECK(step.track.first == (i == 0));
    if (i > 0) {
      CHECK(step_deg > 12.0f);
      CHECK(step.track.state == TrackState::kOk);
      LONGS_EQUAL(2, step.track.start);
      CHECK(std::fabs(step.track.jump_deg - deg0) < 0.2f);  // the jump is the correction of the prior
    }
    CHECK(dt < kTolM);
    CHECK(deg < kTolDeg);
  }
  LONGS_EQUAL(long(truth.size()), long(rig.mapper.map_frames()));
  LONGS_EQUAL(0, allocations);
}

TEST(PipelinePrior, APriorFarOffIsLostAndNotPushed) {
  PriorRig rig;
  const Scene scene = box_sphere_corner();
  const std::vector<Pose> truth = stations();
  std::vector<uint16_t> depth;
  render(scene, rig.cam, truth[0], depth);
  ReferenceStep step;
  CHECK(rig.mapper.map_reference(rig.ref, sensor_frame(depth, rig.cam, 1000), &truth[0], Pose(), step) == Status::kOk);
  render(scene, rig.cam, truth[1], depth);
  Pose prior = truth[1];
  prior.t += Vec3f(0.2f, 0.0f, 0.0f);
  prior.R = prior.R * Eigen::AngleAxisf(20.0f * kDeg, Vec3f(0.0f, 1.0f, 0.0f)).toRotationMatrix();
  CHECK(rig.mapper.map_reference(rig.ref, sensor_frame(depth, rig.cam, 1001), &prior, Pose(), step) == Status::kOk);
  std::printf("\n  prior 20 cm / 20 deg off: %s (inliers %.2f, %d correspondences)", to_string(step.track.state),
              step.track.icp.inlier_ratio(), step.track.icp.correspondences);
  CHECK(step.track.state == TrackState::kLost);
  CHECK_FALSE(step.integrated);
  CHECK_FALSE(step.has_pose);
  CHECK(step.T_world_cam.t == prior.t);
  CHECK_FALSE(rig.mapper.reference().has_pose());
  LONGS_EQUAL(1, long(rig.mapper.map_frames()));
}

TEST(PipelinePrior, AlignReferenceCorrectsAPriorAgainstTheFinishedMapWithoutMapping) {
  PriorRig rig;
  const Scene scene = box_sphere_corner();
  const std::vector<Pose> truth = stations();
  std::vector<std::vector<uint16_t>> depth(truth.size());
  for (std::size_t i = 0; i < truth.size(); ++i) render(scene, rig.cam, truth[i], depth[i]);
  TrackResult aligned;
  CHECK(rig.mapper.align_reference(rig.ref, sensor_frame(depth[0], rig.cam, 1000), truth[0], aligned) ==
        Status::kNotInitialised);
  ReferenceStep step;
  for (std::size_t i = 0; i < truth.size(); ++i)
    CHECK(rig.mapper.map_reference(rig.ref, sensor_frame(depth[i], rig.cam, 1000 + i), &truth[i], Pose(), step) ==
          Status::kOk);
  const std::size_t n = rig.volume.voxel_count();
  const std::vector<int16_t> tsdf(rig.volume.tsdf(), rig.volume.tsdf() + n);
  const std::vector<uint8_t> weight(rig.volume.weight(), rig.volume.weight() + n);
  const uint32_t frames = rig.mapper.map_frames();
  const uint64_t pixels = rig.ref.counts.pixels;
  // The first station again, from a disturbed prior: now the map holds every station's view.
  const Pose prior = disturbed(truth[0], 3);
  alloc_count_start();
  CHECK(rig.mapper.align_reference(rig.ref, sensor_frame(depth[0], rig.cam, 2000), prior, aligned) == Status::kOk);
  LONGS_EQUAL(0, alloc_count());
  float dt0, deg0, dt, deg;
  pose_distance(prior, truth[0], dt0, deg0);
  pose_distance(aligned.T_world_cam, truth[0], dt, deg);
  std::printf("\n  first station aligned again: prior off %.2f mm %.3f deg -> %.3f mm %.4f deg", 1e3f * dt0, deg0,
              1e3f * dt, deg);
  CHECK(aligned.state == TrackState::kOk);
  CHECK_FALSE(aligned.push);
  CHECK(dt < kTolM);
  CHECK(deg < kTolDeg);
  LONGS_EQUAL(long(frames), long(rig.mapper.map_frames()));
  CHECK(rig.ref.counts.pixels == pixels);
  CHECK(std::memcmp(tsdf.data(), rig.volume.tsdf(), n * sizeof(int16_t)) == 0);
  CHECK(std::memcmp(weight.data(), rig.volume.weight(), n) == 0);
}
