// Bilateral filter: a 10 cm step stays a step, noise on a plane is reduced, the range sigma grows
// with depth, invalid pixels neither contribute nor become valid, and argument errors.
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "edgefuse/filters/bilateral.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {

using View = ImageView<uint16_t>;
using CView = ImageView<const uint16_t>;
constexpr int kW = 160, kH = 120;
constexpr float kScale = 5000.0f;  // 0.2 mm per raw unit

std::vector<uint16_t> bilateral(const std::vector<uint16_t>& in, const BilateralParams& p = BilateralParams()) {
  BilateralKernel k;
  CHECK(k.prepare(p, kScale) == Status::kOk);
  std::vector<uint16_t> out(in.size(), 7);
  CHECK(bilateral_filter(CView(in.data(), kW, kH), k, View(out.data(), kW, kH)) == Status::kOk);
  return out;
}

std::vector<uint16_t> add_noise(const std::vector<uint16_t>& clean, float sigma_m, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0.0f, sigma_m * kScale);
  std::vector<uint16_t> out = clean;
  for (uint16_t& z : out)
    if (z != 0) z = uint16_t(std::lround(float(z) + n(rng)));
  return out;
}

// RMS of (img - truth) over the pixels at least 2 px from the border.
double rms_error(const std::vector<uint16_t>& img, const std::vector<uint16_t>& truth) {
  double s = 0;
  long n = 0;
  for (int v = 2; v < kH - 2; ++v)
    for (int u = 2; u < kW - 2; ++u) {
      const std::size_t i = std::size_t(v) * kW + u;
      const double e = double(img[i]) - double(truth[i]);
      s += e * e;
      ++n;
    }
  return std::sqrt(s / double(n));
}

std::vector<uint16_t> step_image(uint16_t left, uint16_t right, int column) {
  std::vector<uint16_t> d(std::size_t(kW) * kH);
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) d[std::size_t(v) * kW + u] = u < column ? left : right;
  return d;
}

}  // namespace

TEST_GROUP(Bilateral){};

TEST(Bilateral, TablesSampleTheGaussians) {
  BilateralKernel k;
  CHECK(k.prepare(BilateralParams(), kScale) == Status::kOk);
  LONGS_EQUAL(2, k.radius);
  LONGS_EQUAL(BilateralKernel::kOne, k.spatial[12]);                    // centre of the 5x5 window
  LONGS_EQUAL(std::lround(1024 * std::exp(-8.0 / 4.5)), k.spatial[0]);  // corner (2, 2) at sigma 1.5
  LONGS_EQUAL(k.spatial[0], k.spatial[24]);
  LONGS_EQUAL(k.spatial[2], k.spatial[10]);  // symmetric in both axes
  LONGS_EQUAL(BilateralKernel::kOne, k.range[0]);
  for (int i = 1; i < BilateralKernel::kRangeSize; ++i) CHECK(k.range[i] <= k.range[i - 1]);
  CHECK(k.range[BilateralKernel::kRangeSize - 1] <= 1);
  // Half a sigma (index 16 covers 0.5..0.53 sigma): exp(-0.5 * 0.516^2).
  LONGS_EQUAL(std::lround(1024 * std::exp(-0.5 * (16.5 / 32) * (16.5 / 32))), k.range[16]);
}

TEST(Bilateral, StepEdgeStaysSharp) {
  // 10 cm step between 0.7 m and 0.8 m, noise as the Xtion at 0.7 m (1.4 mm).
  const std::vector<uint16_t> clean = step_image(3500, 4000, 80);
  const std::vector<uint16_t> exact = bilateral(clean);
  for (std::size_t i = 0; i < clean.size(); ++i) LONGS_EQUAL(clean[i], exact[i]);
  const std::vector<uint16_t> noisy = add_noise(clean, 0.0014f, 1);
  const std::vector<uint16_t> out = bilateral(noisy);
  int worst = 0;
  double bias_left = 0, bias_right = 0;
  for (int v = 0; v < kH; ++v) {
    const std::size_t i = std::size_t(v) * kW + 79;  // last foreground pixel, then first background
    worst = std::max(worst, std::max(std::abs(int(out[i]) - 3500), std::abs(int(out[i + 1]) - 4000)));
    bias_left += (double(out[i]) - 3500.0) / kH;
    bias_right += (double(out[i + 1]) - 4000.0) / kH;
  }
  std::printf("\n  step edge: worst pixel next to the step %.2f mm off its side, mean %.3f / %.3f mm\n", worst / 5.0,
              bias_left / 5.0, bias_right / 5.0);
  CHECK(worst <= 10);                 // 2 mm
  CHECK(std::fabs(bias_left) < 1.0);  // no pull towards the other side: 0.2 mm
  CHECK(std::fabs(bias_right) < 1.0);
}

TEST(Bilateral, NoiseOnATiltedPlaneIsReduced) {
  PinholeIntrinsics c;
  c.width = kW;
  c.height = kH;
  c.fx = c.fy = 200.0f;
  c.cx = 79.5f;
  c.cy = 59.5f;
  c.depth_scale = kScale;
  Scene s;
  const float a = 30.0f * 3.14159265f / 180.0f;
  const Vec3f n(0.0f, std::sin(a), -std::cos(a));
  s.add_plane(n, -n.dot(Vec3f(0, 0, 0.7f)));
  std::vector<uint16_t> clean;
  render(s, c, Pose{}, clean);
  const std::vector<uint16_t> noisy = add_noise(clean, 0.0014f, 2);
  const double before = rms_error(noisy, clean), after = rms_error(bilateral(noisy), clean);
  std::printf("\n  plane noise: rms %.3f mm -> %.3f mm (ratio %.2f)\n", before / 5, after / 5, after / before);
  CHECK(before > 6.0);  // the noise really is there (1.4 mm = 7 raw)
  CHECK(after < 0.5 * before);
}

TEST(Bilateral, RangeSigmaGrowsWithDepth) {
  // At 2 m a structured-light sensor's noise is ~8 mm: the quadratic default (sigma_r 2.4 cm
  // there) smooths it, a constant 3 mm sigma (right at 0.7 m) would leave it almost untouched.
  const std::vector<uint16_t> clean = step_image(10000, 10000, 0);
  const std::vector<uint16_t> noisy = add_noise(clean, 0.008f, 3);
  BilateralParams constant;
  constant.sigma_range_m = 0.003f;
  constant.sigma_range_per_m = 0.0f;
  const double before = rms_error(noisy, clean);
  const double quadratic = rms_error(bilateral(noisy), clean) / before;
  const double fixed_sigma = rms_error(bilateral(noisy, constant), clean) / before;
  std::printf("\n  8 mm noise at 2 m: ratio %.2f with sigma_r = k z^2, %.2f with 3 mm\n", quadratic, fixed_sigma);
  CHECK(quadratic < 0.5);
  CHECK(fixed_sigma > 0.7);
}

TEST(Bilateral, InvalidPixelsNeitherContributeNorBecomeValid) {
  std::vector<uint16_t> d = step_image(3500, 3500, 0);
  std::mt19937 rng(4);
  std::uniform_int_distribution<int> pick(0, kW * kH - 1);
  for (int i = 0; i < 3000; ++i) d[std::size_t(pick(rng))] = 0;
  d[5 * kW + 5] = 3600;  // a valid pixel whose whole window is otherwise invalid
  for (int v = 3; v <= 7; ++v)
    for (int u = 3; u <= 7; ++u)
      if (u != 5 || v != 5) d[std::size_t(v) * kW + u] = 0;
  const std::vector<uint16_t> out = bilateral(d);
  for (std::size_t i = 0; i < d.size(); ++i) {
    CHECK_EQUAL(d[i] == 0, out[i] == 0);
    if (d[i] != 0 && i != std::size_t(5 * kW + 5)) LONGS_EQUAL(3500, out[i]);  // zeros never pull it down
  }
  LONGS_EQUAL(3600, out[5 * kW + 5]);
}

TEST(Bilateral, BadArgumentsAreRejected) {
  BilateralKernel k;
  std::vector<uint16_t> a(kW * kH, 1000), b(kW * kH);
  CHECK(bilateral_filter(CView(a.data(), kW, kH), k, View(b.data(), kW, kH)) == Status::kNotInitialised);
  BilateralParams p;
  CHECK(p.valid());
  p.radius_px = 0;
  CHECK(k.prepare(p, kScale) == Status::kInvalidArgument);
  p.radius_px = BilateralKernel::kMaxRadius + 1;
  CHECK(k.prepare(p, kScale) == Status::kInvalidArgument);
  p = BilateralParams();
  p.sigma_space_px = 0.0f;
  CHECK(k.prepare(p, kScale) == Status::kInvalidArgument);
  p = BilateralParams();
  p.sigma_range_per_m = 0.0f;  // and sigma_range_m = 0: no range sigma at all
  CHECK(k.prepare(p, kScale) == Status::kInvalidArgument);
  p.sigma_range_m = -0.01f;
  CHECK(k.prepare(p, kScale) == Status::kInvalidArgument);
  CHECK(k.prepare(BilateralParams(), 0.0f) == Status::kInvalidArgument);
  CHECK(k.prepare(BilateralParams(), kScale) == Status::kOk);
  CHECK(bilateral_filter(CView(a.data(), kW, kH), k, View(b.data(), kH, kW)) == Status::kInvalidArgument);
  CHECK(bilateral_filter(CView(a.data(), kW, kH), k, View(a.data(), kW, kH)) == Status::kInvalidArgument);
  CHECK(bilateral_filter(CView(a.data(), kW, kH - 1), k, View(a.data() + kW, kW, kH - 1)) ==
        Status::kInvalidArgument);  // overlapping rows
  CHECK(bilateral_filter(CView(a.data(), kW, kH), k, View(b.data(), kW, kH)) == Status::kOk);
}
