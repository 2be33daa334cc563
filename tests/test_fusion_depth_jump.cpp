// Noise-aware depth discontinuity (DepthFrame::jump_m): a depth sensor whose noise is of the order of the truncation (a ToF
// camera: 6 mm against 8 mm) must not have its noise read as depth discontinuities. With the
// truncation as the jump limit two thirds of a noisy plane's voxels get no sample from a frame (the
// 2x2 pixels a voxel interpolates from differ by more than 8 mm); with DepthFrame::jump_m at 2.83
// sigma 85 % do, in the float and the fixed-point kernels alike. (The extraction support rule that
// goes with it is tested in test_extract: MinWeightSupportRule.)
#include <cmath>
#include <random>
#include <vector>

#include "alloc_counter.hpp"
#include "edgefuse/tsdf/integrate.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {
constexpr int kDim = 64;
constexpr float kVoxel = 0.002f, kTrunc = 0.008f, kPlaneZ = 0.7f, kSigma = 0.006f;
VolumeStorage<kDim> g_storage;
SensorBuffers<float> g_buf_f;
SensorBuffers<Fixed> g_buf_q;

//! A plane at z = 0.7 m seen head-on, with gaussian z noise of kSigma (fixed seed).
std::vector<uint16_t> noisy_plane(const PinholeIntrinsics& intr) {
  Scene scene;
  scene.add_plane(Vec3f(0, 0, -1), kPlaneZ);
  std::vector<uint16_t> depth;
  render(scene, intr, Pose::identity(), depth);
  std::mt19937 rng(4);
  std::normal_distribution<float> noise(0.0f, kSigma);
  for (uint16_t& d : depth)
    if (d != 0) d = uint16_t(std::lround((float(d) / intr.depth_scale + noise(rng)) * intr.depth_scale));
  return depth;
}

//! Share of the voxels within trunc/2 of the plane (all inside the frustum) that got a sample.
template <class Real>
double observed_share(float jump_m, SensorBuffers<Real>& buf) {
  const PinholeIntrinsics intr = bin_rig_a_tof_camera();
  const std::vector<uint16_t> depth = noisy_plane(intr);
  TsdfVolume vol;
  const float half = 0.5f * kDim * kVoxel;
  CHECK(vol.init(g_storage.view(false), kDim, Vec3f(-half, -half, kPlaneZ - half), TsdfParams::defaults_for(kVoxel, kTrunc)) ==
        Status::kOk);
  DepthFrame f;
  f.depth = ImageView<const uint16_t>(depth.data(), intr.width, intr.height);
  f.jump_m = jump_m;
  FrameScratch s = buf.scratch();
  const ImageView<const Real> norms = buf.ray_norms(intr);
  const long before = alloc_count();
  CHECK(integrate<Real>(vol, intr, norms, f, Pose::identity(), s) == Status::kOk);
  LONGS_EQUAL(before, alloc_count());
  std::size_t band = 0, seen = 0;
  for (int z = 0; z < kDim; ++z)
    for (int y = 0; y < kDim; ++y)
      for (int x = 0; x < kDim; ++x) {
        if (std::fabs(vol.voxel_centre(x, y, z).z() - kPlaneZ) >= 0.5f * kTrunc) continue;
        ++band;
        seen += vol.weight()[vol.index(x, y, z)] != 0;
      }
  CHECK(band > 0);
  return double(seen) / double(band);
}
}  // namespace

TEST_GROUP(FusionDepthJump){};

TEST(FusionDepthJump, NoiseAwareJumpLetsANoisyPlaneIn) {
  const double f_trunc = observed_share<float>(0.0f, g_buf_f);
  const double f_noise = observed_share<float>(2.83f * kSigma, g_buf_f);
  const double q_trunc = observed_share<Fixed>(0.0f, g_buf_q);
  const double q_noise = observed_share<Fixed>(2.83f * kSigma, g_buf_q);
  std::printf("\nobserved share of the plane's band, one frame at sigma 6 mm: jump = trunc %.3f (fixed %.3f), "
              "jump = 2.83 sigma %.3f (fixed %.3f)\n", f_trunc, q_trunc, f_noise, q_noise);
  CHECK(f_trunc < 0.5);  // measured 0.34
  CHECK(f_noise > 0.8);   // measured 0.85 (the rest: 4 pixels still spread > 2.83 sigma, or d < -rho)
  CHECK(std::fabs(q_trunc - f_trunc) < 0.02);
  CHECK(std::fabs(q_noise - f_noise) < 0.02);
  // A jump limit below the truncation is the truncation (nothing changes).
  CHECK(std::fabs(observed_share<float>(0.5f * kTrunc, g_buf_f) - f_trunc) < 1e-9);
}

TEST(FusionDepthJump, BadJumpRejected) {
  const PinholeIntrinsics intr = bin_rig_a_tof_camera();
  const std::vector<uint16_t> depth = noisy_plane(intr);
  TsdfVolume vol;
  CHECK(vol.init(g_storage.view(false), kDim, Vec3f(-0.064f, -0.064f, 0.636f), TsdfParams::defaults_for(kVoxel, kTrunc)) ==
        Status::kOk);
  DepthFrame f;
  f.depth = ImageView<const uint16_t>(depth.data(), intr.width, intr.height);
  FrameScratch s = g_buf_f.scratch();
  for (float bad : {-0.01f, std::nanf(""), 2.0f}) {
    f.jump_m = bad;
    CHECK(integrate<float>(vol, intr, g_buf_f.ray_norms(intr), f, Pose::identity(), s) == Status::kInvalidArgument);
  }
}
