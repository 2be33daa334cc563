// Localisation on rendered, fused scenes with known poses: a box (symmetric: any of its four
// equivalent poses is right) and a cylinder-free L-shaped part on a floor, an empty bin (no poses),
// a corrupt model (clear error at start-up), model-free segments, and zero heap allocations while
// localising.
#include <array>
#include <atomic>
#include <cmath>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"
#include "edgefuse/localize/localizer.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "edgefuse/tsdf/integrate.hpp"
#include "scenes.hpp"
#include "test_support.hpp"
#include "localize_fixture.hpp"
#include "../src/localize/scene_grid.hpp"  // the nearest-neighbour search is read directly (private to src/)

using namespace edgefuse;
using namespace edgefuse_test;

namespace {

const Vec3f kHalf(0.03f, 0.02f, 0.0125f);

}  // namespace

TEST_GROUP(Localize){};

TEST(Localize, FindsARenderedSymmetricBoxOnTheFloor) {
  Localizer loc;
  CHECK(loc.init(buffers()) == Status::kOk);
  std::vector<Vec3f> v;
  std::vector<std::array<uint32_t, 3>> t;
  box_mesh(kHalf, v, t);
  LocalizeParams params;
  int index = -1;
  CHECK(loc.add_model("box", v.data(), v.size(), reinterpret_cast<const uint32_t(*)[3]>(t.data()), t.size(), params,
                      index) == Status::kOk);
  LONGS_EQUAL(0, index);
  Pose truth;
  truth.R = Eigen::AngleAxisf(0.5f, Vec3f::UnitZ()).toRotationMatrix();
  truth.t = Vec3f(0.03f, -0.02f, kHalf.z());
  Scene scene;
  scene.add_plane(Vec3f(0, 0, 1), 0.0f);
  scene.add_box(truth.t, kHalf, truth);
  TsdfVolume vol;
  SceneContext ctx;
  const std::size_t n = fuse(scene, vol, ctx.viewpoint_m);
  CHECK(n > 5000);
  CHECK(loc.set_scene(g_points, n, ctx, &vol, 0.0075f) == Status::kOk);
  CHECK(loc.remove_bin(params) == Status::kOk);
  CHECK(loc.context().has_floor);
  CHECK(loc.context().up.z() > 0.99f);
  std::size_t count = 0;
  CHECK(loc.localize(params, kObjects, count) == Status::kOk);
  LONGS_EQUAL(1, count);
  const LocalizedObject& o = loc.results()[0];
  // Tolerance from the physics: the surface is fused at 3 mm voxels from exact depth.
  const float err = corner_error(kHalf, o.T_world_object, truth);
  std::printf("\n  box: corner error %.2f mm, score %.2f, free space %.3f\n", err * 1e3f, o.score, o.free_space);
  CHECK(err < 0.003f);
  CHECK(o.score > 0.5f);
  // Grasp on the top face, approached from above.
  DOUBLES_EQUAL(2.0f * kHalf.z(), o.grasp_m.z(), 0.003);
  CHECK(o.approach.z() < -0.95f);
}

TEST(Localize, EmptyBinGivesNoPoses) {
  Localizer loc;
  CHECK(loc.init(buffers()) == Status::kOk);
  std::vector<Vec3f> v;
  std::vector<std::array<uint32_t, 3>> t;
  box_mesh(kHalf, v, t);
  LocalizeParams params;
  int index = -1;
  CHECK(loc.add_model("box", v.data(), v.size(), reinterpret_cast<const uint32_t(*)[3]>(t.data()), t.size(), params,
                      index) == Status::kOk);
  Scene scene;
  scene.add_plane(Vec3f(0, 0, 1), 0.0f);
  TsdfVolume vol;
  SceneContext ctx;
  const std::size_t n = fuse(scene, vol, ctx.viewpoint_m);
  CHECK(loc.set_scene(g_points, n, ctx, &vol, 0.0075f) == Status::kOk);
  CHECK(loc.remove_bin(params) == Status::kOk);
  CHECK(loc.scene_count() < 50);
  std::size_t count = 7;
  CHECK(loc.localize(params, kObjects, count) == Status::kOk);
  LONGS_EQUAL(0, count);
  CHECK(loc.segment(params, kObjects, count) == Status::kOk);
  LONGS_EQUAL(0, count);
}

TEST(Localize, CorruptModelIsRejectedAtStartUp) {
  Localizer loc;
  CHECK(loc.init(buffers()) == Status::kOk);
  LocalizeParams params;
  int index = -1;
  const Vec3f flat[3] = {Vec3f(0, 0, 0), Vec3f(0.01f, 0, 0), Vec3f(0.02f, 0, 0)};  // zero area
  const uint32_t tri[1][3] = {{0, 1, 2}};
  CHECK(loc.add_model("flat", flat, 3, tri, 1, params, index) == Status::kInvalidArgument);
  const uint32_t bad[1][3] = {{0, 1, 7}};  // index out of range
  CHECK(loc.add_model("bad", flat, 3, bad, 1, params, index) == Status::kInvalidArgument);
  const Vec3f nan_v[3] = {Vec3f(0, 0, 0), Vec3f(std::nanf(""), 0, 0), Vec3f(0, 0.01f, 0)};
  CHECK(loc.add_model("nan", nan_v, 3, tri, 1, params, index) == Status::kInvalidArgument);
  // Finite garbage (a corrupt file's 1e30) is refused too: its grid cells would overflow int32.
  const Vec3f far_v[3] = {Vec3f(0, 0, 0), Vec3f(1e30f, 0, 0), Vec3f(0, 0.01f, 0)};
  CHECK(loc.add_model("far", far_v, 3, tri, 1, params, index) == Status::kInvalidArgument);
  LONGS_EQUAL(0, loc.model_count());
  // Capacity: the third model does not fit a two-model board.
  std::vector<Vec3f> v;
  std::vector<std::array<uint32_t, 3>> t;
  box_mesh(kHalf, v, t);
  for (int i = 0; i < 2; ++i)
    CHECK(loc.add_model("box", v.data(), v.size(), reinterpret_cast<const uint32_t(*)[3]>(t.data()), t.size(), params,
                        index) == Status::kOk);
  CHECK(loc.add_model("box", v.data(), v.size(), reinterpret_cast<const uint32_t(*)[3]>(t.data()), t.size(), params,
                      index) == Status::kCapacityExceeded);
}

TEST(Localize, GridNearestEqualsBruteForceAtEveryRadius) {
  // Surface-like points (a plane and a sphere cap, ~1 mm apart, as a fused surface) and queries on,
  // near and far from them, radii from half a cell to 9 cells: the ring search (k <= 1, with the
  // empty-neighbourhood bit) and the 3x3x3 block search (k >= 2) give the brute-force answer, the
  // lower index on a tie.
  Localizer loc;
  CHECK(loc.init(buffers()) == Status::kOk);
  std::vector<ScenePoint> pts;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 60; ++j)
      pts.push_back(ScenePoint{Vec3f(-0.03f + 0.001f * float(i), -0.03f + 0.001f * float(j), 0.5f), Vec3f(0, 0, -1),
                               uint32_t(pts.size()), {}});
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) {
      const float a = 0.03f * float(i), b = 0.157f * float(j);
      const Vec3f n(std::sin(a) * std::cos(b), std::sin(a) * std::sin(b), -std::cos(a));
      pts.push_back(ScenePoint{Vec3f(0.05f, 0.0f, 0.47f) + 0.02f * n, n, uint32_t(pts.size()), {}});
    }
  const float cell = 0.0035f;
  CHECK(loc.set_scene_points(pts.data(), pts.size(), SceneContext{}, nullptr, cell) == Status::kOk);
  const LocalizeBuffers b = buffers();
  uint32_t state = 12345u;
  const auto uniform = [&state](float lo, float hi) {
    state = state * 1664525u + 1013904223u;
    return lo + (hi - lo) * float(state >> 8) / 16777216.0f;
  };
  int found = 0, empty = 0;
  for (int t = 0; t < 4000; ++t) {
    const Vec3f q(uniform(-0.04f, 0.08f), uniform(-0.04f, 0.03f), uniform(0.44f, 0.52f));
    const float r = cell * uniform(0.5f, 9.0f);
    int32_t want = -1;
    float want_d2 = r * r;
    for (std::size_t i = 0; i < loc.scene_count(); ++i) {
      const float d2 = (loc.scene()[i].p - q).squaredNorm();
      if (d2 < want_d2) {
        want_d2 = d2;
        want = int32_t(i);
      }
    }
    const int k = int(std::ceil(r / cell));
    const CellPos cp = cell_pos(q, 1.0f / cell);
    NearestSearch as_localiser(b, q, cp, cell, r * r), rings(b, q, cp, cell, r * r);
    as_localiser.run(k);
    rings.by_rings(k);
    LONGS_EQUAL(want, as_localiser.found());
    LONGS_EQUAL(want, rings.found());
    (want >= 0 ? found : empty)++;
  }
  CHECK(found > 1000 && empty > 1000);  // both outcomes exercised
}

// A cloud file with garbage coordinates (finite, far beyond any cell): those points are skipped
// like non-finite ones, and the rest is localised as without them (the int32 cell index must not
// overflow: UBSan checks it).
TEST(Localize, SceneSkipsPointsBeyondTheWorkspace) {
  Localizer loc;
  CHECK(loc.init(buffers()) == Status::kOk);
  std::vector<ScenePoint> pts;
  for (int i = 0; i < 200; ++i)
    pts.push_back(ScenePoint{Vec3f(0.001f * float(i % 20), 0.001f * float(i / 20), 0.5f), Vec3f(0, 0, -1), uint32_t(i), {}});
  const float garbage[] = {1e30f, -3e9f, kLocalizeCoordMaxM * 1.001f, std::nanf("")};
  for (int k = 0; k < 4; ++k)
    pts.push_back(ScenePoint{Vec3f(0.01f, garbage[k], 0.5f), Vec3f(0, 0, -1), uint32_t(200 + k), {}});
  pts.push_back(ScenePoint{Vec3f(kLocalizeCoordMaxM, 0, 0.5f), Vec3f(0, 0, -1), 204u, {}});  // the limit itself is in
  SceneContext ctx;
  CHECK(loc.set_scene_points(pts.data(), pts.size(), ctx, nullptr, 0.005f) == Status::kOk);
  LONGS_EQUAL(201, loc.scene_count());
  for (std::size_t i = 0; i < loc.scene_count(); ++i) CHECK(localizable(loc.scene()[i].p));
  // A grid cell so small that 1 km would overflow its integer cells is refused, state unchanged.
  CHECK(loc.set_scene_points(pts.data(), pts.size(), ctx, nullptr, kLocalizeGridCellMinM * 0.5f) ==
        Status::kInvalidArgument);
  LONGS_EQUAL(201, loc.scene_count());
}

TEST(Localize, SegmentsTwoBoxesAndAllocatesNothingWhileLocalising) {
  Localizer loc;
  CHECK(loc.init(buffers()) == Status::kOk);
  std::vector<Vec3f> v;
  std::vector<std::array<uint32_t, 3>> t;
  box_mesh(kHalf, v, t);
  LocalizeParams params;
  int index = -1;
  CHECK(loc.add_model("box", v.data(), v.size(), reinterpret_cast<const uint32_t(*)[3]>(t.data()), t.size(), params,
                      index) == Status::kOk);
  Scene scene;
  scene.add_plane(Vec3f(0, 0, 1), 0.0f);
  Pose a, b;
  a.R = Eigen::AngleAxisf(0.3f, Vec3f::UnitZ()).toRotationMatrix();
  a.t = Vec3f(-0.05f, 0.0f, kHalf.z());
  b.R = Eigen::AngleAxisf(-0.7f, Vec3f::UnitZ()).toRotationMatrix();
  b.t = Vec3f(0.06f, 0.03f, kHalf.z());
  scene.add_box(a.t, kHalf, a);
  scene.add_box(b.t, kHalf, b);
  TsdfVolume vol;
  SceneContext ctx;
  const std::size_t n = fuse(scene, vol, ctx.viewpoint_m);
  std::size_t poses = 0, segments = 0;
  alloc_count_start();
  CHECK(loc.set_scene(g_points, n, ctx, &vol, 0.0075f) == Status::kOk);
  CHECK(loc.remove_bin(params) == Status::kOk);
  CHECK(loc.localize(params, kObjects, poses) == Status::kOk);
  const Pose p0 = loc.results()[0].T_world_object, p1 = loc.results()[1].T_world_object;
  CHECK(loc.segment(params, kObjects, segments) == Status::kOk);
  const long allocations = alloc_count();
  LONGS_EQUAL(0, allocations);
  LONGS_EQUAL(2, poses);
  const bool order = (p0.t - a.t).norm() < (p0.t - b.t).norm();
  CHECK(corner_error(kHalf, p0, order ? a : b) < 0.003f);
  CHECK(corner_error(kHalf, p1, order ? b : a) < 0.003f);
  LONGS_EQUAL(2, segments);
  for (std::size_t i = 0; i < 2; ++i) {
    const LocalizedObject& s = loc.results()[i];
    const Vec3f& c = s.T_world_object.t;
    const Vec3f ua = c - a.t, ub = c - b.t;
    const float da = std::hypot(ua.x(), ua.y()), db = std::hypot(ub.x(), ub.y());
    std::printf("\n  segment %zu: centre %.1f mm (horizontal) from a box centre, size %.1f x %.1f x %.1f mm", i + 1,
                std::min(da, db) * 1e3f, s.size_m.x() * 1e3f, s.size_m.y() * 1e3f, s.size_m.z() * 1e3f);
    CHECK(std::min(da, db) < 0.006f);  // horizontal centre within 2 voxels (the box's bottom is hidden)
    DOUBLES_EQUAL(2.0f * kHalf.z(), s.top_m, 0.003);
    CHECK(s.approach.z() < -0.95f);
  }
  // Deterministic: the same scene gives bit-identical poses.
  CHECK(loc.set_scene(g_points, n, ctx, &vol, 0.0075f) == Status::kOk);
  CHECK(loc.remove_bin(params) == Status::kOk);
  std::size_t again = 0;
  CHECK(loc.localize(params, kObjects, again) == Status::kOk);
  LONGS_EQUAL(2, again);
  CHECK(loc.results()[0].T_world_object.t == p0.t);
  CHECK(loc.results()[0].T_world_object.R == p0.R);
}

// A box resting on a larger box, seen as one organised depth frame (as the mOSD Kinect clouds):
// normals from image neighbours blend across the concave crease between the upper box's sides and the
// lower box's top, and with depth noise plain region growing walks through it in small turns.
// With the crease cut two segments, without it one.
ScenePoint g_frame_points[320 * 240];
Vec3f g_frame_xyz[320 * 240], g_frame_normals[320 * 240];

std::size_t stacked_boxes_frame(const Scene& scene, const Pose& T_world_cam) {
  const PinholeIntrinsics cam = camera();
  std::vector<uint16_t> depth;
  render(scene, cam, T_world_cam, depth);
  uint32_t rng = 12345u;  // deterministic depth noise, +-2 units of 0.2 mm steps x 5 (about Kinect's at 0.6 m)
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      const std::size_t i = std::size_t(v) * std::size_t(cam.width) + std::size_t(u);
      rng = rng * 1664525u + 1013904223u;
      const int noise = int((rng >> 16) % 11u) - 5;  // -5 .. 5 depth units = +-1 mm
      const float z = depth[i] ? float(int(depth[i]) + noise) / cam.depth_scale : std::nanf("");
      g_frame_xyz[i] = Vec3f((float(u) - cam.cx) / cam.fx * z, (float(v) - cam.cy) / cam.fy * z, z);
    }
  organised_normals(g_frame_xyz, cam.width, cam.height, 0.02f, g_frame_normals);
  std::size_t n = 0;
  for (std::size_t i = 0; i < std::size_t(cam.width * cam.height); ++i)
    if (g_frame_xyz[i].allFinite() && g_frame_normals[i].allFinite())  // world = camera frame, as a cloud
      g_frame_points[n++] = ScenePoint{g_frame_xyz[i], g_frame_normals[i], uint32_t(i), Rgba8{}};
  return n;
}

TEST(Localize, StackedBoxesSplitAtTheirConcaveCrease) {
  Localizer loc;
  CHECK(loc.init(buffers()) == Status::kOk);
  Scene scene;
  scene.add_plane(Vec3f(0, 0, 1), 0.0f);
  const Vec3f lower_half(0.07f, 0.05f, 0.02f), upper_half(0.03f, 0.02f, 0.015f);
  Pose lower, upper;
  lower.t = Vec3f(0, 0, lower_half.z());
  upper.R = Eigen::AngleAxisf(0.5f, Vec3f::UnitZ()).toRotationMatrix();
  upper.t = Vec3f(0.01f, -0.005f, 2.0f * lower_half.z() + upper_half.z());
  scene.add_box(lower.t, lower_half, lower);
  scene.add_box(upper.t, upper_half, upper);
  const Pose T_world_cam = look_at(Vec3f(0.05f, -0.35f, 0.45f), Vec3f(0, 0, 0.03f), Vec3f(0, 0, -1));
  const std::size_t n = stacked_boxes_frame(scene, T_world_cam);
  SceneContext ctx;  // viewpoint: the camera at the origin
  LocalizeParams params;
  params.segment_min_points = 50;  // a 320 x 240 frame: fewer points per face than a Kinect's
  std::size_t segments = 0;
  alloc_count_start();
  CHECK(loc.set_scene_points(g_frame_points, n, ctx, nullptr, 0.005f) == Status::kOk);
  CHECK(loc.remove_bin(params) == Status::kOk);
  CHECK(loc.segment(params, kObjects, segments) == Status::kOk);
  LONGS_EQUAL(0, alloc_count());
  LONGS_EQUAL(2, segments);
  // Every labelled point belongs to the box it lies on, except within the crease band's width of the
  // contact line, where the blended points may go to either side.
  std::size_t wrong = 0, labelled = 0, count[3] = {0, 0, 0};
  for (std::size_t i = 0; i < loc.scene_count(); ++i) {
    const int32_t l = loc.labels()[i];
    if (l == 0) continue;
    ++labelled;
    ++count[l];
    const Vec3f pw = T_world_cam * loc.scene()[i].p;
    const Vec3f q = upper.R.transpose() * (pw - upper.t);
    const bool on_upper = q.z() > -upper_half.z() + params.segment_crease_radius_m;
    const bool on_lower = pw.z() < 2.0f * lower_half.z() + 0.002f &&
                          (std::fabs(q.x()) > upper_half.x() + params.segment_crease_radius_m ||
                           std::fabs(q.y()) > upper_half.y() + params.segment_crease_radius_m);
    const int32_t upper_label = (T_world_cam * loc.results()[0].T_world_object.t).z() >
                                        (T_world_cam * loc.results()[1].T_world_object.t).z()
                                    ? 1
                                    : 2;
    wrong += (on_upper && l != upper_label) || (on_lower && l == upper_label);
  }
  std::printf("\n  stacked boxes: %zu segments (%zu, %zu points), %zu of %zu labelled points on the wrong box",
              segments, count[1], count[2], wrong, labelled);
  CHECK(wrong < labelled / 100);
  // The same frame without the crease cut is one segment: the test exercises the cut.
  params.segment_crease_deg = 0;
  CHECK(loc.segment(params, kObjects, segments) == Status::kOk);
  LONGS_EQUAL(1, segments);
}

namespace {
// A parallel-for on 3 threads started per call (test only: the board uses its worker pool).
void threads_run(void*, std::size_t count, void (*body)(void*, std::size_t), void* context) {
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    for (std::size_t i = next.fetch_add(1); i < count; i = next.fetch_add(1)) body(context, i);
  };
  std::thread t1(work), t2(work);
  work();
  t1.join();
  t2.join();
}
}  // namespace

TEST(Localize, SameResultsOnAnyThreadCount) {
  Localizer loc;
  CHECK(loc.init(buffers()) == Status::kOk);
  std::vector<Vec3f> v;
  std::vector<std::array<uint32_t, 3>> t;
  box_mesh(kHalf, v, t);
  LocalizeParams params;
  int index = -1;
  CHECK(loc.add_model("box", v.data(), v.size(), reinterpret_cast<const uint32_t(*)[3]>(t.data()), t.size(), params,
                      index) == Status::kOk);
  Scene scene;
  scene.add_plane(Vec3f(0, 0, 1), 0.0f);
  Pose a, b;
  a.R = Eigen::AngleAxisf(0.3f, Vec3f::UnitZ()).toRotationMatrix();
  a.t = Vec3f(-0.05f, 0.0f, kHalf.z());
  b.R = Eigen::AngleAxisf(-0.7f, Vec3f::UnitZ()).toRotationMatrix();
  b.t = Vec3f(0.06f, 0.03f, kHalf.z());
  scene.add_box(a.t, kHalf, a);
  scene.add_box(b.t, kHalf, b);
  TsdfVolume vol;
  SceneContext ctx;
  const std::size_t n = fuse(scene, vol, ctx.viewpoint_m);
  LocalizedObject serial[kObjects];
  std::size_t count_serial = 0, count_parallel = 0;
  CHECK(loc.set_scene(g_points, n, ctx, &vol, 0.0075f) == Status::kOk);
  CHECK(loc.remove_bin(params) == Status::kOk);
  CHECK(loc.localize(params, kObjects, count_serial) == Status::kOk);
  for (std::size_t i = 0; i < count_serial; ++i) serial[i] = loc.results()[i];
  ParallelFor pf;
  pf.run = &threads_run;
  loc.set_parallel(pf);
  CHECK(loc.set_scene(g_points, n, ctx, &vol, 0.0075f) == Status::kOk);
  CHECK(loc.remove_bin(params) == Status::kOk);
  CHECK(loc.localize(params, kObjects, count_parallel) == Status::kOk);
  LONGS_EQUAL(2, count_serial);
  LONGS_EQUAL(count_serial, count_parallel);
  for (std::size_t i = 0; i < count_serial; ++i) {  // bit-identical
    CHECK(loc.results()[i].T_world_object.t == serial[i].T_world_object.t);
    CHECK(loc.results()[i].T_world_object.R == serial[i].T_world_object.R);
    CHECK(loc.results()[i].score == serial[i].score);
  }
}

// The bin from configuration (floor pose + inner size) instead of detection. A second,
// identical box stands outside the configured bin: it must be removed with the bin (one pose only),
// the box inside is found, nothing is allocated, and a bad geometry is refused.
TEST(Localize, BinFromConfigurationRemovesWhatIsOutside) {
  Localizer loc;
  CHECK(loc.init(buffers()) == Status::kOk);
  std::vector<Vec3f> v;
  std::vector<std::array<uint32_t, 3>> t;
  box_mesh(kHalf, v, t);
  LocalizeParams params;
  int index = -1;
  CHECK(loc.add_model("box", v.data(), v.size(), reinterpret_cast<const uint32_t(*)[3]>(t.data()), t.size(), params,
                      index) == Status::kOk);
  Scene scene;
  scene.add_plane(Vec3f(0, 0, 1), 0.0f);
  Pose inside, outside;
  inside.R = Eigen::AngleAxisf(0.4f, Vec3f::UnitZ()).toRotationMatrix();
  inside.t = Vec3f(-0.02f, 0.01f, kHalf.z());
  outside.R = Eigen::AngleAxisf(-0.2f, Vec3f::UnitZ()).toRotationMatrix();
  outside.t = Vec3f(0.14f, -0.02f, kHalf.z());
  scene.add_box(inside.t, kHalf, inside);
  scene.add_box(outside.t, kHalf, outside);
  TsdfVolume vol;
  SceneContext ctx;
  const std::size_t n = fuse(scene, vol, ctx.viewpoint_m);
  BinGeometry bin;  // inner floor 0.20 x 0.20 m at z = 0: the second box (x = 0.14 m) is outside
  bin.inner_x_m = 0.20f;
  bin.inner_y_m = 0.20f;
  std::size_t poses = 0;
  alloc_count_start();
  CHECK(loc.set_scene(g_points, n, ctx, &vol, 0.0075f) == Status::kOk);
  CHECK(loc.set_bin(bin, params) == Status::kOk);
  CHECK(loc.localize(params, kObjects, poses) == Status::kOk);
  LONGS_EQUAL(0, alloc_count());
  CHECK(loc.context().has_floor);
  LONGS_EQUAL(4, loc.context().walls);
  for (std::size_t i = 0; i < loc.scene_count(); ++i) {  // nothing left on the floor or outside the bin
    CHECK(loc.scene()[i].p.z() > params.floor_tol_m);
    CHECK(std::fabs(loc.scene()[i].p.x()) < 0.1f && std::fabs(loc.scene()[i].p.y()) < 0.1f);
  }
  LONGS_EQUAL(1, poses);
  const float err = corner_error(kHalf, loc.results()[0].T_world_object, inside);
  std::printf("\n  box in the configured bin: corner error %.2f mm, score %.2f", err * 1e3f, loc.results()[0].score);
  CHECK(err < 0.003f);
  BinGeometry bad = bin;
  bad.inner_y_m = 0.0f;
  CHECK(loc.set_bin(bad, params) == Status::kInvalidArgument);
}
