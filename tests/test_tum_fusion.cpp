// Real data: the 37 frames of TUM RGB-D fr1/xyz fused at their motion-capture poses, then the
// space raycast at a frame's pose and compared with that frame's own depth.
// Tolerances from the physics: 2 cm voxels; Kinect v1 depth noise 3-5 mm at 1-1.5 m plus its
// disparity steps (~4 mm at 1.2 m); motion-capture pose error of a few mm; TUM's depth-to-mocap
// time offset. Where both see the same surface, the median difference must stay under a quarter
// voxel and 90 % of pixels within one voxel. Runs with the build's scalar (float or fixed point).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "edgefuse/io/dataset.hpp"
#include "edgefuse/tsdf/integrate.hpp"
#include "edgefuse/tsdf/raycast.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {
constexpr int kDim = 128;
constexpr float kVoxel = 0.02f;
VolumeStorage<kDim> g_storage;
SensorBuffers<real_t> g_sensor;
}  // namespace

TEST_GROUP(TumFusion){};

TEST(TumFusion, RaycastOfTheFusedSpaceMatchesAFramesDepth) {
  const std::string dir = require_data("tum_fr1_xyz_37");
  if (dir.empty()) return;
  io::DepthSequence seq;
  std::string err;
  CHECK_TEXT(io::open_depth_sequence(dir, "", seq, err), err.c_str());
  CHECK_EQUAL(37u, seq.frames.size());
  const PinholeIntrinsics& cam = seq.intr;

  // Volume centred on what the first frame sees (median of its points).
  std::vector<uint16_t> depth;
  CHECK_TEXT(io::load_depth(seq.frames[0], cam, depth, err), err.c_str());
  std::vector<float> xs, ys, zs;
  for (int v = 0; v < cam.height; v += 4)
    for (int u = 0; u < cam.width; u += 4) {
      const uint16_t raw = depth[std::size_t(v) * cam.width + u];
      if (raw == 0) continue;
      const Vec3f p = seq.frames[0].T_world_cam * cam.back_project(float(u), float(v), raw / cam.depth_scale);
      xs.push_back(p.x());
      ys.push_back(p.y());
      zs.push_back(p.z());
    }
  auto median = [](std::vector<float>& v) {
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const Vec3f centre(median(xs), median(ys), median(zs));
  TsdfVolume vol;
  CHECK(vol.init(g_storage.view(), kDim, centre - Vec3f::Constant(0.5f * kDim * kVoxel),
                 TsdfParams::defaults_for(kVoxel, 4 * kVoxel)) == Status::kOk);

  const ImageView<const real_t> norms = g_sensor.ray_norms(cam);
  FrameScratch scratch = g_sensor.scratch();
  for (const io::FrameRef& f : seq.frames) {
    CHECK(f.has_pose);
    CHECK_TEXT(io::load_depth(f, cam, depth, err), err.c_str());
    const DepthFrame frame{{depth.data(), cam.width, cam.height}, {}};
    CHECK(integrate<real_t>(vol, cam, norms, frame, f.T_world_cam, scratch) == Status::kOk);
  }

  const io::FrameRef& probe = seq.frames[18];
  CHECK_TEXT(io::load_depth(probe, cam, depth, err), err.c_str());
  std::vector<float> model(std::size_t(cam.width) * cam.height);
  RaycastMaps maps;
  maps.depth_m = ImageView<float>(model.data(), cam.width, cam.height);
  CHECK(raycast<real_t>(vol, cam, probe.T_world_cam, maps) == Status::kOk);

  std::vector<float> diff;
  std::size_t measured = 0;
  for (std::size_t i = 0; i < depth.size(); ++i) {
    if (depth[i] == 0) continue;
    ++measured;
    if (model[i] > 0) diff.push_back(std::fabs(model[i] - depth[i] / cam.depth_scale));
  }
  CHECK(!diff.empty());
  std::sort(diff.begin(), diff.end());
  const float med = diff[diff.size() / 2];
  const std::size_t within = std::size_t(std::upper_bound(diff.begin(), diff.end(), kVoxel) - diff.begin());
  std::printf("\n  TUM fr1/xyz frame 18: %zu measured pixels, %zu raycast, median |diff| %.2f mm, %.1f%% within %.0f mm",
              measured, diff.size(), 1e3f * med, 100.0 * double(within) / double(diff.size()), 1e3f * kVoxel);
  CHECK(diff.size() > measured * 8 / 10);  // the model covers what the frame sees
  CHECK(med < 0.25f * kVoxel);
  CHECK(within >= diff.size() * 9 / 10);
}
