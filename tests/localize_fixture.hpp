// Static buffers of a localiser for the rendered-scene tests (test_localize, test_localize_rest):
// a 128^3 volume, the sensor's scratch, two models' tables and one scene's tables, as the board's
// memory map would give them. Include once per test binary, after the STL / edgefuse headers and
// before CppUTest's (its `new` macro); the storage lives in this binary's anonymous namespace.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "edgefuse/localize/localizer.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "edgefuse/tsdf/integrate.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

namespace {

using namespace edgefuse;
using namespace edgefuse_test;

constexpr int kDim = 128;
constexpr int kModels = 2;
constexpr uint32_t kModelPoints = 2048, kPpfPoints = 256, kScenePoints = 120000, kHypotheses = 4096;
constexpr int kObjects = 8;

VolumeStorage<kDim> g_vol;
SensorBuffers<float> g_sensor;
SurfacePoint g_points[200000];
ModelInfo g_models[kModels];
OrientedPoint g_model_points[kModels * kModelPoints];
OrientedPoint g_ppf_points[kModels * kPpfPoints];
PpfEntry g_entries[kModels * kPpfPoints * (kPpfPoints - 1)];
uint32_t g_buckets[kModels * (kPpfBuckets + 1)];
ScenePoint g_scene[kScenePoints];
uint64_t g_scratch[2 * kScenePoints];
uint32_t g_grid_index[kScenePoints], g_grid_buckets[kGridBuckets + 1], g_sample[kScenePoints], g_queue[kScenePoints];
int32_t g_labels[kScenePoints];
uint64_t g_grid_near[kGridBuckets / 64];
Vec3f g_grid_points[kScenePoints];
uint16_t g_votes[kVoteAccumulators * kPpfPoints * kPpfAngleBins];
PoseCandidate g_candidates[kHypotheses];
LocalizedObject g_verified[kModels * kClustersPerModel], g_results[kObjects];

LocalizeBuffers buffers() {
  LocalizeBuffers b;
  b.models = g_models;
  b.model_points = g_model_points;
  b.ppf_points = g_ppf_points;
  b.ppf_entries = g_entries;
  b.ppf_buckets = g_buckets;
  b.scene = g_scene;
  b.scratch = g_scratch;
  b.grid_index = g_grid_index;
  b.grid_buckets = g_grid_buckets;
  b.grid_near = g_grid_near;
  b.grid_points = g_grid_points;
  b.sample = g_sample;
  b.labels = g_labels;
  b.queue = g_queue;
  b.votes = g_votes;
  b.candidates = g_candidates;
  b.verified = g_verified;
  b.results = g_results;
  b.models_max = kModels;
  b.model_points_max = kModelPoints;
  b.ppf_points_max = kPpfPoints;
  b.scene_points_max = kScenePoints;
  b.hypotheses_max = kHypotheses;
  b.objects_max = kObjects;
  return b;
}

//! The rendered scenes' camera: 320x240, 0.2-2 m, the bin_rig_a xtion's focal length.
PinholeIntrinsics camera() {
  PinholeIntrinsics c;
  c.width = 320;
  c.height = 240;
  c.fx = c.fy = 288.6f;
  c.cx = 159.5f;
  c.cy = 119.5f;
  c.depth_scale = 5000;
  c.min_range_m = 0.2f;
  c.max_range_m = 2.0f;
  return c;
}

//! Fuses the scene seen from three viewpoints above the floor into vol (128^3 x 3 mm) and extracts
//! its surface into g_points; returns the point count and the mean viewpoint.
//! \param max_incidence_deg depth seen at more than this incidence is dropped, as a structured-light
//! camera does (bin_rig_a's xtion: 75); 0 keeps every pixel
std::size_t fuse(const Scene& scene, TsdfVolume& vol, Vec3f& viewpoint, float max_incidence_deg = 0) {
  const PinholeIntrinsics cam = camera();
  CHECK(vol.init(g_vol.view(false), kDim, Vec3f(-0.192f, -0.192f, -0.05f), TsdfParams::defaults_for(0.003f, 0.012f)) ==
        Status::kOk);
  const ImageView<const float> norms = g_sensor.ray_norms(cam);
  FrameScratch scratch = g_sensor.scratch();
  const Vec3f eyes[3] = {Vec3f(0, 0, 0.6f), Vec3f(0.05f, 0.02f, 0.6f), Vec3f(-0.04f, 0.05f, 0.58f)};
  viewpoint = Vec3f::Zero();
  for (const Vec3f& eye : eyes) {
    const Pose T = look_at(eye, Vec3f(0, 0, 0), Vec3f(0, 1, 0));
    std::vector<uint16_t> depth;
    std::vector<float> cos_incidence;
    render(scene, cam, T, depth, nullptr, max_incidence_deg > 0 ? &cos_incidence : nullptr);
    if (max_incidence_deg > 0) {
      const float cos_max = std::cos(max_incidence_deg * 3.14159265f / 180.0f);
      for (std::size_t i = 0; i < depth.size(); ++i)
        if (cos_incidence[i] < cos_max) depth[i] = 0;
    }
    const DepthFrame f{{depth.data(), cam.width, cam.height}, {}};
    CHECK(integrate<float>(vol, cam, norms, f, T, scratch) == Status::kOk);
    viewpoint += eye / 3.0f;
  }
  std::size_t count = 0;
  extract_points(vol, g_points, sizeof(g_points) / sizeof(g_points[0]), count);
  return count;
}

// A closed box mesh, centred, counter-clockwise from outside.
[[maybe_unused]] void box_mesh(const Vec3f& half, std::vector<Vec3f>& v, std::vector<std::array<uint32_t, 3>>& t) {
  v.clear();
  for (int i = 0; i < 8; ++i)
    v.push_back(Vec3f((i & 1) ? half.x() : -half.x(), (i & 2) ? half.y() : -half.y(), (i & 4) ? half.z() : -half.z()));
  t = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
       {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
}

// Largest distance from a box corner at the estimate to the nearest true corner (symmetry-aware).
[[maybe_unused]] float corner_error(const Vec3f& half, const Pose& est, const Pose& truth) {
  float worst = 0;
  for (int i = 0; i < 8; ++i) {
    const Vec3f c((i & 1) ? half.x() : -half.x(), (i & 2) ? half.y() : -half.y(), (i & 4) ? half.z() : -half.z());
    float best = 1e9f;
    for (int j = 0; j < 8; ++j) {
      const Vec3f d((j & 1) ? half.x() : -half.x(), (j & 2) ? half.y() : -half.y(), (j & 4) ? half.z() : -half.z());
      best = std::min(best, (est * c - truth * d).norm());
    }
    worst = std::max(worst, best);
  }
  return worst;
}

}  // namespace
