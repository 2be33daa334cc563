// Jump-edge filter on crafted and rendered depth: a mixed pixel between a foreground and a
// background is removed, tilted planes keep their pixels up to the 80 deg incidence the default
// threshold allows, invalid neighbours are ignored, and the float and fixed-point kernels agree.
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "edgefuse/filters/jump_edge.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {

using View = ImageView<uint16_t>;
using CView = ImageView<const uint16_t>;

PinholeIntrinsics jump_camera(int w, int h, float f) {
  PinholeIntrinsics c;
  c.width = w;
  c.height = h;
  c.fx = c.fy = f;
  c.cx = 0.5f * float(w - 1);
  c.cy = 0.5f * float(h - 1);
  c.depth_scale = 5000.0f;
  c.min_range_m = 0.1f;
  c.max_range_m = 5.0f;
  return c;
}

template <class Real>
std::vector<uint16_t> filtered(const std::vector<uint16_t>& in, const PinholeIntrinsics& c,
                               JumpEdgeParams p = JumpEdgeParams()) {
  JumpEdgeKernel<Real> k;
  CHECK(k.prepare(p, c) == Status::kOk);
  std::vector<uint16_t> out(in.size(), 7);
  CHECK(remove_jump_edges<Real>(CView(in.data(), c.width, c.height), k, View(out.data(), c.width, c.height)) ==
        Status::kOk);
  return out;
}

std::size_t count_valid(const std::vector<uint16_t>& d) {
  std::size_t n = 0;
  for (uint16_t z : d) n += z != 0;
  return n;
}

// A plane through (0, 0, dist) whose normal is tilted by `deg` from the optical axis (about x).
std::vector<uint16_t> tilted_plane(const PinholeIntrinsics& c, float deg, float dist) {
  const float a = deg * 3.14159265f / 180.0f;
  const Vec3f n(0.0f, std::sin(a), -std::cos(a));
  Scene s;
  s.add_plane(n, -n.dot(Vec3f(0, 0, dist)));
  std::vector<uint16_t> depth;
  render(s, c, Pose{}, depth);
  return depth;
}

}  // namespace

TEST_GROUP(JumpEdge){};

template <class Real>
static void mixed_pixel_at_an_edge_is_removed() {
  // Foreground 0.5 m left of column 80, background 1.0 m from column 80 on, and one pixel of the
  // background column at 0.75 m (a mixed pixel straddling the edge).
  const PinholeIntrinsics c = jump_camera(160, 120, 120.0f);
  std::vector<uint16_t> d(std::size_t(c.width) * c.height);
  for (int v = 0; v < c.height; ++v)
    for (int u = 0; u < c.width; ++u) d[std::size_t(v) * c.width + u] = u < 80 ? 2500 : 5000;
  d[60 * 160 + 80] = 3750;
  const std::vector<uint16_t> out = filtered<Real>(d, c);
  LONGS_EQUAL(0, out[60 * 160 + 80]);  // the mixed pixel
  for (int v = 0; v < c.height; ++v)
    for (int u = 0; u < c.width; ++u) {
      const std::size_t i = std::size_t(v) * c.width + u;
      if (u <= 78 || u >= 81 || (u == 80 && v != 60)) LONGS_EQUAL(d[i], out[i]);  // surfaces kept
      // Column 79, the foreground's rim, has the background (or the mixed pixel) right behind it:
      // removed by construction of the criterion (see jump_edge.hpp).
      if (u == 79) LONGS_EQUAL(0, out[i]);
    }
}
TEST(JumpEdge, MixedPixelAtAnEdgeIsRemovedFloat) { mixed_pixel_at_an_edge_is_removed<float>(); }
TEST(JumpEdge, MixedPixelAtAnEdgeIsRemovedFixed) { mixed_pixel_at_an_edge_is_removed<Fixed>(); }

TEST(JumpEdge, SmallStepsAreNotJumps) {
  // 1 cm step at 0.5 m: 2.4 pixel footprints at f = 120, below T* = 5.7: nothing is removed.
  const PinholeIntrinsics c = jump_camera(40, 30, 120.0f);
  std::vector<uint16_t> d(std::size_t(c.width) * c.height);
  for (int v = 0; v < c.height; ++v)
    for (int u = 0; u < c.width; ++u) d[std::size_t(v) * c.width + u] = u < 20 ? 2500 : 2550;
  const std::vector<uint16_t> out = filtered<float>(d, c);
  LONGS_EQUAL(d.size(), count_valid(out));
}

template <class Real>
static void tilted_planes_keep_their_pixels() {
  // 60 deg tilt, 160 x 120 at f = 200: incidence 43..77 deg over the image.
  const PinholeIntrinsics wide = jump_camera(160, 120, 200.0f);
  const std::vector<uint16_t> p60 = tilted_plane(wide, 60.0f, 1.0f);
  const std::size_t n60 = count_valid(p60);
  CHECK(n60 == p60.size());
  const std::size_t k60 = count_valid(filtered<Real>(p60, wide));
  CHECK(double(k60) >= 0.99 * double(n60));
  // 72 deg tilt with a narrow lens (f = 600): incidence 66..78 deg.
  const PinholeIntrinsics narrow = jump_camera(160, 120, 600.0f);
  const std::vector<uint16_t> p72 = tilted_plane(narrow, 72.0f, 1.0f);
  const std::size_t k72 = count_valid(filtered<Real>(p72, narrow));
  CHECK(double(k72) >= 0.99 * double(count_valid(p72)));
  // Beyond the threshold: at 88 deg the plane is seen at 82..88 deg and is dropped (all but the
  // farthest row, which has no neighbour behind it).
  const std::vector<uint16_t> p88 = tilted_plane(narrow, 88.0f, 1.0f);
  const std::size_t n88 = count_valid(p88);
  CHECK(n88 > 1000);
  CHECK(double(count_valid(filtered<Real>(p88, narrow))) < 0.1 * double(n88));
}
TEST(JumpEdge, TiltedPlanesKeepTheirPixelsFloat) { tilted_planes_keep_their_pixels<float>(); }
TEST(JumpEdge, TiltedPlanesKeepTheirPixelsFixed) { tilted_planes_keep_their_pixels<Fixed>(); }

TEST(JumpEdge, InvalidNeighboursAreIgnoredAndInvalidStaysInvalid) {
  const PinholeIntrinsics c = jump_camera(20, 20, 100.0f);
  std::vector<uint16_t> d(400, 4000);
  for (int i = 0; i < 400; i += 3) d[std::size_t(i)] = 0;  // holes everywhere
  const std::vector<uint16_t> out = filtered<float>(d, c);
  for (std::size_t i = 0; i < d.size(); ++i) LONGS_EQUAL(d[i], out[i]);
}

TEST(JumpEdge, FloatAndFixedAgreeOnANoisySceneWithMixedPixels) {
  // Objects on a floor seen from 0.7 m by a ToF-like camera, gaussian noise as the bin_rig_a ToF
  // (~7 mm) and mixed pixels at half of the depth jumps: both kernels must remove the same pixels.
  PinholeIntrinsics c = jump_camera(160, 120, 80.0f);
  c.fy = 88.95f;
  Scene s;
  s.add_plane(Vec3f(0, 0, -1), 0.7f);
  s.add_sphere(Vec3f(0.05f, 0.0f, 0.62f), 0.06f);
  s.add_box(Vec3f(-0.15f, 0.05f, 0.66f), Vec3f(0.05f, 0.03f, 0.04f), Pose{});
  s.add_sphere(Vec3f(-0.05f, -0.15f, 0.65f), 0.04f);
  s.add_sphere(Vec3f(0.2f, 0.15f, 0.6f), 0.05f);
  std::vector<uint16_t> d;
  render(s, c, Pose{}, d);
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.0f, 35.0f);  // raw units: 7 mm
  std::uniform_real_distribution<float> mix(0.0f, 1.0f);
  std::vector<uint16_t> noisy = d;
  int mixed = 0;
  for (int v = 0; v < c.height; ++v)
    for (int u = 0; u + 1 < c.width; ++u) {
      const std::size_t i = std::size_t(v) * c.width + u;
      if (d[i] == 0) continue;
      float z = float(d[i]) + noise(rng);
      if (d[i + 1] != 0 && std::abs(int(d[i + 1]) - int(d[i])) > 150 && mix(rng) < 0.5f) {
        const float a = mix(rng);
        z = a * float(d[i]) + (1.0f - a) * float(d[i + 1]);
        ++mixed;
      }
      noisy[i] = uint16_t(std::lround(z));
    }
  CHECK(mixed > 20);
  const std::vector<uint16_t> a = filtered<float>(noisy, c), b = filtered<Fixed>(noisy, c);
  std::size_t removed = 0, differ = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    removed += noisy[i] != 0 && a[i] == 0;
    differ += a[i] != b[i];
    CHECK(a[i] == 0 || a[i] == noisy[i]);  // a filter that only removes
  }
  std::printf("\n  noisy scene: %d mixed pixels made, %zu pixels removed, float/fixed differ in %zu\n", mixed, removed,
              differ);
  CHECK(removed > std::size_t(mixed) / 2);
  LONGS_EQUAL(0, differ);
}

TEST(JumpEdge, CellBoundsOnlySkipWork) {
  // A wide lens (90 x 90 deg) and noise large enough that many pixels reach the exact test: with
  // every cell bound lowered to "always test", the result must not change.
  const PinholeIntrinsics c = jump_camera(96, 96, 48.0f);
  Scene s;
  s.add_plane(Vec3f(0.3f, 0, -1), 0.8f);
  s.add_sphere(Vec3f(0.1f, 0.05f, 0.6f), 0.1f);
  std::vector<uint16_t> d;
  render(s, c, Pose{}, d);
  std::mt19937 rng(5);
  std::normal_distribution<float> noise(0.0f, 60.0f);
  for (uint16_t& z : d)
    if (z != 0) z = uint16_t(std::lround(float(z) + noise(rng)));
  JumpEdgeKernel<Fixed> k;
  CHECK(k.prepare(JumpEdgeParams(), c) == Status::kOk);
  std::vector<uint16_t> a(d.size()), b(d.size());
  CHECK(remove_jump_edges<Fixed>(CView(d.data(), c.width, c.height), k, View(a.data(), c.width, c.height)) ==
        Status::kOk);
  for (int64_t& bound : k.bound_q16) bound = -(int64_t(1) << 40);
  CHECK(remove_jump_edges<Fixed>(CView(d.data(), c.width, c.height), k, View(b.data(), c.width, c.height)) ==
        Status::kOk);
  std::size_t removed = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    LONGS_EQUAL(b[i], a[i]);
    removed += d[i] != 0 && a[i] == 0;
  }
  CHECK(removed > 20);
}

TEST(JumpEdge, BadArgumentsAreRejected) {
  const PinholeIntrinsics c = jump_camera(16, 12, 50.0f);
  std::vector<uint16_t> a(16 * 12, 1000), b(16 * 12);
  JumpEdgeKernel<float> k;
  CHECK(remove_jump_edges<float>(CView(a.data(), 16, 12), k, View(b.data(), 16, 12)) == Status::kNotInitialised);
  JumpEdgeParams p;
  p.max_angle_deg = 90.0f;
  CHECK(k.prepare(p, c) == Status::kInvalidArgument);
  p.max_angle_deg = 180.0f;
  CHECK(k.prepare(p, c) == Status::kInvalidArgument);
  p.max_angle_deg = std::nanf("");
  CHECK_FALSE(p.valid());
  PinholeIntrinsics bad = c;
  bad.fx = 0;
  CHECK(k.prepare(JumpEdgeParams(), bad) == Status::kInvalidArgument);
  CHECK(k.prepare(JumpEdgeParams(), c) == Status::kOk);
  CHECK(remove_jump_edges<float>(CView(a.data(), 16, 12), k, View(b.data(), 12, 16)) == Status::kInvalidArgument);
  CHECK(remove_jump_edges<float>(CView(a.data(), 12, 16), k, View(b.data(), 12, 16)) == Status::kInvalidArgument);
  CHECK(remove_jump_edges<float>(CView(a.data(), 16, 12), k, View(a.data(), 16, 12)) == Status::kInvalidArgument);
  CHECK(remove_jump_edges<float>(CView(a.data(), 16, 12), k, View(b.data(), 16, 12)) == Status::kOk);
}
