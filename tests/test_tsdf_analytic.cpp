// Integration + raycasting on analytic scenes drawn by the test (no noise): the raycast depth
// must match the exact depth within 0.1 voxel where the surface is seen within 45 degrees of its
// normal. Between 45 and 60 degrees the projective distance of eq. (1) grows as 1/cos and bends
// around a curved surface, so trilinear interpolation of it is allowed 0.3 voxel there. The
// fixed-point kernels must stay within 0.25 voxel of the float ones.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "edgefuse/tsdf/integrate.hpp"
#include "edgefuse/tsdf/raycast.hpp"
#include "../src/tsdf/raycast_bounds.hpp"  // the bounds test reads them (private to src/)
#include "scenes.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {

constexpr int kDim = 64;
constexpr float kVoxel = 0.01f;
VolumeStorage<kDim> g_storage_a, g_storage_b;
SensorBuffers<float> g_sensor_float;
SensorBuffers<Fixed> g_sensor_fixed;
FrameScratch g_scratch = g_sensor_float.scratch();

template <class Real>
SensorBuffers<Real>& sensor();
template <>
SensorBuffers<float>& sensor<float>() { return g_sensor_float; }
template <>
SensorBuffers<Fixed>& sensor<Fixed>() { return g_sensor_fixed; }

PinholeIntrinsics camera() {
  PinholeIntrinsics c;
  c.width = 320;
  c.height = 240;
  c.fx = c.fy = 300.0f;
  c.cx = 159.5f;
  c.cy = 119.5f;
  c.depth_scale = 10000.0f;  // 0.1 mm steps: quantisation far below the 1 mm tolerance
  c.min_range_m = 0.1f;
  c.max_range_m = 3.0f;
  return c;
}

struct Maps {
  std::vector<float> depth;
  std::vector<Vec3f> vertex, normal;
  std::vector<Rgba8> colour;
  RaycastMaps views(const PinholeIntrinsics& c) {
    const std::size_t n = std::size_t(c.width) * c.height;
    depth.assign(n, 0);
    vertex.assign(n, Vec3f::Zero());
    normal.assign(n, Vec3f::Zero());
    colour.assign(n, Rgba8{});
    return RaycastMaps{{depth.data(), c.width, c.height}, {vertex.data(), c.width, c.height},
                       {normal.data(), c.width, c.height}, {colour.data(), c.width, c.height}};
  }
};

struct Stats {
  int compared = 0, hits = 0;
  float max_err = 0;          // over pixels seen within 45 degrees of the normal
  float max_err_oblique = 0;  // 45..60 degrees
  std::vector<float> errs;
  float percentile(float q) {
    if (errs.empty()) return 0;
    std::sort(errs.begin(), errs.end());
    return errs[std::min(errs.size() - 1, std::size_t(q * float(errs.size())))];
  }
};

template <class Real>
void fuse(TsdfVolume& vol, const Scene& scene, const PinholeIntrinsics& c, const std::vector<Pose>& poses) {
  const ImageView<const Real> norms = sensor<Real>().ray_norms(c);
  FrameScratch scratch = sensor<Real>().scratch();
  for (const Pose& T : poses) {
    std::vector<uint16_t> depth;
    std::vector<Rgb8> colour;
    render(scene, c, T, depth, &colour);
    DepthFrame f{{depth.data(), c.width, c.height}, {colour.data(), c.width, c.height}};
    CHECK(integrate<Real>(vol, c, norms, f, T, scratch) == Status::kOk);
  }
}

// Pixels whose truth is trustworthy for a depth comparison: a non-grazing hit inside the volume
// whose 8 neighbours hit the same primitive (no silhouette edge).
Stats compare_depth(const Scene& scene, const PinholeIntrinsics& c, const Pose& T, const std::vector<float>& depth,
                    const TsdfVolume& vol) {
  std::vector<uint16_t> truth;
  std::vector<float> cosi;
  std::vector<int> item;
  render(scene, c, T, truth, nullptr, &cosi, &item);
  Stats s;
  const float margin = 3 * kVoxel;
  for (int v = 1; v < c.height - 1; ++v)
    for (int u = 1; u < c.width - 1; ++u) {
      const std::size_t i = std::size_t(v) * c.width + u;
      if (truth[i] == 0 || cosi[i] < 0.5f) continue;
      bool edge = false;
      for (int dv = -1; dv <= 1; ++dv)
        for (int du = -1; du <= 1; ++du) edge = edge || item[i + dv * c.width + du] != item[i];
      if (edge) continue;
      const float z = float(truth[i]) / c.depth_scale;
      const Vec3f p = T * c.back_project(float(u), float(v), z);
      const Vec3f lo = vol.origin_m() + Vec3f::Constant(margin);
      const Vec3f hi = vol.origin_m() + Vec3f::Constant(vol.dim() * kVoxel - margin);
      if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) continue;
      ++s.compared;
      if (depth[i] <= 0) continue;
      ++s.hits;
      const float e = std::fabs(depth[i] - z);
      s.errs.push_back(e);
      if (cosi[i] >= std::cos(float(M_PI) / 4))
        s.max_err = std::max(s.max_err, e);
      else
        s.max_err_oblique = std::max(s.max_err_oblique, e);
    }
  return s;
}

Scene sphere_scene() {
  Scene s;
  s.add_sphere(Vec3f(0.0f, 0.0f, 0.8f), 0.12f, {200, 40, 40});
  s.add_plane(Vec3f(0, 0, -1), 1.0f, {40, 40, 200});  // z = 1.0, facing the camera
  return s;
}

std::vector<Pose> views_around(const Vec3f& target, float spread) {
  std::vector<Pose> poses;
  for (int i = 0; i < 5; ++i) {
    const float a = 2.0f * float(M_PI) * float(i) / 5.0f;
    const Vec3f eye(spread * std::cos(a), spread * std::sin(a), 0.0f);
    poses.push_back(look_at(eye, target));
  }
  return poses;
}

Vec3f origin_for(const Vec3f& centre) { return centre - Vec3f::Constant(0.5f * kDim * kVoxel); }

}  // namespace

TEST_GROUP(TsdfAnalytic) {
  TsdfVolume vol;
  PinholeIntrinsics cam = camera();
  void setup() override {
    CHECK(vol.init(g_storage_a.view(), kDim, origin_for(Vec3f(0, 0, 0.8f)), TsdfParams::defaults_for(kVoxel, 4 * kVoxel)) ==
          Status::kOk);
  }
};

TEST(TsdfAnalytic, SphereAndPlaneRaycastMatchesTruthWithinATenthOfAVoxel) {
  const Scene scene = sphere_scene();
  const std::vector<Pose> poses = views_around(Vec3f(0, 0, 0.8f), 0.1f);
  fuse<float>(vol, scene, cam, poses);
  Maps maps;
  for (const Pose& T : {poses[0], poses[3], look_at(Vec3f(0.05f, -0.03f, 0.02f), Vec3f(0.0f, 0.0f, 0.8f))}) {
    const RaycastMaps m = maps.views(cam);
    CHECK(raycast<float>(vol, cam, T, m) == Status::kOk);
    Stats s = compare_depth(scene, cam, T, maps.depth, vol);
    std::printf("\n  sphere+plane: %d compared, %d hit, median %.3f mm, p99 %.3f mm, max %.3f mm (45-60 deg: %.3f mm)",
                s.compared, s.hits, 1e3 * s.percentile(0.5f), 1e3 * s.percentile(0.99f), 1e3 * s.max_err,
                1e3 * s.max_err_oblique);
    CHECK(s.compared > 20000);
    CHECK(s.hits >= s.compared * 99 / 100);
    CHECK(s.max_err < 0.1f * kVoxel);
    CHECK(s.max_err_oblique < 0.3f * kVoxel);
  }
}

TEST(TsdfAnalytic, TiltedPlaneNormalsAndVerticesAgreeWithTheGeometry) {
  Scene scene;
  const Vec3f n = Vec3f(0.3f, -0.2f, -1.0f).normalized();
  scene.add_plane(n, -n.dot(Vec3f(0, 0, 0.85f)));
  const std::vector<Pose> poses = views_around(Vec3f(0, 0, 0.85f), 0.05f);
  fuse<float>(vol, scene, cam, poses);
  Maps maps;
  const RaycastMaps m = maps.views(cam);
  CHECK(raycast<float>(vol, cam, poses[1], m) == Status::kOk);
  Stats s = compare_depth(scene, cam, poses[1], maps.depth, vol);
  CHECK(s.compared > 20000);
  CHECK(s.hits >= s.compared * 99 / 100);
  CHECK(s.max_err < 0.1f * kVoxel);
  // Normals (sensor frame) against the plane's normal, vertices on the plane.
  const Vec3f n_cam = poses[1].R.transpose() * n;
  int checked = 0;
  for (std::size_t i = 0; i < maps.depth.size(); ++i) {
    if (maps.depth[i] <= 0 || maps.normal[i].isZero()) continue;
    const Vec3f p_world = poses[1] * maps.vertex[i];
    if (std::fabs(n.dot(p_world) - n.dot(Vec3f(0, 0, 0.85f))) > 0.1f * kVoxel) FAIL("vertex off the plane");
    if (maps.normal[i].dot(n_cam) < std::cos(1.0f * float(M_PI) / 180.0f)) FAIL("normal more than 1 degree off");
    ++checked;
  }
  CHECK(checked > 20000);
}

TEST(TsdfAnalytic, BoxFacesAreRecoveredWithinATenthOfAVoxel) {
  Scene scene;
  Pose R;
  R.R = Eigen::AngleAxisf(0.4f, Vec3f(0.2f, 1.0f, 0.3f).normalized()).toRotationMatrix();
  scene.add_box(Vec3f(0.0f, 0.0f, 0.8f), Vec3f(0.12f, 0.08f, 0.06f), R);
  scene.add_plane(Vec3f(0, 0, -1), 1.0f);
  const std::vector<Pose> poses = views_around(Vec3f(0, 0, 0.8f), 0.1f);
  fuse<float>(vol, scene, cam, poses);
  Maps maps;
  const RaycastMaps m = maps.views(cam);
  CHECK(raycast<float>(vol, cam, poses[2], m) == Status::kOk);
  Stats s = compare_depth(scene, cam, poses[2], maps.depth, vol);
  std::printf("\n  box: %d compared, %d hit, median %.3f mm, p95 %.3f mm, p99 %.3f mm, max %.3f mm", s.compared, s.hits,
              1e3 * s.percentile(0.5f), 1e3 * s.percentile(0.95f), 1e3 * s.percentile(0.99f),
              1e3 * std::max(s.max_err, s.max_err_oblique));
  CHECK(s.compared > 20000);
  CHECK(s.hits >= s.compared * 98 / 100);
  // Box edges round off over about a voxel: the bulk must be exact, the edges within a voxel.
  CHECK(s.percentile(0.95f) < 0.1f * kVoxel);
  CHECK(s.percentile(0.99f) < 1.0f * kVoxel);
}

TEST(TsdfAnalytic, ColourIsCarriedFromTheImageToTheRaycast) {
  const Scene scene = sphere_scene();
  const std::vector<Pose> poses = views_around(Vec3f(0, 0, 0.8f), 0.1f);
  fuse<float>(vol, scene, cam, poses);
  Maps maps;
  const RaycastMaps m = maps.views(cam);
  CHECK(raycast<float>(vol, cam, poses[0], m) == Status::kOk);
  const std::size_t centre = std::size_t(cam.height / 2) * cam.width + cam.width / 2;
  CHECK(maps.depth[centre] > 0);
  CHECK_EQUAL(255, maps.colour[centre].a);
  CHECK(std::abs(int(maps.colour[centre].r) - 200) <= 2);
  CHECK(std::abs(int(maps.colour[centre].g) - 40) <= 2);
}

TEST(TsdfAnalytic, FrustumCullingSkipsBricksTheSensorCannotSee) {
  const Pose T = look_at(Vec3f(0, 0, 0), Vec3f(0.5f, 0, 0.8f));  // looks past the volume's side
  const std::size_t selected = select_bricks(vol, cam, T);
  CHECK(selected > 0);
  CHECK(selected < vol.brick_count() * 3 / 4);
  const Pose away = look_at(Vec3f(0, 0, 0), Vec3f(0, 0, -1));  // looks away
  CHECK_EQUAL(0u, select_bricks(vol, cam, away));
}

TEST(TsdfAnalytic, EmptySpaceGivesNoHits) {
  Maps maps;
  const RaycastMaps m = maps.views(cam);
  CHECK(raycast<float>(vol, cam, Pose::identity(), m) == Status::kOk);
  for (float d : maps.depth) CHECK_EQUAL(0.0f, d);
}

TEST(TsdfAnalytic, MismatchedInputsAreRefused) {
  const ImageView<const float> norms = g_sensor_float.ray_norms(cam);
  std::vector<uint16_t> depth(100);
  DepthFrame f{{depth.data(), 10, 10}, {}};
  CHECK(integrate<float>(vol, cam, norms, f, Pose{}, g_scratch) == Status::kInvalidArgument);
  std::vector<uint16_t> full(std::size_t(cam.width) * cam.height);
  DepthFrame g{{full.data(), cam.width, cam.height}, {}};
  CHECK(integrate<float>(vol, cam, norms, g, Pose{}, g_scratch, 0.0f) == Status::kInvalidArgument);  // trust > 0
  FrameScratch small = g_scratch;
  small.capacity = 10;
  CHECK(integrate<float>(vol, cam, norms, g, Pose{}, small) == Status::kCapacityExceeded);
  Maps maps;
  RaycastMaps m = maps.views(cam);
  m.depth_m.width = 10;
  CHECK(raycast<float>(vol, cam, Pose{}, m) == Status::kInvalidArgument);
  TsdfVolume other;
  CHECK(other.init(g_storage_b.view(), kDim + 8, Vec3f::Zero(), TsdfParams::defaults_for(kVoxel, 4 * kVoxel)) ==
        Status::kCapacityExceeded);
  CHECK(other.init(g_storage_b.view(), 60, Vec3f::Zero(), TsdfParams::defaults_for(kVoxel, 4 * kVoxel)) ==
        Status::kInvalidArgument);
}

TEST(TsdfAnalytic, FixedPointRaycastIsWithinAQuarterVoxelOfFloat) {
  const Scene scene = sphere_scene();
  const std::vector<Pose> poses = views_around(Vec3f(0, 0, 0.8f), 0.1f);
  TsdfVolume fixed_vol;
  CHECK(fixed_vol.init(g_storage_b.view(), kDim, origin_for(Vec3f(0, 0, 0.8f)), TsdfParams::defaults_for(kVoxel, 4 * kVoxel)) ==
        Status::kOk);
  fuse<float>(vol, scene, cam, poses);
  fuse<Fixed>(fixed_vol, scene, cam, poses);
  Maps a, b;
  const RaycastMaps ma = a.views(cam), mb = b.views(cam);
  CHECK(raycast<float>(vol, cam, poses[4], ma) == Status::kOk);
  CHECK(raycast<Fixed>(fixed_vol, cam, poses[4], mb) == Status::kOk);
  // Silhouette and grazing pixels (the truth changes primitive nearby, or the surface is seen at
  // more than 60 degrees) may hit either surface depending on the last bit: left out.
  std::vector<uint16_t> truth;
  std::vector<float> cosi;
  std::vector<int> item;
  render(scene, cam, poses[4], truth, nullptr, &cosi, &item);
  int both = 0, only_one = 0;
  float max_diff = 0;
  for (int v = 1; v < cam.height - 1; ++v)
    for (int u = 1; u < cam.width - 1; ++u) {
    const std::size_t i = std::size_t(v) * cam.width + u;
    bool edge = false;
    for (int dv = -1; dv <= 1; ++dv)
      for (int du = -1; du <= 1; ++du) edge = edge || item[i + dv * cam.width + du] != item[i];
    if (edge || cosi[i] < 0.5f) continue;
    if ((a.depth[i] > 0) != (b.depth[i] > 0)) ++only_one;
    if (a.depth[i] <= 0 || b.depth[i] <= 0) continue;
    ++both;
    max_diff = std::max(max_diff, std::fabs(a.depth[i] - b.depth[i]));
  }
  std::printf("\n  fixed vs float: %d pixels, max diff %.3f mm, %d hit in one only", both, 1e3 * max_diff, only_one);
  CHECK(both > 30000);
  CHECK(only_one < both / 200);  // pixels at the volume's border may flip
  CHECK(max_diff < 0.25f * kVoxel);
  // The stored voxels agree too. Voxels whose projection lands exactly on a decision boundary
  // (range limit, depth-jump test, pixel border) may be updated in one build and not the other;
  // they must be rare, and the rest must agree to within 1 % of the truncation.
  long differing_weights = 0, differing_values = 0;
  for_each_voxel_pair(vol, fixed_vol, [&](std::size_t i, std::size_t j) {
    differing_weights += vol.weight()[i] != fixed_vol.weight()[j];
    if (vol.weight()[i] && fixed_vol.weight()[j] && std::abs(vol.tsdf()[i] - fixed_vol.tsdf()[j]) > kTsdfMax / 100)
      ++differing_values;
  });
  const long observed = long(vol.observed_voxels());
  std::printf(", of %ld voxels: %ld with another weight, %ld differ by > 1%% of trunc", observed, differing_weights,
              differing_values);
  CHECK(differing_weights < observed / 20);
  CHECK(differing_values < observed / 100);
}

// Block masks: integration keeps a mask per surface brick of the 2^3-voxel blocks
// holding an observed distance at or below 0, and the raycast bounds
// each pixel's search by the marked blocks only. The mask must be exact, and the raycast must find the same surface with it
// as with whole-brick bounds (a volume without mask storage).
TEST(TsdfAnalytic, BlockMasksMarkTheBlocksAtOrBehindTheSurfaceAndLeaveTheRaycastUnchanged) {
  const Scene scene = sphere_scene();
  const std::vector<Pose> poses = views_around(Vec3f(0, 0, 0.8f), 0.1f);
  fuse<float>(vol, scene, cam, poses);
  TsdfVolume plain;
  VoxelStorage no_mask = g_storage_b.view();
  no_mask.block_mask = nullptr;
  CHECK(plain.init(no_mask, kDim, vol.origin_m(), vol.params()) == Status::kOk);
  fuse<float>(plain, scene, cam, poses);

  int surface_bricks = 0, marked_blocks = 0;
  for (std::size_t b = 0; b < vol.brick_count(); ++b) {
    if (!(vol.brick_flags()[b] & kBrickSurface)) continue;
    ++surface_bricks;
    uint64_t expect = 0;
    const int16_t* t = vol.tsdf() + vol.brick_base(b);
    for (int i = 0; i < kBrickVoxels; ++i) {
      const int x = i & 7, y = (i >> 3) & 7, z = i >> 6;
      if (t[i] != kTsdfUnobserved && t[i] <= 0) expect |= uint64_t(1) << (((z >> 1) << 4) | ((y >> 1) << 2) | (x >> 1));
    }
    CHECK(vol.block_mask()[b] == expect);
    for (int k = 0; k < 64; ++k) marked_blocks += int((expect >> k) & 1u);
  }
  std::printf("\n  block masks: %d surface bricks, %.1f of 64 blocks marked on average", surface_bricks,
              double(marked_blocks) / std::max(surface_bricks, 1));
  CHECK(surface_bricks > 50);
  CHECK(marked_blocks < surface_bricks * 64);  // some blocks stay clear

  // Where the truth is trustworthy (no silhouette, not grazing) both must meet the analytic
  // tolerance and agree closely. At silhouettes a grazing ray may meet the sphere or pass on to the
  // plane depending on where its march starts, with or without masks alike; those pixels are left out.
  Maps with, without;
  for (const Pose& T : {poses[1], look_at(Vec3f(0.05f, -0.03f, 0.02f), Vec3f(0.0f, 0.0f, 0.8f))}) {
    CHECK(raycast<float>(vol, cam, T, with.views(cam)) == Status::kOk);
    CHECK(raycast<float>(plain, cam, T, without.views(cam)) == Status::kOk);
    Stats a = compare_depth(scene, cam, T, with.depth, vol);
    Stats b = compare_depth(scene, cam, T, without.depth, plain);
    std::printf("\n  with / without block masks: %d / %d of %d hit, max error %.3f / %.3f mm", a.hits, b.hits, a.compared,
                1e3 * a.max_err, 1e3 * b.max_err);
    CHECK(a.compared > 20000);
    CHECK(a.hits >= b.hits - b.hits / 1000);
    CHECK(a.max_err < 0.1f * kVoxel);
    CHECK(a.max_err_oblique < 0.3f * kVoxel);
  }
}

// Raycast bounds (src/tsdf/raycast_bounds.hpp): prepare_raycast leaves in each pixel of
// the depth map the z range its ray is marched over, from the marked 2^3 blocks' front and back
// faces. Every trustworthy surface pixel must be covered, its true depth inside the range (the
// zero crossing of the trilinear field lies within 0.1 voxel of the truth, as the raycast tests
// above show), and the range must start within a few voxels of the surface: the marked band in
// front of it (4 voxels at trunc = 4 voxels), a block's reach (2.6) and the lateral reach.
TEST(TsdfAnalytic, PerPixelBoundsHoldEveryTrueSurfaceAndStartNearIt) {
  const Scene scene = sphere_scene();
  const std::vector<Pose> poses = views_around(Vec3f(0, 0, 0.8f), 0.1f);
  fuse<float>(vol, scene, cam, poses);
  const raycast_bounds::Quant q(cam.max_range_m);
  for (const Pose& T : {poses[1], look_at(Vec3f(0.05f, -0.03f, 0.02f), Vec3f(0.0f, 0.0f, 0.8f))}) {
    Maps m;
    const RaycastMaps views = m.views(cam);
    CHECK(prepare_raycast(vol, cam, T, views) == Status::kOk);
    std::vector<uint16_t> truth;
    std::vector<float> cosi;
    std::vector<int> item;
    render(scene, cam, T, truth, nullptr, &cosi, &item);
    int compared = 0, covered = 0, inside = 0, marched = 0;
    double lead_voxels = 0;
    for (int v = 1; v < cam.height - 1; ++v)
      for (int u = 1; u < cam.width - 1; ++u) {
        float near_m = 0, far_m = 0;
        const bool has = raycast_bounds::read(views.depth_m.at(u, v), q, near_m, far_m);
        marched += has;
        const std::size_t i = std::size_t(v) * cam.width + u;
        if (truth[i] == 0 || cosi[i] < 0.5f) continue;
        bool edge = false;
        for (int dv = -1; dv <= 1; ++dv)
          for (int du = -1; du <= 1; ++du) edge = edge || item[i + dv * cam.width + du] != item[i];
        if (edge) continue;
        const float z = float(truth[i]) / cam.depth_scale;
        const Vec3f p = T * cam.back_project(float(u), float(v), z);
        const Vec3f lo = vol.origin_m() + Vec3f::Constant(3 * kVoxel);
        const Vec3f hi = vol.origin_m() + Vec3f::Constant(vol.dim() * kVoxel - 3 * kVoxel);
        if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) continue;
        ++compared;
        if (!has) continue;
        ++covered;
        if (near_m <= z + 0.1f * kVoxel && z - 0.1f * kVoxel <= far_m) ++inside;
        lead_voxels += (z - near_m) / kVoxel;
      }
    std::printf("\n  bounds: %d trustworthy surface pixels, %d covered, %d inside their range, start %.1f voxels "
                "before the surface on average; %d of %d pixels marched",
                compared, covered, inside, lead_voxels / std::max(covered, 1), marched, cam.width * cam.height);
    CHECK(compared > 20000);
    CHECK(covered == compared);
    CHECK(inside == compared);
    CHECK(lead_voxels / std::max(covered, 1) < 13.0);  // 11.4 and 11.5 when written
  }
}

// Splat widening: raycast_bounds::dilate() filters only between each row's first and last covered
// pixels (found 8 bytes at a time from both ends) and the column pass only over their box. It
// must still equal the plain 5x5 min filter of both halves (beyond the image: nothing), on
// images of odd and even sizes (down to 1x1) and from empty to full.
TEST(TsdfAnalytic, BoundsDilationEqualsThePlainSquareMinFilter) {
  std::mt19937 rng(6);
  const int sizes[][2] = {{1, 1}, {2, 1}, {1, 3}, {3, 2}, {5, 4}, {8, 8}, {17, 9}, {64, 3}, {320, 240}};
  const double fill[] = {0.0, 0.0005, 0.01, 0.2, 1.0};
  int cases = 0;
  for (const auto& wh : sizes)
    for (double p : fill)
      for (int rep = 0; rep < 3; ++rep) {
        const int w = wh[0], h = wh[1];
        std::vector<float> img(std::size_t(w) * h);
        std::memset(img.data(), 0x7F, img.size() * sizeof(float));  // raycast_bounds::clear()
        std::vector<int16_t> in(2 * img.size(), raycast_bounds::kEmpty);
        std::uniform_real_distribution<double> coin(0.0, 1.0);
        std::uniform_int_distribution<int> half(-32768, raycast_bounds::kEmpty - 1);
        for (std::size_t k = 0; k < img.size(); ++k) {
          // Lone pixels at the ends of rows matter most: put some there whatever the fill.
          const int u = int(k % std::size_t(w));
          if (coin(rng) < p || (rep == 2 && (u == 0 || u == w - 1) && coin(rng) < 0.3)) {
            in[2 * k] = int16_t(half(rng));
            in[2 * k + 1] = coin(rng) < 0.2 ? raycast_bounds::kEmpty : int16_t(half(rng));
          }
        }
        std::memcpy(img.data(), in.data(), img.size() * sizeof(float));
        raycast_bounds::dilate(ImageView<float>{img.data(), w, h});
        std::vector<int16_t> out(in.size());
        std::memcpy(out.data(), img.data(), img.size() * sizeof(float));
        int wrong = 0;
        for (int v = 0; v < h; ++v)
          for (int u = 0; u < w; ++u)
            for (int c = 0; c < 2; ++c) {
              int16_t m = raycast_bounds::kEmpty;
              for (int dv = -raycast_bounds::kDilate; dv <= raycast_bounds::kDilate; ++dv)
                for (int du = -raycast_bounds::kDilate; du <= raycast_bounds::kDilate; ++du) {
                  const int uu = u + du, vv = v + dv;
                  if (uu >= 0 && uu < w && vv >= 0 && vv < h) m = std::min(m, in[2 * (std::size_t(vv) * w + uu) + c]);
                }
              wrong += out[2 * (std::size_t(v) * w + u) + c] != m;
            }
        LONGS_EQUAL(0, wrong);
        ++cases;
      }
  CHECK(cases == 9 * 5 * 3);
}

// merge_rect() writes four pixels per vector: without alignment the last four of a row again
// (overlapping) and rects narrower than four pixel by pixel; aligned (rows on 16 bytes, widths of
// whole groups of four) the groups holding the rect with kEmpty lanes outside it. Every pixel in
// the rect must get the minimum, every pixel outside it keep its value, also at the borders.
TEST(TsdfAnalytic, BoundsRectMergeTouchesExactlyItsRect) {
  std::mt19937 rng(66);
  std::uniform_int_distribution<int> half(-32768, raycast_bounds::kEmpty);
  int wrong = 0, aligned_runs = 0;
  for (const int w : {13, 16}) {
    const int h = 5;
    alignas(16) float img[16 * 5];
    const ImageView<float> view{img, w, h};
    for (int trial = 0; trial < 2000; ++trial) {
      std::vector<int16_t> before(2 * w * h);
      for (int16_t& x : before) x = int16_t(half(rng));
      std::memcpy(img, before.data(), before.size() * sizeof(int16_t));
      const int u0 = std::uniform_int_distribution<int>(0, w - 1)(rng);
      const int u1 = std::uniform_int_distribution<int>(u0, w - 1)(rng);
      const int v0 = std::uniform_int_distribution<int>(0, h - 1)(rng);
      const int v1 = std::uniform_int_distribution<int>(v0, h - 1)(rng);
      const int16_t nh = int16_t(half(rng)), fh = trial % 5 == 0 ? raycast_bounds::kEmpty : int16_t(half(rng));
      const bool aligned = raycast_bounds::four_pixel_aligned(view);
      aligned_runs += aligned;
      raycast_bounds::merge_rect(view, u0, u1, v0, v1, nh, fh, aligned);
      std::vector<int16_t> after(before.size());
      std::memcpy(after.data(), img, after.size() * sizeof(int16_t));
      for (int v = 0; v < h; ++v)
        for (int u = 0; u < w; ++u) {
          const std::size_t k = 2 * (std::size_t(v) * w + u);
          const bool in = u >= u0 && u <= u1 && v >= v0 && v <= v1;
          wrong += after[k] != (in ? std::min(before[k], nh) : before[k]);
          wrong += after[k + 1] != (in ? std::min(before[k + 1], fh) : before[k + 1]);
        }
    }
  }
  LONGS_EQUAL(0, wrong);
  LONGS_EQUAL(2000, aligned_runs);  // the 16-pixel rows, not the 13-pixel ones
}

// Cube bounds: a block's bound is the sensor-axis box of its crossing cube (half-size
// 1.5 voxels along world axes around the block centre), written by centres() (4 blocks per
// vector, bricks of small footprints, shrunk by kDilate and widened by dilate()) or
// footprints(). Conservative means: a pixel whose ray passes through a front (back) block's cube
// at z-depth z is covered with near <= z (far >= z). Checked on random poses, cameras, bricks and
// block sets; and the dilated splat holds the exact one (dilate = false, whole footprints).
TEST(TsdfAnalytic, CubeBoundsHoldEveryRayThroughACrossingCube) {
  std::mt19937 rng(707);
  std::uniform_real_distribution<float> uni(-1.0f, 1.0f);
  long checked = 0, uncovered = 0, near_after = 0, far_before = 0, wider_missing = 0;
  long centre_path = 0;
  for (int trial = 0; trial < 300; ++trial) {
    PinholeIntrinsics intr;
    const bool vga = trial % 3 == 0;
    intr.width = vga ? 640 : 320;
    intr.height = vga ? 480 : 240;
    intr.fx = (vga ? 525.0f : 285.0f) * (1.0f + 0.1f * uni(rng));
    intr.fy = intr.fx * (1.0f + 0.02f * uni(rng));
    intr.cx = 0.5f * intr.width + 5.0f * uni(rng);
    intr.cy = 0.5f * intr.height + 5.0f * uni(rng);
    intr.min_range_m = 0.1f;
    intr.max_range_m = 4.0f;
    const float vs = trial % 2 == 0 ? 0.002f : 0.01f;
    Pose T_cam_world = Pose::from_tq(uni(rng), uni(rng), uni(rng), uni(rng), uni(rng), uni(rng), uni(rng) + 0.1f);
    // A brick somewhere in view (its block 0 centre), near or far.
    const float z = (trial % 5 == 0 ? 0.05f : 0.3f) + 1.5f * (0.5f + 0.5f * uni(rng));
    const Vec3f c0(z * 0.5f * uni(rng), z * 0.4f * uni(rng), z);
    raycast_bounds::Sides sides;
    const uint64_t bits = (uint64_t(rng()) << 32) | rng();
    sides.front = bits & ((uint64_t(rng()) << 32) | rng());
    sides.back = bits & ((uint64_t(rng()) << 32) | rng());
    const std::size_t n = std::size_t(intr.width) * intr.height;
    std::vector<float> buf_a(n + 16), buf_b(n + 16);
    const auto aligned16 = [](std::vector<float>& b) {
      return reinterpret_cast<float*>((reinterpret_cast<uintptr_t>(b.data()) + 15) & ~uintptr_t(15));
    };
    const ImageView<float> dil{aligned16(buf_a) + (trial % 4 == 1 ? 1 : 0), intr.width, intr.height};
    const ImageView<float> exact{aligned16(buf_b), intr.width, intr.height};
    raycast_bounds::clear(dil);
    raycast_bounds::clear(exact);
    {
      const raycast_bounds::Splatter s(dil, intr, T_cam_world, vs, true);
      s.brick(sides, c0);
      raycast_bounds::dilate(dil);
    }
    {
      const raycast_bounds::Splatter s(exact, intr, T_cam_world, vs, false);
      s.brick(sides, c0);
    }
    const raycast_bounds::Quant q(intr.max_range_m);
    // The dilated splat holds the exact one.
    for (int v = 0; v < intr.height; ++v)
      for (int u = 0; u < intr.width; ++u) {
        int16_t a[2], b[2];
        std::memcpy(a, &dil.at(u, v), sizeof a);
        std::memcpy(b, &exact.at(u, v), sizeof b);
        wider_missing += a[0] > b[0] || a[1] > b[1];
      }
    // Rays through pixel centres near random points of each block's cube.
    const Mat3f& R = T_cam_world.R;
    const float h = raycast_bounds::kCubeHalfVoxels * vs;
    for (int bit = 0; bit < 64; ++bit) {
      const bool front = (sides.front >> bit) & 1u, back = (sides.back >> bit) & 1u;
      if (!front && !back) continue;
      const Vec3f c = c0 + R.col(0) * (2.0f * vs * float(bit & 3)) + R.col(1) * (2.0f * vs * float((bit >> 2) & 3)) +
                      R.col(2) * (2.0f * vs * float(bit >> 4));
      for (int k = 0; k < 200; ++k) {
        const Vec3f p = c + R * Vec3f(h * uni(rng), h * uni(rng), h * uni(rng));
        if (!(p.z() > 1e-3f)) continue;
        const int u = int(std::lround(intr.fx * p.x() / p.z() + intr.cx));
        const int v = int(std::lround(intr.fy * p.y() / p.z() + intr.cy));
        if (u < 0 || v < 0 || u >= intr.width || v >= intr.height) continue;
        const Vec3f ray((float(u) - intr.cx) / intr.fx, (float(v) - intr.cy) / intr.fy, 1.0f);
        const Vec3f on_ray = ray * p.z();  // the pixel's ray at p's depth
        const Vec3f d = R.transpose() * (on_ray - c);
        if (std::fabs(d.x()) > h || std::fabs(d.y()) > h || std::fabs(d.z()) > h) continue;
        ++checked;
        // The halves as read() decodes them (a pixel without a near half is not marched: only
        // front blocks must cover it; a back block must give it a far half).
        int16_t half[2];
        std::memcpy(half, &dil.at(u, v), sizeof half);
        const float near_m = float(int32_t(half[0]) + 32768) * q.unit_m;
        const float far_m = float(32767 - int32_t(half[1])) * q.unit_m;
        uncovered += (front && half[0] == raycast_bounds::kEmpty) || (back && half[1] == raycast_bounds::kEmpty);
        near_after += front && half[0] != raycast_bounds::kEmpty && near_m > p.z();
        far_before += back && half[1] != raycast_bounds::kEmpty && far_m < p.z();
      }
    }
    centre_path += z > 0.3f;
  }
  std::printf("\n  cube bounds: %ld rays through crossing cubes checked over 300 bricks", checked);
  LONGS_EQUAL(0, wider_missing);
  LONGS_EQUAL(0, uncovered);
  LONGS_EQUAL(0, near_after);
  LONGS_EQUAL(0, far_before);
  CHECK(checked > 100000);
  CHECK(centre_path > 0);
}

namespace {

// Depth the raycast sees at the image centre from T.
float centre_depth(const TsdfVolume& vol, const PinholeIntrinsics& c, const Pose& T) {
  Maps maps;
  const RaycastMaps m = maps.views(c);
  CHECK(raycast<float>(vol, c, T, m) == Status::kOk);
  return maps.depth[std::size_t(c.height / 2) * c.width + c.width / 2];
}

// Frames of `scene` fused from T until the centre depth is within 2 voxels of `want` (at most max_frames).
int frames_until_seen(TsdfVolume& vol, const Scene& scene, const PinholeIntrinsics& c, const Pose& T, float want,
                      int max_frames) {
  for (int n = 1; n <= max_frames; ++n) {
    fuse<float>(vol, scene, c, {T});
    if (std::fabs(centre_depth(vol, c, T) - want) < 2 * kVoxel) return n;
  }
  return max_frames + 1;
}

Scene plane_scene() {
  Scene s;
  s.add_plane(Vec3f(0, 0, -1), 1.0f, {40, 40, 200});  // z = 1.0
  return s;
}

}  // namespace

// An object placed in front of a known surface appears at once: its measurements list the bricks
// around them, which held nothing (free space beyond the band's free margin, 8 cm here, is not
// integrated), so its first samples set them (measured: seen after 1 frame).
TEST(TsdfAnalytic, AnObjectPlacedInFrontOfAKnownSurfaceAppears) {
  const Pose T = Pose::identity();
  for (int i = 0; i < 8; ++i) fuse<float>(vol, plane_scene(), cam, {T});
  Scene with_ball = plane_scene();
  with_ball.add_sphere(Vec3f(0.0f, 0.0f, 0.56f), 0.04f, {200, 40, 40});  // front at z = 0.52
  const int frames = frames_until_seen(vol, with_ball, cam, T, 0.52f, 30);
  std::printf("\n  ball in front of the plane seen after %d frames", frames);
  CHECK(frames <= 2);
}

namespace {

// Integrates one rendered frame of `scene` from T into `v` with the bricks of every frustum
// (select_bricks) instead of the band's.
void fuse_whole_frustum(TsdfVolume& v, const Scene& scene, const PinholeIntrinsics& c, const Pose& T) {
  std::vector<uint16_t> depth;
  std::vector<Rgb8> colour;
  render(scene, c, T, depth, &colour);
  const DepthFrame f{{depth.data(), c.width, c.height}, {colour.data(), c.width, c.height}};
  FrameScratch scratch = g_sensor_float.scratch();
  IntegrationJob<float> job;
  CHECK(prepare_integration<float>(v, c, g_sensor_float.ray_norms(c), f, T, 1.0f, scratch, job) == Status::kOk);
  const std::size_t n = select_bricks(v, c, T);
  for (std::size_t i = 0; i < n; ++i) CHECK(v.store_brick(v.brick_list()[i]));  // select_bricks gives no slots
  integrate_bricks<float>(v, job, 0, n);
  finish_integration(v, n);
}

}  // namespace

// The band selection lists every brick the frame writes a distance below +1 into (the truncation
// band and the occluded side down to -rho): one frame from a fresh volume, integrated with the band's
// bricks and with every brick of the frustum, gives the same voxels wherever the latter stored
// less than +1, and the band's voxels are a subset of the frustum's, identical where both wrote
// (measured: 58 % of the frustum's, the rest free space beyond the free margin).
// Oblique views, silhouettes and the sphere's curvature test the conservative bounds.
TEST(TsdfAnalytic, TheBandSelectionListsEveryBrickTheFrameWritesASurfaceInto) {
  TsdfVolume whole;
  const TsdfParams params = TsdfParams::defaults_for(kVoxel, 4 * kVoxel);
  Scene scene = sphere_scene();
  scene.add_box(Vec3f(0.12f, -0.08f, 0.85f), Vec3f(0.04f, 0.03f, 0.05f), look_at(Vec3f(0, 0, 0), Vec3f(1, 1, 3)));
  const std::vector<Pose> views = {Pose::identity(), look_at(Vec3f(0.25f, -0.1f, 0.1f), Vec3f(0.0f, 0.0f, 0.8f)),
                                   look_at(Vec3f(-0.2f, 0.2f, 0.3f), Vec3f(0.05f, 0.0f, 0.85f))};
  long band_voxels = 0, band_written = 0, whole_written = 0;
  for (const Pose& T : views) {
    CHECK(vol.init(g_storage_a.view(), kDim, origin_for(Vec3f(0, 0, 0.8f)), params) == Status::kOk);
    CHECK(whole.init(g_storage_b.view(), kDim, origin_for(Vec3f(0, 0, 0.8f)), params) == Status::kOk);
    fuse<float>(vol, scene, cam, {T});
    fuse_whole_frustum(whole, scene, cam, T);
    long missed = 0, differ = 0;
    for_each_voxel_pair(vol, whole, [&](std::size_t i, std::size_t j) {
      const bool in_band = whole.weight()[j] > 0 && whole.tsdf()[j] < kTsdfMax;
      band_voxels += in_band;
      whole_written += whole.weight()[j] > 0;
      band_written += vol.weight()[i] > 0;
      missed += in_band && (vol.weight()[i] != whole.weight()[j] || vol.tsdf()[i] != whole.tsdf()[j]);
      differ += vol.weight()[i] > 0 && (vol.weight()[i] != whole.weight()[j] || vol.tsdf()[i] != whole.tsdf()[j]);
    });
    LONGS_EQUAL(0, missed);
    LONGS_EQUAL(0, differ);
    for (std::size_t b = 0; b < vol.brick_count(); ++b) LONGS_EQUAL(0, vol.brick_flags()[b] & kBrickListed);
  }
  std::printf("\n  band selection: %ld band voxels, %ld voxels written (whole frustum: %ld)", band_voxels,
              band_written, whole_written);
  CHECK(band_voxels > 50000);
  CHECK(band_written < whole_written * 2 / 3);  // free space beyond the margin is left alone
}

// A removed object leaves the map: its bricks hold surface, so they are carved every frame
// (measured: the plane is seen again after 3 frames).
TEST(TsdfAnalytic, ARemovedObjectIsCarvedAway) {
  const Pose T = Pose::identity();
  Scene with_ball = plane_scene();
  with_ball.add_sphere(Vec3f(0.0f, 0.0f, 0.8f), 0.06f, {200, 40, 40});
  for (int i = 0; i < 8; ++i) fuse<float>(vol, with_ball, cam, {T});
  CHECK(std::fabs(centre_depth(vol, cam, T) - 0.74f) < 2 * kVoxel);
  const int frames = frames_until_seen(vol, plane_scene(), cam, T, 1.0f, 30);
  std::printf("\n  removed ball carved away after %d frames", frames);
  CHECK(frames <= 4);
}

// The voxel pool: bricks get a slot when integration first writes into them, so a scene uses a
// share of the cube. A pool too small for the scene fills up, counts the bricks it refused
// and keeps what it holds: every brick it stored is the same as with room for all (a brick's
// update reads only itself and the frame), the empty brick stays empty, and the raycast reads the
// stored surface. clear() hands every slot back.
TEST(TsdfAnalytic, TheVoxelPoolStoresOnlyBricksItWritesAndAFullPoolRefusesTheRestCounted) {
  const Scene scene = sphere_scene();
  const std::vector<Pose> poses = views_around(Vec3f(0, 0, 0.8f), 0.1f);
  fuse<float>(vol, scene, cam, poses);
  const uint32_t used = vol.bricks_in_use();
  std::printf("\n  voxel pool: %u of %zu bricks stored", used, vol.brick_count());
  CHECK(used > 100 && used < vol.brick_count() * 3 / 4);  // 64^3 voxels of 1 cm: the margins are a large share
  CHECK_EQUAL(0u, vol.bricks_refused());

  VoxelStorage small = g_storage_b.view();
  small.pool_bricks = used / 3 + 1;
  TsdfVolume tight;
  CHECK(tight.init(small, kDim, vol.origin_m(), vol.params()) == Status::kOk);
  fuse<float>(tight, scene, cam, poses);
  CHECK_EQUAL(small.pool_bricks - 1u, tight.bricks_in_use());
  CHECK(tight.bricks_refused() > 0);
  int surface = 0;
  for (std::size_t b = 0; b < tight.brick_count(); ++b) {
    if (!tight.brick_stored(b)) {
      LONGS_EQUAL(0, tight.brick_flags()[b] & (kBrickObserved | kBrickSurface));
      continue;
    }
    surface += (tight.brick_flags()[b] & kBrickSurface) != 0;
    const std::size_t i = tight.brick_base(b), j = vol.brick_base(b);
    CHECK(std::memcmp(tight.tsdf() + i, vol.tsdf() + j, kBrickVoxels * sizeof(int16_t)) == 0);
    CHECK(std::memcmp(tight.weight() + i, vol.weight() + j, kBrickVoxels) == 0);
  }
  for (int i = 0; i < kBrickVoxels; ++i) CHECK(tight.weight()[i] == 0 && tight.tsdf()[i] == kTsdfUnobserved);
  std::printf(", a pool of %u: %llu stores refused, %d surface bricks kept", small.pool_bricks,
              static_cast<unsigned long long>(tight.bricks_refused()), surface);
  CHECK(surface > 0);

  // Where the pool refused the sphere's front, the ray may meet the plane behind it: every hit
  // must lie on one of the scene's two surfaces.
  Maps tight_maps;
  CHECK(raycast<float>(tight, cam, poses[0], tight_maps.views(cam)) == Status::kOk);
  std::vector<float> off_surface;
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      const float z = tight_maps.depth[std::size_t(v) * cam.width + u];
      if (!(z > 0.0f)) continue;
      const Vec3f p = poses[0] * Vec3f((float(u) - cam.cx) / cam.fx * z, (float(v) - cam.cy) / cam.fy * z, z);
      off_surface.push_back(std::min(std::fabs((p - Vec3f(0.0f, 0.0f, 0.8f)).norm() - 0.12f), std::fabs(p.z() - 1.0f)));
    }
  std::sort(off_surface.begin(), off_surface.end());
  CHECK(off_surface.size() > 1000);
  const float median = off_surface[off_surface.size() / 2], p99 = off_surface[off_surface.size() * 99 / 100];
  std::printf(", raycast: %zu hits, off the surfaces median %.3f mm, p99 %.3f mm", off_surface.size(), 1e3 * median,
              1e3 * p99);
  CHECK(median < 0.1f * kVoxel);
  CHECK(p99 < 0.5f * kVoxel);
  tight.clear();
  CHECK_EQUAL(0u, tight.bricks_in_use());
  CHECK_EQUAL(0u, tight.bricks_refused());
}
