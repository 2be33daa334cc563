// The filters on a real bin_rig_a ToF frame (synthetic rig, README noise model: flying pixels at
// 1.49 % of all pixels, no depth below normalised amplitude 0.02). Prints what each step removes.
#include <cstdint>
#include <string>
#include <vector>

#include "edgefuse/filters/depth_filter_chain.hpp"
#include "edgefuse/io/png.hpp"
#include "edgefuse/io/rig.hpp"
#include "test_support.hpp"

using namespace edgefuse;

namespace {
using View = ImageView<uint16_t>;
using CView = ImageView<const uint16_t>;

std::size_t count_valid(const std::vector<uint16_t>& d) {
  std::size_t n = 0;
  for (uint16_t z : d) n += z != 0;
  return n;
}
}  // namespace

TEST_GROUP(FiltersOnTof){};

TEST(FiltersOnTof, BinRigAFrame) {
  const std::string root = edgefuse_test::require_data("bin_rig_a");
  if (root.empty()) return;
  std::string err;
  io::RigToml rig;
  CHECK_TEXT(io::read_rig_toml(root + "/rig.toml", rig, err), err.c_str());
  const io::RigSensor* tof = rig.find_sensor("tof");
  CHECK(tof != nullptr);
  const PinholeIntrinsics c = tof->pinhole;
  std::vector<uint16_t> depth, amplitude;
  int w = 0, h = 0, wa = 0, ha = 0;
  CHECK_TEXT(io::read_png_u16(root + "/tof/depth/1000.000000.png", depth, w, h, err), err.c_str());
  CHECK_TEXT(io::read_png_u16(root + "/tof/amplitude/1000.000000.png", amplitude, wa, ha, err), err.c_str());
  CHECK(w == c.width && h == c.height && wa == w && ha == h);
  const double pixels = double(depth.size());

  auto chain = DepthFilterChain<float>::defaults_for(c, DepthSensorKind::kTimeOfFlight);
  auto chain_fixed = DepthFilterChain<Fixed>::defaults_for(c, DepthSensorKind::kTimeOfFlight);
  CHECK(chain.prepare(c) == Status::kOk);
  CHECK(chain_fixed.prepare(c) == Status::kOk);
  std::vector<uint16_t> masked(depth.size()), jumped(depth.size()), jumped_fixed(depth.size());
  CHECK(range_mask(CView(depth.data(), w, h), chain.range, c.depth_scale, View(masked.data(), w, h)) == Status::kOk);
  const std::size_t n_raw = count_valid(depth), n_range = count_valid(masked);
  CHECK(amplitude_mask(CView(masked.data(), w, h), CView(amplitude.data(), w, h), chain.amplitude,
                       View(masked.data(), w, h)) == Status::kOk);
  const std::size_t n_amp = count_valid(masked);
  CHECK(remove_jump_edges<float>(CView(masked.data(), w, h), chain.jump_kernel, View(jumped.data(), w, h)) ==
        Status::kOk);
  CHECK(remove_jump_edges<Fixed>(CView(masked.data(), w, h), chain_fixed.jump_kernel,
                                 View(jumped_fixed.data(), w, h)) == Status::kOk);
  const std::size_t n_jump = count_valid(jumped);
  std::size_t differ = 0;
  for (std::size_t i = 0; i < jumped.size(); ++i) differ += jumped[i] != jumped_fixed[i];
  const std::size_t removed = n_amp - n_jump;

  std::vector<uint16_t> scratch(depth.size()), out(depth.size());
  CHECK(chain.run(CView(depth.data(), w, h), CView(amplitude.data(), w, h), View(scratch.data(), w, h),
                  View(out.data(), w, h)) == Status::kOk);

  std::printf("\n  bin_rig_a tof frame 0 (%dx%d): valid %zu (%.2f %%); range mask -%zu, amplitude >= %u -%zu\n", w, h,
              n_raw, 100.0 * double(n_raw) / pixels, n_raw - n_range, unsigned(chain.amplitude.min_amplitude),
              n_range - n_amp);
  std::printf(
      "  jump edges (xi > %.0f deg): removed %zu = %.2f %% of all pixels (README: flying pixels 1.49 %%),\n"
      "  %.1f %% of the valid ones; kept %.1f %%; float/fixed differ in %zu pixels; chain output %zu valid\n",
      double(chain.jump_edge.max_angle_deg), removed, 100.0 * double(removed) / pixels,
      100.0 * double(removed) / double(n_amp), 100.0 * double(n_jump) / double(n_amp), differ, count_valid(out));
  // Physically sensible: of the order of the flying pixels, and most of the surfaces kept. The
  // criterion also drops the foreground's one-pixel rim at every jump (jump_edge.hpp), and the
  // image is small and cluttered, so ~11 % of the valid pixels go, not just the ~10 % flying ones.
  CHECK(removed >= std::size_t(0.005 * pixels));
  CHECK(removed <= std::size_t(0.05 * pixels));
  CHECK(double(n_jump) >= 0.85 * double(n_amp));
  CHECK(double(differ) <= 0.001 * pixels);
  CHECK(n_raw - n_range == 0);  // the camera already clips to its range: nothing to do here
}
