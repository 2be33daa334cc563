// Tracking a rendered sequence with known motion (two boxes and a sphere before a three-plane
// corner; 12 frames of ~4 mm and ~0.4 degrees each): every frame's pose must be within 1 mm and 0.1 degrees of the
// truth (the space is 64^3 voxels of 1 cm, whose raycast surface is exact to ~0.1 voxel, and ICP
// averages thousands of such points). The loop must allocate nothing per frame, and spreading the
// ICP's rows over threads must give bit-identical poses.
#include <atomic>
#include <cmath>
#include <vector>

#include "alloc_counter.hpp"
#include "test_tracking_rig.hpp"
#include "edgefuse/hal/platform/threads/pool_row_runner.hpp"
#include "edgefuse/hal/platform/threads/worker_pool.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {

RigBuffers<float> g_buf;

struct SequenceRun {
  std::vector<Pose> poses;
  std::vector<TrackResult> results;
  long allocations = 0;
};

SequenceRun track_sequence(const std::vector<Pose>& truth, const RowRunner* runner) {
  const Scene scene = box_sphere_corner();
  Rig<float> rig(g_buf, kRigCentre, 0.01f);
  rig.runner = runner;
  TrackerParams params;
  CHECK(rig.tracker.start(truth[0], params) == Status::kOk);
  std::vector<std::vector<uint16_t>> depth(truth.size());
  for (std::size_t i = 0; i < truth.size(); ++i) render(scene, rig.cam, truth[i], depth[i]);
  SequenceRun run;
  run.poses.reserve(truth.size());
  run.results.reserve(truth.size());
  for (std::size_t i = 0; i < truth.size(); ++i) {
    TrackResult r;
    alloc_count_start();
    const Status s = rig.run_frame(depth[i], r);
    run.allocations += alloc_count();
    CHECK(s == Status::kOk);
    run.poses.push_back(r.T_world_cam);
    run.results.push_back(r);
  }
  return run;
}

}  // namespace

TEST_GROUP(TrackingSequence){};

TEST(TrackingSequence, KnownMotionIsTrackedWithinAMillimetreAndATenthOfADegree) {
  const std::vector<Pose> truth = known_motion(12);
  const SequenceRun run = track_sequence(truth, nullptr);
  float worst_t = 0, worst_deg = 0, worst_step_t = 0, worst_step_deg = 0;
  int pushes = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const TrackResult& r = run.results[i];
    float dt, deg;
    pose_error(r.T_world_cam, truth[i], dt, deg);
    std::printf("\n  frame %2zu: %-8s push %d, start %d, attempts %d, inliers %.2f, rms %.2f mm, it %d/%d/%d, "
                "error %.3f mm %.4f deg",
                i, to_string(r.state), int(r.push), r.start, r.attempts, r.icp.inlier_ratio(), 1e3f * r.icp.rms_m,
                r.icp.iterations[2], r.icp.iterations[1], r.icp.iterations[0], 1e3f * dt, deg);
    worst_t = std::max(worst_t, dt);
    worst_deg = std::max(worst_deg, deg);
    pushes += r.push;
    if (i == 0) {
      CHECK(r.first && r.push);
      continue;
    }
    CHECK(r.state == TrackState::kOk);
    // Error of the frame-to-frame motion.
    const Pose est = run.poses[i - 1].inverse() * run.poses[i];
    const Pose gt = truth[i - 1].inverse() * truth[i];
    pose_error(est, gt, dt, deg);
    worst_step_t = std::max(worst_step_t, dt);
    worst_step_deg = std::max(worst_step_deg, deg);
  }
  std::printf("\n  worst: absolute %.3f mm %.4f deg, per step %.3f mm %.4f deg, %d pushes", 1e3f * worst_t, worst_deg,
              1e3f * worst_step_t, worst_step_deg, pushes);
  CHECK(worst_t < 0.001f);
  CHECK(worst_deg < 0.1f);
  CHECK(worst_step_t < 0.001f);
  CHECK(worst_step_deg < 0.1f);
  CHECK(pushes >= 3);                 // the motion (~4 cm in all) crosses the 1 cm push threshold
  CHECK(pushes < int(truth.size()));  // ... but not on every frame
  LONGS_EQUAL(0, run.allocations);    // raycast, pyramid, ICP, state, push, integrate: no heap
}

TEST(TrackingSequence, ThreadsDoNotChangeTheResult) {
  const std::vector<Pose> truth = known_motion(4);
  const SequenceRun serial = track_sequence(truth, nullptr);
  WorkerPool pool;  // rows in chunks over three threads, as the tools run them (hal/platform/threads)
  pool.start(3);
  PoolRowRunner rows(pool, 3);
  const SequenceRun threaded = track_sequence(truth, rows.runner());
  pool.stop();
  for (std::size_t i = 0; i < truth.size(); ++i) {
    CHECK(serial.poses[i].R == threaded.poses[i].R);
    CHECK(serial.poses[i].t == threaded.poses[i].t);
    LONGS_EQUAL(serial.results[i].icp.correspondences, threaded.results[i].icp.correspondences);
  }
}
