// DepthFilterChain: the steps run in the documented order through one scratch image, give the same
// result as the steps called one by one, allocate nothing per frame, and the float and fixed-point
// chains agree.
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "alloc_counter.hpp"
#include "edgefuse/filters/depth_filter_chain.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {

using View = ImageView<uint16_t>;
using CView = ImageView<const uint16_t>;

// Objects on a floor at 0.7 m with ToF-like noise, mixed pixels, a patch beyond the range limit and
// an amplitude image with a dark patch.
struct TofFrame {
  std::vector<uint16_t> depth, amplitude;
  explicit TofFrame(const PinholeIntrinsics& c) {
    Scene s;
    s.add_plane(Vec3f(0, 0, -1), 0.7f);
    s.add_sphere(Vec3f(0.05f, 0.0f, 0.62f), 0.06f);
    s.add_box(Vec3f(-0.15f, 0.05f, 0.66f), Vec3f(0.05f, 0.03f, 0.04f), Pose{});
    std::vector<uint16_t> clean;
    render(s, c, Pose{}, clean);
    std::mt19937 rng(11);
    std::normal_distribution<float> noise(0.0f, 30.0f);
    std::uniform_real_distribution<float> uni(0.0f, 1.0f);
    depth = clean;
    amplitude.assign(clean.size(), 0);
    for (int v = 0; v < c.height; ++v)
      for (int u = 0; u < c.width; ++u) {
        const std::size_t i = std::size_t(v) * c.width + u;
        if (clean[i] == 0) continue;
        float z = float(clean[i]) + noise(rng);
        if (u + 1 < c.width && clean[i + 1] != 0 && std::abs(int(clean[i + 1]) - int(clean[i])) > 150 &&
            uni(rng) < 0.5f) {
          const float a = uni(rng);
          z = a * float(clean[i]) + (1.0f - a) * float(clean[i + 1]);
        }
        depth[i] = uint16_t(std::lround(z));
        amplitude[i] = uint16_t(u < 20 && v < 20 ? 300 : 5000);  // dark top-left corner
        if (u >= 140 && v >= 100) depth[i] = 8000;               // 1.6 m: beyond max_range
      }
  }
};

template <class Real>
std::vector<uint16_t> run_chain(const DepthFilterChain<Real>& chain, const PinholeIntrinsics& c,
                                const std::vector<uint16_t>& depth, const std::vector<uint16_t>* amplitude) {
  std::vector<uint16_t> scratch(depth.size()), out(depth.size(), 7);
  const CView amp = amplitude ? CView(amplitude->data(), c.width, c.height) : CView();
  CHECK(chain.run(CView(depth.data(), c.width, c.height), amp, View(scratch.data(), c.width, c.height),
                  View(out.data(), c.width, c.height)) == Status::kOk);
  return out;
}

}  // namespace

TEST_GROUP(FilterChain){};

template <class Real>
static void chain_equals_the_steps_one_by_one() {
  const PinholeIntrinsics c = bin_rig_a_tof_camera();
  const TofFrame f(c);
  const int w = c.width, h = c.height;
  // By hand: range -> amplitude -> jump edges -> bilateral.
  std::vector<uint16_t> a(f.depth.size()), b(f.depth.size());
  DepthFilterChain<Real> chain = DepthFilterChain<Real>::defaults_for(c, DepthSensorKind::kTimeOfFlight);
  CHECK(chain.prepare(c) == Status::kOk);
  CHECK(range_mask(CView(f.depth.data(), w, h), chain.range, c.depth_scale, View(a.data(), w, h)) == Status::kOk);
  CHECK(amplitude_mask(CView(a.data(), w, h), CView(f.amplitude.data(), w, h), chain.amplitude, View(a.data(), w, h)) ==
        Status::kOk);
  const std::vector<uint16_t> masked = a;
  CHECK(remove_jump_edges<Real>(CView(a.data(), w, h), chain.jump_kernel, View(b.data(), w, h)) == Status::kOk);
  const std::vector<uint16_t> jumped = b;
  CHECK(bilateral_filter(CView(b.data(), w, h), chain.bilateral_kernel, View(a.data(), w, h)) == Status::kOk);
  const std::vector<uint16_t> all = run_chain(chain, c, f.depth, &f.amplitude);
  for (std::size_t i = 0; i < all.size(); ++i) LONGS_EQUAL(a[i], all[i]);
  // The masks did their job, and nothing invalid came back.
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const std::size_t i = std::size_t(v) * w + u;
      if ((u < 20 && v < 20) || (u >= 140 && v >= 100) || f.depth[i] == 0) LONGS_EQUAL(0, all[i]);
      CHECK_EQUAL(jumped[i] == 0, all[i] == 0);
    }
  // Each neighbourhood step alone, and none, through the same buffers.
  chain.bilateral_enabled = false;
  CHECK(chain.prepare(c) == Status::kOk);
  const std::vector<uint16_t> jump_only = run_chain(chain, c, f.depth, &f.amplitude);
  for (std::size_t i = 0; i < all.size(); ++i) LONGS_EQUAL(jumped[i], jump_only[i]);
  chain.jump_edge_enabled = false;
  CHECK(chain.prepare(c) == Status::kOk);
  const std::vector<uint16_t> masks_only = run_chain(chain, c, f.depth, &f.amplitude);
  for (std::size_t i = 0; i < all.size(); ++i) LONGS_EQUAL(masked[i], masks_only[i]);
  chain.bilateral_enabled = true;
  CHECK(chain.prepare(c) == Status::kOk);
  const std::vector<uint16_t> bilateral_only = run_chain(chain, c, f.depth, &f.amplitude);
  CHECK(bilateral_filter(CView(masked.data(), w, h), chain.bilateral_kernel, View(b.data(), w, h)) == Status::kOk);
  for (std::size_t i = 0; i < all.size(); ++i) LONGS_EQUAL(b[i], bilateral_only[i]);
  // No amplitude image: the amplitude step is skipped.
  const std::vector<uint16_t> no_amp = run_chain(chain, c, f.depth, nullptr);
  CHECK(no_amp[5 * w + 5] != 0);
}
TEST(FilterChain, EqualsTheStepsOneByOneFloat) { chain_equals_the_steps_one_by_one<float>(); }
TEST(FilterChain, EqualsTheStepsOneByOneFixed) { chain_equals_the_steps_one_by_one<Fixed>(); }

TEST(FilterChain, InPlaceOnTheDepthImage) {
  const PinholeIntrinsics c = bin_rig_a_tof_camera();
  const TofFrame f(c);
  DepthFilterChain<float> chain = DepthFilterChain<float>::defaults_for(c, DepthSensorKind::kTimeOfFlight);
  CHECK(chain.prepare(c) == Status::kOk);
  const std::vector<uint16_t> expect = run_chain(chain, c, f.depth, &f.amplitude);
  std::vector<uint16_t> buf = f.depth, scratch(buf.size());
  const View v(buf.data(), c.width, c.height);
  CHECK(chain.run(CView(v), CView(f.amplitude.data(), c.width, c.height), View(scratch.data(), c.width, c.height), v) ==
        Status::kOk);
  for (std::size_t i = 0; i < buf.size(); ++i) LONGS_EQUAL(expect[i], buf[i]);
}

TEST(FilterChain, FloatAndFixedAgree) {
  const PinholeIntrinsics c = bin_rig_a_tof_camera();
  const TofFrame f(c);
  auto cf = DepthFilterChain<float>::defaults_for(c, DepthSensorKind::kTimeOfFlight);
  auto cx = DepthFilterChain<Fixed>::defaults_for(c, DepthSensorKind::kTimeOfFlight);
  CHECK(cf.prepare(c) == Status::kOk);
  CHECK(cx.prepare(c) == Status::kOk);
  const std::vector<uint16_t> a = run_chain(cf, c, f.depth, &f.amplitude), b = run_chain(cx, c, f.depth, &f.amplitude);
  std::size_t differ = 0;
  for (std::size_t i = 0; i < a.size(); ++i) differ += a[i] != b[i];
  LONGS_EQUAL(0, differ);
}

TEST(FilterChain, NoHeapAllocationPerFrame) {
  const PinholeIntrinsics c = bin_rig_a_tof_camera();
  const TofFrame f(c);
  const int w = c.width, h = c.height;
  auto tof_f = DepthFilterChain<float>::defaults_for(c, DepthSensorKind::kTimeOfFlight);
  auto tof_x = DepthFilterChain<Fixed>::defaults_for(c, DepthSensorKind::kTimeOfFlight);
  auto sl = DepthFilterChain<float>::defaults_for(c, DepthSensorKind::kStructuredLight);
  CHECK(tof_f.prepare(c) == Status::kOk);
  CHECK(tof_x.prepare(c) == Status::kOk);
  CHECK(sl.prepare(c) == Status::kOk);
  std::vector<uint16_t> scratch(f.depth.size()), out(f.depth.size()), tmp(f.depth.size());
  const CView depth(f.depth.data(), w, h), amp(f.amplitude.data(), w, h);
  const View s(scratch.data(), w, h), o(out.data(), w, h), t(tmp.data(), w, h);
  alloc_count_start();
  for (int frame = 0; frame < 3; ++frame) {
    CHECK(tof_f.run(depth, amp, s, o) == Status::kOk);
    CHECK(tof_x.run(depth, amp, s, o) == Status::kOk);
    CHECK(sl.run(depth, CView(), s, o) == Status::kOk);
    CHECK(range_mask(depth, tof_f.range, c.depth_scale, t) == Status::kOk);
    CHECK(amplitude_mask(depth, amp, tof_f.amplitude, t) == Status::kOk);
    CHECK(remove_jump_edges<float>(depth, tof_f.jump_kernel, t) == Status::kOk);
    CHECK(remove_jump_edges<Fixed>(depth, tof_x.jump_kernel, t) == Status::kOk);
    CHECK(bilateral_filter(depth, sl.bilateral_kernel, t) == Status::kOk);
  }
  LONGS_EQUAL(0, alloc_count());
}

TEST(FilterChain, BadArgumentsAreRejected) {
  const PinholeIntrinsics c = bin_rig_a_tof_camera();
  const int w = c.width, h = c.height;
  std::vector<uint16_t> d(std::size_t(w) * h, 3000), s(d.size()), o(d.size());
  DepthFilterChain<float> chain = DepthFilterChain<float>::defaults_for(c, DepthSensorKind::kTimeOfFlight);
  CHECK(chain.run(CView(d.data(), w, h), CView(), View(s.data(), w, h), View(o.data(), w, h)) ==
        Status::kNotInitialised);
  chain.jump_edge.max_angle_deg = 200.0f;
  CHECK(chain.prepare(c) == Status::kInvalidArgument);
  chain.jump_edge = JumpEdgeParams();
  chain.bilateral.radius_px = 9;
  CHECK(chain.prepare(c) == Status::kInvalidArgument);
  chain.bilateral = BilateralParams();
  chain.range.max_m = 0.0f;
  CHECK(chain.prepare(c) == Status::kInvalidArgument);
  chain.range = RangeMaskParams::from_sensor(c);
  CHECK(chain.prepare(c) == Status::kOk);
  CHECK(chain.run(CView(d.data(), w, h), CView(), View(s.data(), w, h), View(s.data(), w, h)) ==
        Status::kInvalidArgument);  // scratch is the output
  CHECK(chain.run(CView(d.data(), w, h), CView(), View(d.data(), w, h), View(o.data(), w, h)) ==
        Status::kInvalidArgument);  // scratch is the input
  CHECK(chain.run(CView(d.data(), w - 1, h), CView(), View(s.data(), w - 1, h), View(o.data(), w - 1, h)) ==
        Status::kInvalidArgument);  // not the prepared size
  CHECK(chain.run(CView(d.data(), w, h), CView(d.data(), w, h - 1), View(s.data(), w, h), View(o.data(), w, h)) ==
        Status::kInvalidArgument);  // amplitude size
  CHECK(chain.run(CView(d.data(), w, h), CView(), View(s.data(), w, h), View(o.data(), w, h)) == Status::kOk);
}
