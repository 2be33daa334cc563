// Static buffers of a localiser for the rendered-scene tests (test_localize, test_localize_rest):
// a 128^3 volume, the sensor's scratch, two models' tables and one scene's tables, as the board's
// memory map would give them. Include once per test binary, after the STL / edgefuse headers and
// before CppUTest's (its `new` macro); the storage lives in this binary's anonymous namespace.
#pragma once
#include "edgefuse/localize/localizer.hpp"
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

}  // namespace
