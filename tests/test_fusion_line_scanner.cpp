// Line scanner moved linearly (paper eq. 6-8): a swept profile scanner back-projected into the
// space reproduces the rendered surface, a profile raycast out of the space reproduces the exact
// ranges (round trip), float and Q16.16 agree, and a push and a raycast allocate nothing.
#include <algorithm>
#include <cmath>
#include <vector>

#include "alloc_counter.hpp"
#include "edgefuse/sensor/line_scanner.hpp"
#include "edgefuse/tsdf/integrate_profile.hpp"
#include "edgefuse/tsdf/raycast.hpp"
#include "edgefuse/tsdf/register_profiles.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {
constexpr int kDim = 64;
constexpr float kVoxel = 0.002f;
VolumeStorage<kDim> g_storage;
float g_tan_f[640];
Fixed g_tan_q[640];
float g_ranges[640], g_model[640];

LineScannerModel scanner() {
  LineScannerModel m;
  m.beams = 640;
  m.fov_deg = 20.0f;
  m.min_range_m = 0.05f;
  m.max_range_m = 0.265f;
  return m;
}

// A floor at z = 0, a box 16 mm high and a sphere cap: the bin_rig_a laser's geometry at small scale.
Scene bin_scene() {
  Scene s;
  s.add_plane(Vec3f(0, 0, 1), 0.0f);
  Pose R;
  R.R = Eigen::AngleAxisf(0.4f, Vec3f(0, 0, 1)).toRotationMatrix();
  s.add_box(Vec3f(-0.012f, 0.004f, 0.008f), Vec3f(0.015f, 0.012f, 0.008f), R);
  s.add_sphere(Vec3f(0.022f, -0.015f, -0.004f), 0.018f);
  return s;
}

// Scanner looking straight down (x' = x, y' = -y, z' = -z) at height 0.22 m, at y.
Pose scanner_pose(float y) {
  Pose T;
  T.R = Eigen::AngleAxisf(float(M_PI), Vec3f(1, 0, 0)).toRotationMatrix();
  T.t = Vec3f(0.0f, y, 0.22f);
  return T;
}

void render_profile(const Scene& s, const LineScannerModel& m, const Pose& T, float* ranges) {
  for (int i = 0; i < m.beams; ++i) {
    const float th = m.beam_angle_rad(i);
    const Vec3f dir = T.R * Vec3f(std::sin(th), 0, std::cos(th));
    float t;
    Vec3f n;
    int item;
    ranges[i] = s.intersect(T.t, dir, t, n, item) && t >= m.min_range_m && t <= m.max_range_m ? t : 0.0f;
  }
}

template <class Real>
LineScannerTables<Real> tables();
template <>
LineScannerTables<float> tables<float>() { return LineScannerTables<float>{g_tan_f, 640}; }
template <>
LineScannerTables<Fixed> tables<Fixed>() { return LineScannerTables<Fixed>{g_tan_q, 640}; }

template <class Real>
void sweep(TsdfVolume& vol, const Scene& scene, float step_m) {
  vol.init(g_storage.view(false), kDim, Vec3f(-0.064f, -0.064f, -0.03f), TsdfParams::defaults_for(kVoxel, 4 * kVoxel));
  const LineScannerModel m = scanner();
  LineScannerTables<Real> tab = tables<Real>();
  CHECK(tab.build(m) == Status::kOk);
  for (float y = -0.05f; y <= 0.05f + 1e-6f; y += step_m) {
    render_profile(scene, m, scanner_pose(y), g_ranges);
    CHECK(integrate_profile<Real>(vol, m, tab, g_ranges, scanner_pose(y)) == Status::kOk);
  }
}

// |model - exact| over the beams both have, at a pose between two profiles.
template <class Real>
void round_trip(const TsdfVolume& vol, const Scene& scene, float y, float& median_m, float& p95_m, int& hits) {
  const LineScannerModel m = scanner();
  render_profile(scene, m, scanner_pose(y), g_ranges);
  CHECK(raycast_profile<Real>(vol, m, scanner_pose(y), g_model) == Status::kOk);
  std::vector<float> err;
  for (int i = 0; i < m.beams; ++i)
    if (g_ranges[i] > 0 && g_model[i] > 0) err.push_back(std::fabs(g_ranges[i] - g_model[i]));
  hits = int(err.size());
  std::sort(err.begin(), err.end());
  median_m = err.empty() ? 1.0f : err[err.size() / 2];
  p95_m = err.empty() ? 1.0f : err[err.size() * 95 / 100];
}
}  // namespace

TEST_GROUP(LineScanner){};

// Back-projection: the TSDF vanishes on the rendered floor and box top inside the swept fan.
TEST(LineScanner, SweepBackProjectsOntoTheSurface) {
  TsdfVolume vol;
  const Scene scene = bin_scene();
  sweep<float>(vol, scene, 0.001f);
  int inside = 0, near_zero = 0;
  for (float x = -0.03f; x <= 0.03f; x += 0.0023f)
    for (float y = -0.045f; y <= 0.045f; y += 0.0023f) {
      float t;
      Vec3f n;
      int item;
      if (!scene.intersect(Vec3f(x, y, 0.22f), Vec3f(0, 0, -1), t, n, item) || n.z() < 0.9f) continue;
      const Vec3f p(x, y, 0.22f - t);
      // away from the box's and the sphere's rims (the scanner's grazing view there is clipped)
      float d;
      if (!sample_tsdf<float>(vol, p, d)) continue;
      ++inside;
      near_zero += std::fabs(d) < 0.25f * kVoxel;
    }
  CHECK(inside > 300);
  CHECK(near_zero > inside * 9 / 10);
}

// Round trip: a profile raycast between two pushed profiles reproduces the exact ranges.
TEST(LineScanner, ProfileRaycastRoundTrip) {
  TsdfVolume vol;
  const Scene scene = bin_scene();
  sweep<float>(vol, scene, 0.001f);
  float median, p95;
  int hits;
  round_trip<float>(vol, scene, 0.0035f, median, p95, hits);
  std::printf("\n  line scanner round trip (float): %d beams, median %.3f mm, p95 %.3f mm\n", hits, 1e3f * median,
              1e3f * p95);
  CHECK(hits > 500);
  CHECK(median < 0.1f * kVoxel);  // 0.2 mm at 2 mm voxels
  CHECK(p95 < 0.5f * kVoxel);     // edges of the box and the sphere's rim
}

// Both numeric builds compute the same profile (Q16.16 resolves 15 um).
TEST(LineScanner, FixedPointAgreesWithFloat) {
  TsdfVolume vol;
  const Scene scene = bin_scene();
  sweep<Fixed>(vol, scene, 0.001f);
  float median, p95;
  int hits;
  round_trip<Fixed>(vol, scene, 0.0035f, median, p95, hits);
  std::printf("\n  line scanner round trip (Q16.16): %d beams, median %.3f mm, p95 %.3f mm\n", hits, 1e3f * median,
              1e3f * p95);
  CHECK(hits > 500);
  CHECK(median < 0.15f * kVoxel);
  CHECK(p95 < 0.5f * kVoxel);
}

// Only the slab around the scan plane is written: one profile touches a single voxel layer.
TEST(LineScanner, UpdatesOnlyThePlaneSlab) {
  TsdfVolume vol;
  vol.init(g_storage.view(false), kDim, Vec3f(-0.064f, -0.064f, -0.03f), TsdfParams::defaults_for(kVoxel, 4 * kVoxel));
  const LineScannerModel m = scanner();
  LineScannerTables<float> tab = tables<float>();
  CHECK(tab.build(m) == Status::kOk);
  const Scene scene = bin_scene();
  const Pose T = scanner_pose(0.0011f);  // voxel centres at y = -0.064 + (j + 0.5) 2 mm: 0.001 is one
  render_profile(scene, m, T, g_ranges);
  ProfilePushStats st;
  CHECK(integrate_profile<float>(vol, m, tab, g_ranges, T, 0.0f, 1.0f, &st) == Status::kOk);
  CHECK(st.voxels_updated > 100);
  int layers = 0;
  for (int y = 0; y < kDim; ++y) {
    bool any = false;
    for (int z = 0; z < kDim && !any; ++z)
      for (int x = 0; x < kDim && !any; ++x) any = vol.weight()[vol.index(x, y, z)] > 0;
    layers += any;
  }
  LONGS_EQUAL(1, layers);
}

TEST(LineScanner, BadArgumentsAreRefused) {
  TsdfVolume vol;
  vol.init(g_storage.view(false), kDim, Vec3f::Zero(), TsdfParams::defaults_for(kVoxel, 4 * kVoxel));
  LineScannerModel m = scanner();
  LineScannerTables<float> tab = tables<float>();
  CHECK(tab.build(m) == Status::kOk);
  CHECK(integrate_profile<float>(vol, m, tab, nullptr, Pose()) == Status::kInvalidArgument);
  CHECK(integrate_profile<float>(vol, m, tab, g_ranges, Pose(), 0.0f, 0.0f) == Status::kInvalidArgument);
  m.beams = 1;
  CHECK(integrate_profile<float>(vol, m, tab, g_ranges, Pose()) == Status::kInvalidArgument);
  m = scanner();
  m.beams = 641;
  LineScannerTables<float> small{g_tan_f, 640};
  CHECK(small.build(m) == Status::kCapacityExceeded);
}

// Steady state: a push and a raycast of a profile allocate nothing, in both builds.
TEST(LineScanner, ZeroAllocationsPerPush) {
  TsdfVolume vol;
  const Scene scene = bin_scene();
  sweep<float>(vol, scene, 0.004f);
  const LineScannerModel m = scanner();
  render_profile(scene, m, scanner_pose(0.0f), g_ranges);
  LineScannerTables<float> tf = tables<float>();
  LineScannerTables<Fixed> tq = tables<Fixed>();
  CHECK(tq.build(m) == Status::kOk);
  alloc_count_start();
  for (int k = 0; k < 3; ++k) {
    integrate_profile<float>(vol, m, tf, g_ranges, scanner_pose(0.001f * float(k)));
    integrate_profile<Fixed>(vol, m, tq, g_ranges, scanner_pose(0.001f * float(k)));
    raycast_profile<float>(vol, m, scanner_pose(0.0f), g_model);
    raycast_profile<Fixed>(vol, m, scanner_pose(0.0f), g_model);
  }
  LONGS_EQUAL(0, alloc_count());
}

namespace {
float g_patch[30 * 640];
Pose g_patch_pose[30];

// Renders 30 profiles at y = -15 .. 14 mm and returns them with their poses moved by T_err.
void make_patch(const Scene& scene, const Pose& T_err) {
  const LineScannerModel m = scanner();
  for (int k = 0; k < 30; ++k) {
    const Pose T = scanner_pose(-0.015f + 0.001f * float(k));
    render_profile(scene, m, T, g_patch + k * 640);
    g_patch_pose[k] = T_err * T;
  }
}
}  // namespace

// A patch of profiles whose poses are off by 1.5 mm and 0.4 degrees is registered back onto the
// space (the robot's pose is not trusted while it moves fast: the data corrects it).
TEST(LineScanner, PatchRegistrationCorrectsThePose) {
  TsdfVolume vol;
  const Scene scene = bin_scene();
  sweep<float>(vol, scene, 0.001f);
  Pose T_err;
  T_err.R = Eigen::AngleAxisf(0.4f * float(M_PI) / 180.0f, Vec3f(0.3f, -0.5f, 0.8f).normalized()).toRotationMatrix();
  T_err.t = Vec3f(0.0008f, -0.001f, 0.0009f);
  make_patch(scene, T_err);
  ProfileRegistrationResult r;
  CHECK(register_profiles<float>(vol, scanner(), g_patch, g_patch_pose, 30, ProfileRegistrationParams(), r) ==
        Status::kOk);
  const Pose residual = r.T_correction * T_err;  // identity when the correction undoes the error
  // RMS displacement of the patch's points before and after the correction.
  const LineScannerModel m = scanner();
  double before = 0, after = 0;
  int n = 0;
  for (int k = 0; k < 30; ++k)
    for (int i = 0; i < 640; i += 4) {
      const float rng = g_patch[k * 640 + i];
      if (rng <= 0.0f) continue;
      const float th = m.beam_angle_rad(i);
      const Vec3f p = scanner_pose(-0.015f + 0.001f * float(k)) * Vec3f(rng * std::sin(th), 0, rng * std::cos(th));
      before += (T_err * p - p).squaredNorm();
      after += (residual * p - p).squaredNorm();
      ++n;
    }
  before = std::sqrt(before / n);
  after = std::sqrt(after / n);
  std::printf("\n  patch registration: %s, %d points, %d dof, rms %.3f mm; points moved %.3f mm rms before, %.3f mm "
              "after (left %.3f deg)\n",
              r.accepted ? "accepted" : "refused", r.points, r.observable, 1e3f * r.rms_m, 1e3 * before, 1e3 * after,
              residual.angle_rad() * 180.0f / float(M_PI));
  CHECK(r.accepted);
  // The space itself is good to ~0.3 mm rms at 2 mm voxels (edges, the sphere's flanks): the patch
  // lands within that, a fifth of where it started.
  CHECK(after < 0.4e-3);
  CHECK(after < before / 4);
}

// A patch that sees only a floor cannot be registered in six directions: refused.
TEST(LineScanner, FlatPatchIsRefused) {
  TsdfVolume vol;
  Scene floor;
  floor.add_plane(Vec3f(0, 0, 1), 0.0f);
  sweep<float>(vol, floor, 0.001f);
  make_patch(floor, Pose());
  ProfileRegistrationResult r;
  CHECK(register_profiles<float>(vol, scanner(), g_patch, g_patch_pose, 30, ProfileRegistrationParams(), r) ==
        Status::kOk);
  CHECK(!r.accepted);
  CHECK(r.observable <= 3);
}

// Translation-only registration (`edgefuse fuse --register-laser`: the robot's orientation is
// trusted, encoder and hand-eye errors are mostly offsets): a patch 1.5 mm off is moved back, in
// the float and the Q16.16 build alike, and the registration allocates nothing.
TEST(LineScanner, TranslationOnlyRegistrationFloatAndFixed) {
  TsdfVolume vol;
  const Scene scene = bin_scene();
  sweep<float>(vol, scene, 0.001f);
  Pose T_err;
  T_err.t = Vec3f(0.0008f, -0.001f, 0.0007f);
  make_patch(scene, T_err);
  ProfileRegistrationParams p;
  p.translation_only = true;
  p.min_eigen_ratio = 3e-3f;  // `fuse --register-laser`'s default
  ProfileRegistrationResult rf, rq;
  alloc_count_start();
  CHECK(register_profiles<float>(vol, scanner(), g_patch, g_patch_pose, 30, p, rf) == Status::kOk);
  CHECK(register_profiles<Fixed>(vol, scanner(), g_patch, g_patch_pose, 30, p, rq) == Status::kOk);
  LONGS_EQUAL(0, alloc_count());
  for (const ProfileRegistrationResult* r : {&rf, &rq}) {
    const Pose residual = r->T_correction * T_err;
    std::printf("\n  translation-only registration: %s, %d points, %d of 3 directions, rms %.3f mm, left %.3f mm",
                r->accepted ? "accepted" : "refused", r->points, r->observable, 1e3f * r->rms_m,
                1e3f * residual.t.norm());
    CHECK(r->accepted);
    LONGS_EQUAL(3, r->observable);
    CHECK(r->T_correction.angle_rad() < 1e-6f);  // no rotation is estimated
    // The space is good to ~0.3 mm rms at 2 mm voxels (edges, the sphere's flanks; the 6-dof test
    // above lands at 0.35 mm rms): the patch lands within 0.45 mm, from 1.5 mm.
    CHECK(residual.t.norm() < 0.45e-3f);
    CHECK(residual.t.norm() < T_err.t.norm() / 3);
  }
  // Float and fixed-point spaces' trilinear samples differ by the Q16.16 rounding only.
  CHECK((rf.T_correction.t - rq.T_correction.t).norm() < 0.05e-3f);
}

// A floor-only patch pins its height only: translation-only registration refuses it too.
TEST(LineScanner, FlatPatchTranslationOnlyIsRefused) {
  TsdfVolume vol;
  Scene floor;
  floor.add_plane(Vec3f(0, 0, 1), 0.0f);
  sweep<float>(vol, floor, 0.001f);
  make_patch(floor, Pose());
  ProfileRegistrationParams p;
  p.translation_only = true;
  for (float ratio : {1e-2f, 3e-3f}) {  // 3e-3: `fuse --register-laser`'s default
    p.min_eigen_ratio = ratio;
    ProfileRegistrationResult r;
    CHECK(register_profiles<float>(vol, scanner(), g_patch, g_patch_pose, 30, p, r) == Status::kOk);
    CHECK(!r.accepted);
    LONGS_EQUAL(1, r.observable);
  }
}

namespace {
// Five sweeps of a sensor 1 mm off (ranges + 1 mm, trust 1: a camera-like average of ~80 weight
// units), then one exact sweep at `trust`; returns the median |model - exact| range at a pose
// between two profiles.
template <class Real>
float biased_then_exact(const Scene& scene, float trust) {
  TsdfVolume vol;
  vol.init(g_storage.view(false), kDim, Vec3f(-0.064f, -0.064f, -0.03f), TsdfParams::defaults_for(kVoxel, 4 * kVoxel));
  const LineScannerModel m = scanner();
  LineScannerTables<Real> tab = tables<Real>();
  CHECK(tab.build(m) == Status::kOk);
  for (int pass = 0; pass <= 5; ++pass)
    for (float y = -0.02f; y <= 0.02f + 1e-6f; y += 0.001f) {
      render_profile(scene, m, scanner_pose(y), g_ranges);
      if (pass < 5)
        for (int i = 0; i < m.beams; ++i) g_ranges[i] = g_ranges[i] > 0.0f ? g_ranges[i] + 0.001f : 0.0f;
      CHECK(integrate_profile<Real>(vol, m, tab, g_ranges, scanner_pose(y), 0.0f, pass < 5 ? 1.0f : trust) ==
            Status::kOk);
    }
  float med, p95;
  int hits;
  round_trip<Real>(vol, scene, 0.0005f, med, p95, hits);
  CHECK(hits > 300);
  return med;
}
}  // namespace

// Trust above 1: a 20 um scanner is ~50x
// finer than sigma_ref, so its samples must outweigh a camera's average where it measured. With
// trust capped at 1 the exact sweep moves the 1 mm-off surface by ~1/6 only; at kProfileTrustMax
// (255 weight units a sample) it lands within 0.25 mm (float and Q16.16); beyond it is refused.
TEST(LineScanner, FineScannerOutweighsACoarseAverage) {
  Scene floor;
  floor.add_plane(Vec3f(0, 0, 1), 0.0f);
  const float capped_f = biased_then_exact<float>(floor, 1.0f);
  const float full_f = biased_then_exact<float>(floor, kProfileTrustMax);
  const float full_q = biased_then_exact<Fixed>(floor, kProfileTrustMax);
  std::printf("\n  1 mm-off average, then one exact sweep: trust 1 leaves %.3f mm, trust %.2f leaves %.3f mm "
              "(Q16.16 %.3f mm)\n", 1e3f * capped_f, kProfileTrustMax, 1e3f * full_f, 1e3f * full_q);
  CHECK(capped_f > 0.6e-3f);
  CHECK(full_f < 0.25e-3f);
  CHECK(full_q < 0.25e-3f);
  TsdfVolume vol;
  sweep<float>(vol, floor, 0.01f);
  LineScannerTables<float> tab = tables<float>();
  CHECK(integrate_profile<float>(vol, scanner(), tab, g_ranges, scanner_pose(0.0f), 0.0f, kProfileTrustMax * 1.01f) ==
        Status::kInvalidArgument);
}
