// The pipeline's mapping step (src/pipeline: kernels, CameraSlot, Mapper) on a rendered scene (two
// boxes and a sphere before a corner of three planes, test_tracking_rig.hpp) seen by a 160x120
// camera bound to the build board's slot buffers, in a 64^3 space of 1 cm voxels:
//   - integrate_frame / raycast_frame give bit-identical volumes and maps to the core's serial
//     integrate() / raycast(), on the calling thread and over a runner that hands out rows in a
//     scrambled order and split (float and Q16.16 kernels, both compiled in every build);
//   - known poses: a new map is centred on the first view, the map's raycast matches the rendered
//     depth, the counters are right, a frame without a pose clears the reference;
//   - tracked poses: ICP keeps the pose within 1 mm / 0.1 degree of the truth (float and Q16.16
//     builds alike), the push policy integrates only after 1 cm / 1 degree (or every frame), and the
//     steady-state step allocates nothing;
//   - map_paired: another camera of the rig is placed at the reference's pose at its own stamp.
#include <cstring>
#include <vector>

#include "alloc_counter.hpp"
#include "edgefuse/pipeline/kernels.hpp"
#include "edgefuse/pipeline/mapper.hpp"
#include "test_tracking_rig.hpp"
#include "pipeline_fixture.hpp"

using namespace edgefuse;
using namespace edgefuse_test;
using namespace pipeline_test;

namespace {

constexpr int kDim = kSpaceDim;
constexpr float kVoxel = kSpaceVoxelM;
//! Raycast comparisons count the surface at least a truncation band (4 voxels) inside the space.
constexpr float kMarginM = 4 * kVoxel;

// ------------------------------------------------------------------------------------------------
// Kernels

VolumeStorage<kDim> g_vol_a, g_vol_b, g_vol_c;
SensorBuffers<float> g_sensor_f;
SensorBuffers<Fixed> g_sensor_x;
float g_depth[3][160 * 120];
Vec3f g_vertex[3][160 * 120], g_normal[3][160 * 120];
Rgba8 g_colour[3][160 * 120];

SensorBuffers<float>& sensor_for(float*) { return g_sensor_f; }
SensorBuffers<Fixed>& sensor_for(Fixed*) { return g_sensor_x; }

RaycastMaps maps_of(int k, const PinholeIntrinsics& c) {
  RaycastMaps m;
  m.depth_m = ImageView<float>(g_depth[k], c.width, c.height);
  m.vertex = ImageView<Vec3f>(g_vertex[k], c.width, c.height);
  m.normal = ImageView<Vec3f>(g_normal[k], c.width, c.height);
  m.colour = ImageView<Rgba8>(g_colour[k], c.width, c.height);
  return m;
}

// A platform runner as a pool might behave at its worst: [0, count) cut into chunks of 1..3 rows,
// handed out in a shuffled order (fixed LCG: every platform draws the same).
struct ScrambledRunner {
  RowRunner runner;
  uint32_t state = 12345;
  int calls = 0;      // run() calls
  int max_count = 0;  // largest row count seen
  ScrambledRunner() {
    runner.run = &ScrambledRunner::run;
    runner.self = this;
  }
  uint32_t next() { return state = state * 1664525u + 1013904223u; }
  static void run(void* self, void (*rows)(void*, int, int), void* job, int count) {
    auto* r = static_cast<ScrambledRunner*>(self);
    ++r->calls;
    r->max_count = std::max(r->max_count, count);
    std::vector<std::pair<int, int>> chunks;
    for (int b = 0; b < count;) {
      const int e = std::min(count, b + 1 + int(r->next() >> 16) % 3);
      chunks.emplace_back(b, e);
      b = e;
    }
    for (std::size_t i = chunks.size(); i > 1; --i) std::swap(chunks[i - 1], chunks[(r->next() >> 8) % i]);
    for (const auto& c : chunks) rows(job, c.first, c.second);
  }
};

bool same_volume(const TsdfVolume& a, const TsdfVolume& b) {
  const std::size_t n = a.voxel_count(), nb = a.brick_count();
  bool same = std::memcmp(a.tsdf(), b.tsdf(), n * sizeof(int16_t)) == 0 &&
              std::memcmp(a.weight(), b.weight(), n) == 0 && std::memcmp(a.brick_flags(), b.brick_flags(), nb) == 0 &&
              std::memcmp(a.block_mask(), b.block_mask(), nb * sizeof(uint64_t)) == 0;
  if (a.has_colour())
    same = same && std::memcmp(a.colour(), b.colour(), n * sizeof(Rgb8)) == 0 &&
           std::memcmp(a.colour_weight(), b.colour_weight(), n) == 0;
  return same;
}

bool same_maps(const PinholeIntrinsics& c, int a, int b) {
  const std::size_t n = std::size_t(c.width) * c.height;
  return std::memcmp(g_depth[a], g_depth[b], n * sizeof(float)) == 0 &&
         std::memcmp(g_vertex[a], g_vertex[b], n * sizeof(Vec3f)) == 0 &&
         std::memcmp(g_normal[a], g_normal[b], n * sizeof(Vec3f)) == 0 &&
         std::memcmp(g_colour[a], g_colour[b], n * sizeof(Rgba8)) == 0;
}

template <class Real>
void kernels_match_the_serial_core() {
  const PinholeIntrinsics cam = small_camera();
  const Scene scene = box_sphere_corner();
  const TsdfParams p = TsdfParams::defaults_for(kVoxel, 4 * kVoxel);
  const Vec3f origin = kRigCentre - Vec3f::Constant(0.5f * kDim * kVoxel);
  TsdfVolume a, b, c;  // core integrate(); integrate_frame on this thread; ... over the scrambled runner
  CHECK(a.init(g_vol_a.view(true), kDim, origin, p) == Status::kOk);
  CHECK(b.init(g_vol_b.view(true), kDim, origin, p) == Status::kOk);
  CHECK(c.init(g_vol_c.view(true), kDim, origin, p) == Status::kOk);
  SensorBuffers<Real>& sensor = sensor_for(static_cast<Real*>(nullptr));
  const ImageView<const Real> norms = sensor.ray_norms(cam);
  FrameScratch scratch = sensor.scratch();
  ScrambledRunner scrambled;
  const std::vector<Pose> poses = known_motion(3);
  for (const Pose& T : poses) {
    std::vector<uint16_t> depth;
    std::vector<Rgb8> colour;
    render(scene, cam, T, depth, &colour);
    const DepthFrame f{{depth.data(), cam.width, cam.height}, {colour.data(), cam.width, cam.height}};
    CHECK(integrate<Real>(a, cam, norms, f, T, scratch) == Status::kOk);
    CHECK(integrate_frame<Real>(nullptr, b, cam, norms, f, T, scratch) == Status::kOk);
    CHECK(integrate_frame<Real>(&scrambled.runner, c, cam, norms, f, T, scratch) == Status::kOk);
  }
  CHECK(a.observed_voxels() > 10000);  // the frames did reach the space
  CHECK(same_volume(a, b));
  CHECK(same_volume(a, c));
  LONGS_EQUAL(3, scrambled.calls);
  CHECK(scrambled.max_count > 4);  // several chunks of bricks, so the order did change
  // Raycast at a pose between the frames.
  const Pose T = interpolate(poses[0], poses[2], 0.3f);
  CHECK(raycast<Real>(a, cam, T, maps_of(0, cam)) == Status::kOk);
  CHECK(raycast_frame<Real>(nullptr, a, cam, T, maps_of(1, cam)) == Status::kOk);
  CHECK(raycast_frame<Real>(&scrambled.runner, a, cam, T, maps_of(2, cam)) == Status::kOk);
  LONGS_EQUAL(4, scrambled.calls);
  LONGS_EQUAL((cam.height + kRaycastRowsPerRow - 1) / kRaycastRowsPerRow, scrambled.max_count);
  std::size_t hits = 0;
  for (int i = 0; i < cam.width * cam.height; ++i) hits += g_depth[0][i] > 0;
  CHECK(hits > std::size_t(cam.width * cam.height / 2));
  CHECK(same_maps(cam, 0, 1));
  CHECK(same_maps(cam, 0, 2));
}

// ------------------------------------------------------------------------------------------------
// Mapper

CentreScratch g_centre;

struct Frames {
  std::vector<Pose> poses;
  std::vector<uint64_t> stamps;
  std::vector<std::vector<uint16_t>> depth;
};

constexpr uint64_t kStamp0 = 5000000, kFrameUs = 33333;

Frames render_frames(const std::vector<Pose>& poses, const PinholeIntrinsics& cam) {
  const Scene scene = box_sphere_corner();
  Frames f;
  f.poses = poses;
  f.depth.resize(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    render(scene, cam, poses[i], f.depth[i]);
    f.stamps.push_back(kStamp0 + i * kFrameUs);
  }
  return f;
}

SensorFrame frame_of(const Frames& f, std::size_t i, const PinholeIntrinsics& cam) {
  return sensor_frame(f.depth[i], cam, f.stamps[i]);
}

// The reference camera in slot 0 (another in slot 1), the space in the board's voxel buffers.
struct MapperRig {
  PinholeIntrinsics cam = small_camera();
  TsdfVolume volume;
  CameraSlot ref, other;
  Mapper mapper;

  explicit MapperRig(PoseMode mode, const PushPolicy& push = PushPolicy()) {
    init_space(volume, Vec3f::Zero());
    bind_camera(ref, 0, cam);
    bind_camera(other, 1, cam);
    MapperParams mp;
    mp.poses = mode;
    mp.tracker.push = push;
    CHECK(mapper.init(volume, KernelRunners(), spare_image(cam.width, cam.height), g_centre.view(), mp) == Status::kOk);
    CameraSlot* cams[2] = {&ref, &other};
    mapper.set_fused_cameras(cams, 2);
  }
};

// Median world point of every pixel of a rendered view (all pixels, not view_centre's every 2nd).
Vec3f median_of_view(const std::vector<uint16_t>& depth, const PinholeIntrinsics& cam, const Pose& T) {
  std::vector<float> xs, ys, zs;
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      const uint16_t r = depth[std::size_t(v) * cam.width + u];
      if (r == 0) continue;
      const Vec3f p = T * cam.back_project(float(u), float(v), float(r) / cam.depth_scale);
      xs.push_back(p.x());
      ys.push_back(p.y());
      zs.push_back(p.z());
    }
  auto med = [](std::vector<float>& v) {
    std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  return Vec3f(med(xs), med(ys), med(zs));
}

}  // namespace

TEST_GROUP(PipelineKernels){};

TEST(PipelineKernels, FloatKernelsMatchTheSerialCoreForAnySplit) { kernels_match_the_serial_core<float>(); }

TEST(PipelineKernels, FixedKernelsMatchTheSerialCoreForAnySplit) { kernels_match_the_serial_core<Fixed>(); }

TEST_GROUP(PipelineMapper){};

TEST(PipelineMapper, KnownPosesCentreANewMapOnTheFirstViewAndTheMapMatchesTheScene) {
  MapperRig rig(PoseMode::kKnown);
  const Frames f = render_frames(known_motion(5), rig.cam);
  CHECK_FALSE(rig.mapper.placed());
  ReferenceStep step;
  Vec3f viewpoints = Vec3f::Zero();
  for (std::size_t i = 0; i < f.poses.size(); ++i) {
    CHECK(rig.mapper.map_reference(rig.ref, frame_of(f, i, rig.cam), &f.poses[i], Pose(), step) == Status::kOk);
    CHECK(step.filtered && step.has_pose && step.integrated && step.track.push);
    CHECK(step.centred == (i == 0));
    CHECK(step.track.first == (i == 0));
    CHECK(step.T_world_cam.t == f.poses[i].t);
    CHECK(rig.mapper.placed());
    viewpoints += f.poses[i].t;
    if (i == 0) {
      // Centred on the median of the first view: the volume's centre is the median world point of
      // the rendered view within a voxel (view_centre samples every 2nd pixel: the medians of the
      // two samplings differ by a few mm on this scene).
      const Vec3f centre = rig.volume.origin_m() + Vec3f::Constant(0.5f * kDim * kVoxel);
      const Vec3f expect = median_of_view(f.depth[0], rig.cam, f.poses[0]);
      std::printf("\n  volume centre (%.4f %.4f %.4f), view median (%.4f %.4f %.4f)", centre.x(), centre.y(),
                  centre.z(), expect.x(), expect.y(), expect.z());
      CHECK((centre - expect).norm() < kVoxel);
    }
  }
  LONGS_EQUAL(5, long(rig.mapper.map_frames()));
  CHECK(rig.mapper.last_capture_us() == f.stamps[4]);
  CHECK((rig.mapper.mean_viewpoint() - viewpoints / 5.0f).norm() < 1e-6f);
  CHECK(rig.mapper.reference().has_pose());
  CHECK(rig.mapper.reference().stamp_us() == f.stamps[4]);
  LONGS_EQUAL(0, rig.mapper.support_weight());  // equal weights (no noise model): every crossing
  // The map seen from the last pose: exact depth, so the raycast surface (trilinear TSDF, regula
  // falsi) lies within a small fraction of a voxel of the rendered one on the planes and boxes;
  // silhouettes and the 7 cm sphere's curvature give the tail (median within 0.05 voxel, 90 %
  // within 0.3 voxel, no bias beyond 0.1 voxel; measured 0.03 / 0.33 / -0.12 mm in float, 0.09 /
  // 0.32 / -0.02 mm in Q16.16, whose rounding is far below these bounds). Coverage:
  // integration skips voxels whose 4 pixels span a depth jump, so a band of about a voxel (2-3
  // pixels at 4 mm per pixel) along every silhouette stays empty: ~10 % of a 160x120 view here.
  CHECK(raycast_frame<real_t>(nullptr, rig.volume, rig.cam, f.poses[4], rig.ref.maps) == Status::kOk);
  const DepthAgreement d = compare_depth(rig.ref.maps.depth_m, f.depth[4], rig.cam, f.poses[4], rig.volume, kMarginM);
  std::printf("\n  raycast vs rendered: %zu of %zu pixels, median %.3f mm, p90 %.3f mm, mean %.3f mm", d.both,
              d.rendered, 1e3f * d.median_abs_m, 1e3f * d.p90_abs_m, 1e3f * d.mean_signed_m);
  CHECK(d.both > d.rendered * 85 / 100);
  CHECK(d.median_abs_m < 0.05f * kVoxel);
  CHECK(d.p90_abs_m < 0.3f * kVoxel);
  CHECK(std::fabs(d.mean_signed_m) < 0.1f * kVoxel);
  // A frame without a known pose: filtered, not integrated, and the reference forgets its pose, so
  // no other camera can be paired with it.
  CHECK(rig.mapper.map_paired(rig.other, frame_of(f, 4, rig.cam), Pose()) == Status::kOk);  // still has one
  LONGS_EQUAL(6, long(rig.mapper.map_frames()));
  const std::size_t observed = rig.volume.observed_voxels();
  SensorFrame unposed = frame_of(f, 3, rig.cam);
  unposed.stamp_us = f.stamps[4] + kFrameUs;
  CHECK(rig.mapper.map_reference(rig.ref, unposed, nullptr, Pose(), step) == Status::kOk);
  CHECK(step.filtered);
  CHECK_FALSE(step.has_pose);
  CHECK_FALSE(step.integrated);
  LONGS_EQUAL(6, long(rig.mapper.map_frames()));
  CHECK(rig.mapper.last_capture_us() == f.stamps[4]);
  CHECK(rig.volume.observed_voxels() == observed);
  CHECK_FALSE(rig.mapper.reference().has_pose());
  CHECK(rig.mapper.map_paired(rig.other, frame_of(f, 4, rig.cam), Pose()) == Status::kNotInitialised);
  LONGS_EQUAL(6, long(rig.mapper.map_frames()));
}

TEST(PipelineMapper, NewMapRecentresAndNewMapInPlaceKeepsThePlacement) {
  MapperRig rig(PoseMode::kKnown);
  const Frames f = render_frames(known_motion(2), rig.cam);
  ReferenceStep step;
  // No map yet: another camera cannot be paired.
  CHECK(rig.mapper.map_paired(rig.other, frame_of(f, 0, rig.cam), Pose()) == Status::kNotInitialised);
  CHECK(rig.mapper.map_reference(rig.ref, frame_of(f, 0, rig.cam), &f.poses[0], Pose(), step) == Status::kOk);
  const Vec3f origin0 = rig.volume.origin_m();
  // A new map from a pose 20 cm further left: cleared and centred on the new view.
  Pose moved = f.poses[1];
  moved.t.x() -= 0.2f;
  std::vector<uint16_t> depth;
  render(box_sphere_corner(), rig.cam, moved, depth);
  SensorFrame sf;
  sf.depth = ImageView<const uint16_t>(depth.data(), rig.cam.width, rig.cam.height);
  sf.stamp_us = f.stamps[1];
  rig.mapper.new_map();
  CHECK_FALSE(rig.mapper.placed());
  LONGS_EQUAL(0, long(rig.mapper.map_frames()));
  CHECK(rig.mapper.mean_viewpoint() == Vec3f::Zero());
  CHECK_FALSE(rig.mapper.reference().has_pose());
  CHECK(rig.mapper.map_reference(rig.ref, sf, &moved, Pose(), step) == Status::kOk);
  CHECK(step.centred && step.integrated && step.track.first);
  LONGS_EQUAL(1, long(rig.mapper.map_frames()));
  CHECK((rig.mapper.mean_viewpoint() - moved.t).norm() < 1e-6f);
  const Vec3f centre = rig.volume.origin_m() + Vec3f::Constant(0.5f * kDim * kVoxel);
  CHECK((centre - median_of_view(depth, rig.cam, moved)).norm() < kVoxel);
  CHECK((rig.volume.origin_m() - origin0).norm() > 0.05f);
  // In place: the caller's placement is kept, and the next frame is integrated there.
  const Vec3f placed_origin = rig.volume.origin_m() + Vec3f(0.01f, 0.02f, 0.03f);
  rig.volume.set_origin(placed_origin);
  rig.volume.clear();
  rig.mapper.new_map_in_place();
  CHECK(rig.mapper.placed());
  LONGS_EQUAL(0, long(rig.mapper.map_frames()));
  CHECK(rig.mapper.map_reference(rig.ref, frame_of(f, 0, rig.cam), &f.poses[0], Pose(), step) == Status::kOk);
  CHECK_FALSE(step.centred);
  CHECK(step.integrated && step.track.first);
  CHECK(rig.volume.origin_m() == placed_origin);
  LONGS_EQUAL(1, long(rig.mapper.map_frames()));
}

// The first frame of a new map that sees nothing in range cannot place the map (view_centre finds
// no point): the map stays pending, and by ReferenceStep / map_frames()'s documentation ("pushed
// into the map", "frames integrated into this map") the frame is not counted, nor its pose in
// mean_viewpoint() (the localiser's viewpoint).
TEST(PipelineMapper, AFirstFrameThatSeesNothingIsNotCountedInTheMap) {
  MapperRig rig(PoseMode::kKnown);
  const Frames f = render_frames(known_motion(2), rig.cam);
  std::vector<uint16_t> blank(std::size_t(rig.cam.width) * rig.cam.height, 0);
  SensorFrame sf;
  sf.depth = ImageView<const uint16_t>(blank.data(), rig.cam.width, rig.cam.height);
  sf.stamp_us = f.stamps[0];
  Pose far = f.poses[0];
  far.t += Vec3f(1.0f, 0, 0);
  ReferenceStep blank_step, step;
  CHECK(rig.mapper.map_reference(rig.ref, sf, &far, Pose(), blank_step) == Status::kOk);
  const bool placed_after_blank = rig.mapper.placed();
  const uint32_t frames_after_blank = rig.mapper.map_frames();
  CHECK(rig.mapper.map_reference(rig.ref, frame_of(f, 1, rig.cam), &f.poses[1], Pose(), step) == Status::kOk);
  const Vec3f vp = rig.mapper.mean_viewpoint();
  std::printf("\n  blank frame: centred %d, integrated %d, placed %d, map_frames %u; after the next frame: "
              "map_frames %u, mean_viewpoint %.3f m from that frame's position",
              int(blank_step.centred), int(blank_step.integrated), int(placed_after_blank), frames_after_blank,
              rig.mapper.map_frames(), (vp - f.poses[1].t).norm());
  CHECK_FALSE(blank_step.centred);
  CHECK_FALSE(placed_after_blank);
  CHECK_FALSE(blank_step.integrated);
  LONGS_EQUAL(0, long(frames_after_blank));
  CHECK(step.centred && step.integrated);
  LONGS_EQUAL(1, long(rig.mapper.map_frames()));
  CHECK((vp - f.poses[1].t).norm() < 1e-6f);
}

namespace {

struct TrackedRun {
  std::vector<ReferenceStep> steps;
  long allocations = 0;
  uint32_t map_frames = 0;
};

TrackedRun run_tracked(const Frames& f, const PushPolicy& push) {
  MapperRig rig(PoseMode::kTracked, push);
  TrackedRun run;
  run.steps.resize(f.poses.size());
  for (std::size_t i = 0; i < f.poses.size(); ++i) {
    const SensorFrame sf = frame_of(f, i, rig.cam);
    if (i >= 2) alloc_count_start();  // steady state: after the first frame and the first tracked one
    const Status s = rig.mapper.map_reference(rig.ref, sf, nullptr, f.poses[0], run.steps[i]);
    if (i >= 2) run.allocations += alloc_count();
    CHECK(s == Status::kOk);
  }
  run.map_frames = rig.mapper.map_frames();
  return run;
}

// The same bound in both builds: Q16.16's step (1.5e-5 m) is 1/600 of a voxel, and its ICP sums
// are accumulated in 64 bits; measured worst errors 0.17 mm / 0.016 degree (float) and 0.23 mm /
// 0.013 degree (fixed), so neither needs a wider bound.
constexpr float kTrackTolM = 0.001f, kTrackTolDeg = 0.1f;

}  // namespace

TEST(PipelineMapper, TrackedPosesFollowTheTruthAndArePushedAfterACentimetreOrADegree) {
  // ~4 mm and 0.4 degree per frame (known_motion): ICP on exact depth against the map's raycast
  // (surface within ~0.1 voxel = 1 mm, averaged over thousands of points) holds the pose to well
  // under a millimetre; the rig's 320x240 test holds 1 mm / 0.1 degree, and 160x120 halves the
  // points but not their accuracy.
  const Frames f = render_frames(known_motion(10), small_camera());
  const TrackedRun run = run_tracked(f, PushPolicy());
  float worst_t = 0, worst_deg = 0;
  Pose last_push = f.poses[0];
  int pushes = 0;
  for (std::size_t i = 0; i < f.poses.size(); ++i) {
    const ReferenceStep& s = run.steps[i];
    float dt, deg;
    pose_distance(s.T_world_cam, f.poses[i], dt, deg);
    std::printf("\n  frame %zu: %s push %d, error %.3f mm %.4f deg", i, to_string(s.track.state), int(s.integrated),
                1e3f * dt, deg);
    CHECK(s.has_pose);
    CHECK(s.track.state == TrackState::kOk);
    worst_t = std::max(worst_t, dt);
    worst_deg = std::max(worst_deg, deg);
    CHECK(s.integrated == s.track.push);
    if (i == 0) {
      CHECK(s.centred && s.integrated && s.track.first);
      continue;
    }
    // The push policy on the tracked poses: pushed exactly when 1 cm or 1 degree from the last push.
    float mt, mdeg;
    pose_distance(last_push, s.T_world_cam, mt, mdeg);
    const bool far = mt > 0.01f || mdeg > 1.0f;
    CHECK(s.integrated == far);
    if (s.integrated) {
      last_push = s.T_world_cam;
      ++pushes;
    }
  }
  std::printf("\n  worst %.3f mm %.4f deg, %d pushes after the first, %ld allocations", 1e3f * worst_t, worst_deg,
              pushes, run.allocations);
  CHECK(worst_t < kTrackTolM);
  CHECK(worst_deg < kTrackTolDeg);
  CHECK(pushes >= 2);                         // ~4 cm and 4 degrees in all cross the thresholds ...
  CHECK(pushes < int(f.poses.size()) - 1);    // ... but not on every frame
  LONGS_EQUAL(1 + pushes, long(run.map_frames));
  LONGS_EQUAL(0, run.allocations);  // filter, raycast, pyramid, ICP, push, integrate: no heap
}

TEST(PipelineMapper, PushEveryFrameIntegratesEveryTrackedFrame) {
  const Frames f = render_frames(known_motion(5), small_camera());
  PushPolicy every;
  every.every_frame = true;
  const TrackedRun run = run_tracked(f, every);
  for (const ReferenceStep& s : run.steps) {
    CHECK(s.has_pose);
    CHECK(s.integrated);
  }
  LONGS_EQUAL(5, long(run.map_frames));
  LONGS_EQUAL(0, run.allocations);
}

namespace {

// The rig on an exactly constant-velocity path (0.3 m/s towards the scene and sideways, 20 deg/s
// about a fixed axis of the rig): PoseHistory's interpolation between two frames is then exact.
Pose rig_path(double t_s) {
  Pose p = look_at(Vec3f(-0.02f, -0.01f, 0.0f), Vec3f(0.0f, 0.0f, 0.8f), Vec3f(0, 1, 0));
  p.t += Vec3f(0.1f, 0.0f, 0.3f) * float(t_s);
  p.R = p.R * Eigen::AngleAxisf(float(t_s) * 20.0f * 3.14159265f / 180.0f, Vec3f(0.3f, 1.0f, 0.1f).normalized())
                  .toRotationMatrix();
  return p;
}

}  // namespace

TEST(PipelineMapper, PairedCameraIsPlacedAtTheReferencePoseOfItsOwnStamp) {
  MapperRig rig(PoseMode::kKnown);
  std::vector<Pose> poses;
  for (int i = 0; i < 3; ++i) poses.push_back(rig_path(double(i) * double(kFrameUs) * 1e-6));
  const Frames f = render_frames(poses, rig.cam);
  ReferenceStep step;
  for (std::size_t i = 0; i < 3; ++i)
    CHECK(rig.mapper.map_reference(rig.ref, frame_of(f, i, rig.cam), &f.poses[i], Pose(), step) == Status::kOk);
  // The other camera: 6 cm to the right, turned 12 degrees left, its frame half-way between the
  // last two reference frames. The nearest reference frame would misplace it by 0.3 m/s x 16.7 ms
  // = 5.3 mm (mostly along its view: a depth bias); the interpolated pose is exact to float.
  Pose T_ref_cam;
  T_ref_cam.R = Eigen::AngleAxisf(-12.0f * 3.14159265f / 180.0f, Vec3f::UnitY()).toRotationMatrix();
  T_ref_cam.t = Vec3f(0.06f, 0.0f, 0.0f);
  const uint64_t stamp = f.stamps[1] + kFrameUs / 2;
  const Pose truth = rig_path(double(stamp - kStamp0) * 1e-6) * T_ref_cam;
  float dt, deg;
  pose_distance(rig.mapper.reference().pose_at(stamp) * T_ref_cam, truth, dt, deg);
  std::printf("\n  pose_at error %.4f mm %.5f deg", 1e3f * dt, deg);
  CHECK(dt < 1e-5f);
  CHECK(deg < 0.005f);
  std::vector<uint16_t> depth;
  render(box_sphere_corner(), rig.cam, truth, depth);
  SensorFrame sf;
  sf.depth = ImageView<const uint16_t>(depth.data(), rig.cam.width, rig.cam.height);
  sf.stamp_us = stamp;
  const Vec3f sum = rig.mapper.mean_viewpoint() * 3.0f;
  CHECK(rig.mapper.map_paired(rig.other, sf, T_ref_cam) == Status::kOk);
  LONGS_EQUAL(4, long(rig.mapper.map_frames()));
  CHECK(rig.mapper.last_capture_us() == f.stamps[2]);  // the reference's stamp: pairing does not move it
  CHECK((rig.mapper.mean_viewpoint() - (sum + truth.t) / 4.0f).norm() < 1e-5f);
  // Through the map: seen from the other camera's true pose, the map matches what it rendered (the
  // surface only it saw included). Same bounds as the known-pose map: placed at the nearest
  // reference frame's pose instead (5.3 mm off) the median is 0.9 mm and the mean 1.3 mm.
  CHECK(raycast_frame<real_t>(nullptr, rig.volume, rig.cam, truth, rig.other.maps) == Status::kOk);
  const DepthAgreement d = compare_depth(rig.other.maps.depth_m, depth, rig.cam, truth, rig.volume, kMarginM);
  std::printf("\n  paired raycast vs rendered: %zu of %zu pixels, median %.3f mm, p90 %.3f mm, mean %.3f mm", d.both,
              d.rendered, 1e3f * d.median_abs_m, 1e3f * d.p90_abs_m, 1e3f * d.mean_signed_m);
  CHECK(d.both > d.rendered * 85 / 100);
  CHECK(d.median_abs_m < 0.05f * kVoxel);
  CHECK(d.p90_abs_m < 0.3f * kVoxel);
  CHECK(std::fabs(d.mean_signed_m) < 0.1f * kVoxel);
}
