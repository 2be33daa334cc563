// The noise rules of multi-sensor fusion shared by `edgefuse fuse --sensors`, `localize --sensors`
// and edgefused (fusion_rules.hpp), and the physics of the evidence rule: a voxel fed only samples
// worth less than half a weight unit (a ToF pixel of 6.7 mm against sigma_ref 1 mm: 0.18 unit) never
// holds more than 8 units however many frames come, so a support of 9 leaves no crossing made of
// them alone, while one frame of a 1.4 mm camera (0.51 trust: 4 units) passes support 4 and three
// pass 9. Float and fixed-point kernels alike; zero allocations.
#include <cmath>
#include <cstdio>
#include <vector>

#include "alloc_counter.hpp"
#include "edgefuse/fusion/fusion_rules.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "edgefuse/tsdf/integrate.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {
constexpr int kDim = 64;
constexpr float kVoxel = 0.002f, kTrunc = 0.008f, kPlaneZ = 0.7f, kSigmaRef = 0.001f;
VolumeStorage<kDim> g_storage;
SensorBuffers<float> g_buf_f;
SensorBuffers<Fixed> g_buf_q;
SurfacePoint g_points[kDim * kDim * 4];

//! Integrates `frames` noise-free frames of a plane at 0.7 m whose pixels all carry the trust of a
//! sensor of noise sigma_m; returns the largest weight within trunc/2 of the plane and the crossings at supports 4 and 9.
template <class Real>
void plane_frames(float sigma_m, int frames, SensorBuffers<Real>& buf, int& max_w, std::size_t& n4, std::size_t& n9,
                  int fill_units = kWeightUnitsPerSample, int first_frames = 0, float first_sigma_m = 0.0f) {
  const PinholeIntrinsics intr = bin_rig_a_tof_camera();
  Scene scene;
  scene.add_plane(Vec3f(0, 0, -1), kPlaneZ);
  std::vector<uint16_t> depth;
  render(scene, intr, Pose::identity(), depth);
  const NoiseModel noise = NoiseModel::constant(sigma_m);
  std::vector<uint8_t> trust(depth.size());
  const ImageView<const uint16_t> dv(depth.data(), intr.width, intr.height);
  CHECK(build_trust_map(noise, kSigmaRef, dv, intr.depth_scale, {}, ImageView<uint8_t>(trust.data(), intr.width, intr.height)) ==
        Status::kOk);
  TsdfVolume vol;
  const float half = 0.5f * kDim * kVoxel;
  CHECK(vol.init(g_storage.view(false), kDim, Vec3f(-half, -half, kPlaneZ - half + 0.0003f),
                 TsdfParams::defaults_for(kVoxel, kTrunc)) == Status::kOk);
  DepthFrame f;
  f.depth = dv;
  f.trust = ImageView<const uint8_t>(trust.data(), intr.width, intr.height);
  f.jump_m = noise_jump_m(sigma_m, kJumpSigmas);
  f.sub_unit_fill_units = fill_units;
  // Optionally `first_frames` frames of another sensor (noise first_sigma_m) before.
  std::vector<uint8_t> trust_first(depth.size());
  DepthFrame f0 = f;
  if (first_frames > 0) {
    CHECK(build_trust_map(NoiseModel::constant(first_sigma_m), kSigmaRef, dv, intr.depth_scale, {},
                          ImageView<uint8_t>(trust_first.data(), intr.width, intr.height)) == Status::kOk);
    f0.trust = ImageView<const uint8_t>(trust_first.data(), intr.width, intr.height);
    f0.jump_m = noise_jump_m(first_sigma_m, kJumpSigmas);
  }
  FrameScratch s = buf.scratch();
  const ImageView<const Real> norms = buf.ray_norms(intr);
  const long before = alloc_count();
  for (int i = 0; i < first_frames; ++i) CHECK(integrate<Real>(vol, intr, norms, f0, Pose::identity(), s) == Status::kOk);
  for (int i = 0; i < frames; ++i) CHECK(integrate<Real>(vol, intr, norms, f, Pose::identity(), s) == Status::kOk);
  CHECK(extract_points(vol, g_points, sizeof(g_points) / sizeof(g_points[0]), n4, 4) == Status::kOk);
  CHECK(extract_points(vol, g_points, sizeof(g_points) / sizeof(g_points[0]), n9, kEvidenceSupportWeight) == Status::kOk);
  LONGS_EQUAL(before, alloc_count());
  max_w = 0;  // over the surface's band (voxels in free space further in front take full free-space updates)
  for (int z = 0; z < kDim; ++z)
    for (int y = 0; y < kDim; ++y)
      for (int x = 0; x < kDim; ++x)
        if (std::fabs(vol.voxel_centre(x, y, z).z() - kPlaneZ) < 0.5f * kTrunc)
          max_w = std::max(max_w, int(vol.weight()[vol.index(x, y, z)]));
}
}  // namespace

TEST_GROUP(FusionRules){};

TEST(FusionRules, RuleValues) {
  DOUBLES_EQUAL(0.0, noise_jump_m(0.0067f, 0.0f), 0.0);
  DOUBLES_EQUAL(2.83 * 0.0067, noise_jump_m(0.0067f, kJumpSigmas), 1e-6);
  DOUBLES_EQUAL(1.0, noise_jump_m(0.5f, 10.0f), 0.0);  // integration's bound
  CHECK(!sub_unit_sensor(0.0014f, kSigmaRef));  // Xtion at 0.7 m: 4 units
  CHECK(!sub_unit_sensor(0.0040f, kSigmaRef));  // exactly half a unit
  CHECK(sub_unit_sensor(0.0041f, kSigmaRef));
  CHECK(sub_unit_sensor(0.0067f, kSigmaRef));   // the ToF on bin_rig_a
  CHECK(!sub_unit_sensor(0.0f, kSigmaRef));     // no data
  const float xtion_tof[] = {0.0014f, 0.0067f}, tof_only[] = {0.0067f}, xtion_only[] = {0.0014f},
              tof_nodata[] = {0.0067f, 0.0f}, two_good[] = {0.0014f, 0.0012f};
  LONGS_EQUAL(9, default_support_weight(xtion_tof, 2, kSigmaRef));
  LONGS_EQUAL(4, default_support_weight(tof_only, 1, kSigmaRef));
  LONGS_EQUAL(4, default_support_weight(xtion_only, 1, kSigmaRef));
  LONGS_EQUAL(4, default_support_weight(tof_nodata, 2, kSigmaRef));
  LONGS_EQUAL(4, default_support_weight(two_good, 2, kSigmaRef));
  LONGS_EQUAL(kWeightUnitsPerSample + 1, kEvidenceSupportWeight);
  // A mixed set fills sub-unit samples to 3 (< the support rule's 4), and then needs 4 only.
  CHECK(kSubUnitFillUnits < kMinSupportWeight);
  CHECK(mixed_sub_unit_set(xtion_tof, 2, kSigmaRef));
  CHECK(!mixed_sub_unit_set(tof_only, 1, kSigmaRef) && !mixed_sub_unit_set(xtion_only, 1, kSigmaRef));
  CHECK(!mixed_sub_unit_set(tof_nodata, 2, kSigmaRef) && !mixed_sub_unit_set(two_good, 2, kSigmaRef));
  LONGS_EQUAL(kSubUnitFillUnits, default_sub_unit_fill(xtion_tof, 2, kSigmaRef));
  LONGS_EQUAL(kWeightUnitsPerSample, default_sub_unit_fill(tof_only, 1, kSigmaRef));
  LONGS_EQUAL(kWeightUnitsPerSample, default_sub_unit_fill(xtion_only, 1, kSigmaRef));
  LONGS_EQUAL(kWeightUnitsPerSample, default_sub_unit_fill(two_good, 2, kSigmaRef));
  LONGS_EQUAL(4, default_support_weight(xtion_tof, 2, kSigmaRef, kSubUnitFillUnits));
  LONGS_EQUAL(9, default_support_weight(xtion_tof, 2, kSigmaRef, kWeightUnitsPerSample));
  LONGS_EQUAL(9, default_support_weight(xtion_tof, 2, kSigmaRef, kMinSupportWeight));
  LONGS_EQUAL(4, default_support_weight(tof_only, 1, kSigmaRef, kSubUnitFillUnits));
  LONGS_EQUAL(kWeightUnitsPerSample, DepthFrame{}.sub_unit_fill_units);  // default: one full sample
}

namespace {
// The frame's median noise comes with its trust map (build_trust_map's optional output).
float median_sigma_of(const NoiseModel& model, const uint16_t* d, int n) {
  uint8_t trust[8];
  float med = -1.0f;
  CHECK(build_trust_map(model, kSigmaRef, ImageView<const uint16_t>(d, n, 1), 5000.0f, {}, ImageView<uint8_t>(trust, n, 1),
                        0.0f, &med) == Status::kOk);
  return med;
}
}  // namespace

TEST(FusionRules, MedianSigmaOfAFrame) {
  uint16_t d[6] = {0, 3500, 3500, 3500, 5000, 5000};  // 0.7 m x3, 1.0 m x2 (depth scale 5000)
  const NoiseModel sl = NoiseModel::structured_light();
  const float med = median_sigma_of(sl, d, 6);
  DOUBLES_EQUAL(sl.sigma_m(0.7f), med, 0.000125);
  uint16_t none[2] = {0, 0};
  DOUBLES_EQUAL(0.0, median_sigma_of(sl, none, 2), 0.0);
}

TEST(FusionRules, SubUnitSamplesNeverReachTheEvidenceRule) {
  int w_tof = 0, w_tof_q = 0, w_one = 0, w_three = 0;
  std::size_t tof4 = 0, tof9 = 0, tof4_q = 0, tof9_q = 0, one4 = 0, one9 = 0, three4 = 0, three9 = 0;
  plane_frames<float>(0.0067f, 20, g_buf_f, w_tof, tof4, tof9);
  plane_frames<Fixed>(0.0067f, 20, g_buf_q, w_tof_q, tof4_q, tof9_q);
  plane_frames<float>(0.0014f, 1, g_buf_f, w_one, one4, one9);
  plane_frames<float>(0.0014f, 3, g_buf_f, w_three, three4, three9);
  std::printf("\nplane, 20 frames at 6.7 mm: max weight %d (fixed %d), crossings %zu at support 4, %zu at 9; "
              "1.4 mm: 1 frame max %d, %zu / %zu; 3 frames max %d, %zu / %zu\n",
              w_tof, w_tof_q, tof4, tof9, w_one, one4, one9, w_three, three4, three9);
  CHECK(w_tof <= kWeightUnitsPerSample);  // 20 samples, at most 8 units stored
  CHECK(w_tof_q <= kWeightUnitsPerSample);
  CHECK(tof4 > std::size_t(kDim * kDim / 2));  // support 4 keeps the ToF's plane at fill 8
  LONGS_EQUAL(0, tof9);                        // the evidence rule does not
  LONGS_EQUAL(tof4, tof4_q);
  LONGS_EQUAL(0, tof9_q);
  CHECK(one4 > std::size_t(kDim * kDim / 2));  // one 1.4 mm frame: 4 units, passes 4 ...
  LONGS_EQUAL(0, one9);                        // ... not 9
  CHECK(three9 > std::size_t(kDim * kDim / 2));  // three frames pass the evidence rule
}

// With the mixed set's fill, 20 ToF frames alone stop at 3 units (float and Q16.16), so
// support 4 leaves none of their crossings; one 1.4 mm frame still passes 4. Where the ToF comes
// after one such frame (4 units) it adds nothing; where it comes first, 3 units against the frame's 4.
// The default fill (8) gives the volume of the test above, here checked again.
TEST(FusionRules, MixedSetFillStopsSubUnitSamplesBelowTheSupportRule) {
  int w = 0, w_q = 0, w_one = 0, w_after = 0;
  std::size_t n4 = 0, n9 = 0, n4_q = 0, n9_q = 0, one4 = 0, one9 = 0, a4 = 0, a9 = 0;
  plane_frames<float>(0.0067f, 20, g_buf_f, w, n4, n9, kSubUnitFillUnits);
  plane_frames<Fixed>(0.0067f, 20, g_buf_q, w_q, n4_q, n9_q, kSubUnitFillUnits);
  plane_frames<float>(0.0014f, 1, g_buf_f, w_one, one4, one9, kSubUnitFillUnits);
  plane_frames<float>(0.0067f, 20, g_buf_f, w_after, a4, a9, kSubUnitFillUnits, 1, 0.0014f);
  std::printf("\nplane, fill 3: 20 frames at 6.7 mm max weight %d (fixed %d), crossings %zu at support 4; one 1.4 mm "
              "frame %d, %zu; that frame then 20 ToF frames: %d, %zu\n", w, w_q, n4, w_one, one4, w_after, a4);
  LONGS_EQUAL(kSubUnitFillUnits, w);  // 20 samples, 3 units stored
  LONGS_EQUAL(kSubUnitFillUnits, w_q);
  LONGS_EQUAL(0, n4);                 // a ToF-only voxel never passes the support rule
  LONGS_EQUAL(0, n4_q);
  CHECK(one4 > std::size_t(kDim * kDim / 2));  // the xtion's single-frame crossings stay
  CHECK(w_after <= 4);                         // 4 units, the ToF adds none on top
  LONGS_EQUAL(one4, a4);
  // The ToF first (3 units), then the 1.4 mm frame (4): 7 units, the surface passes support 4.
  int w_first = 0;
  std::size_t f4 = 0, f9 = 0;
  plane_frames<float>(0.0014f, 1, g_buf_f, w_first, f4, f9, kSubUnitFillUnits, 20, 0.0067f);  // 20 ToF frames first
  CHECK(w_first <= kSubUnitFillUnits + 4);
  CHECK(f4 > std::size_t(kDim * kDim / 2));
  LONGS_EQUAL(0, f9);
  // Default fill: at most 8 units, crossings at support 4.
  int w8 = 0, w8_q = 0;
  std::size_t m4 = 0, m9 = 0, m4_q = 0, m9_q = 0;
  plane_frames<float>(0.0067f, 20, g_buf_f, w8, m4, m9);
  plane_frames<Fixed>(0.0067f, 20, g_buf_q, w8_q, m4_q, m9_q);
  LONGS_EQUAL(kWeightUnitsPerSample, w8);
  LONGS_EQUAL(kWeightUnitsPerSample, w8_q);
  CHECK(m4 > std::size_t(kDim * kDim / 2));
}

// A fill outside 1..255 is refused before anything is integrated.
TEST(FusionRules, BadSubUnitFillRejected) {
  const PinholeIntrinsics intr = bin_rig_a_tof_camera();
  Scene scene;
  scene.add_plane(Vec3f(0, 0, -1), kPlaneZ);
  std::vector<uint16_t> depth;
  render(scene, intr, Pose::identity(), depth);
  TsdfVolume vol;
  const float half = 0.5f * kDim * kVoxel;
  CHECK(vol.init(g_storage.view(false), kDim, Vec3f(-half, -half, kPlaneZ - half), TsdfParams::defaults_for(kVoxel, kTrunc)) ==
        Status::kOk);
  DepthFrame f;
  f.depth = ImageView<const uint16_t>(depth.data(), intr.width, intr.height);
  FrameScratch s = g_buf_f.scratch();
  for (int bad : {0, -3, 256}) {
    f.sub_unit_fill_units = bad;
    CHECK(integrate<float>(vol, intr, g_buf_f.ray_norms(intr), f, Pose::identity(), s) == Status::kInvalidArgument);
  }
  LONGS_EQUAL(0, int(vol.observed_voxels()));
}
