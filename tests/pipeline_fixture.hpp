// Shared set-up of the pipeline tests (test_pipeline_*): the build board's static buffers carved
// once per binary, a small camera that every board's buffers hold (160x120: am335x holds 320x240),
// and the helpers that compare poses and depth maps. Include after the STL / edgefuse headers and
// scenes.hpp (this file includes CppUTest through test_support.hpp last).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "edgefuse/memory/arena.hpp"
#include "edgefuse/memory/memmap.hpp"
#include "edgefuse/pipeline/camera_slot.hpp"
#include "edgefuse/pipeline/view_centre.hpp"
#include "edgefuse/tsdf/volume.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

namespace pipeline_test {

using namespace edgefuse;

//! The build board's memory map, carved from its static arena on first use (as the programs do).
inline const CoreBuffers& board_buffers() {
  static CoreBuffers b;
  static bool carved = false;
  if (!carved) {
    CHECK(carve_memory(build_board(), static_arena(), static_arena_bytes(), b) == Status::kOk);
    carved = true;
  }
  return b;
}

//! 160x120, 35 x 27 degrees (fx = fy = 250: test_tracking_rig.hpp's field of view, so the views of
//! box_sphere_corner() fit a 64^3 space of 1 cm), 0.1 mm depth steps, 0.1-3 m.
inline PinholeIntrinsics small_camera() {
  PinholeIntrinsics c;
  c.width = 160;
  c.height = 120;
  c.fx = c.fy = 250.0f;
  c.cx = 79.5f;
  c.cy = 59.5f;
  c.depth_scale = 10000.0f;
  c.min_range_m = 0.1f;
  c.max_range_m = 3.0f;
  return c;
}

//! The pre-filters' spare image: the board's last sensor slot (no test binds it), as the CLI does.
inline ImageView<uint16_t> spare_image(int w, int h) {
  const CoreBuffers& b = board_buffers();
  return ImageView<uint16_t>(b.depth_frames + std::size_t(build_board().sensors_max - 1) * b.pixels_per_sensor, w, h);
}

//! The pipeline tests' space: 64^3 voxels of 1 cm (truncation 4 voxels) in the board's voxel buffer.
constexpr int kSpaceDim = 64;
constexpr float kSpaceVoxelM = 0.01f;

inline void init_space(TsdfVolume& volume, const Vec3f& origin) {
  CHECK(volume.init(board_buffers().voxels, kSpaceDim, origin, TsdfParams::defaults_for(kSpaceVoxelM, 4 * kSpaceVoxelM)) ==
        Status::kOk);
}

//! A structured-light camera in board slot `index`, without the bilateral filter: the rendered depth
//! is exact, so the map can be held to it.
inline void bind_camera(CameraSlot& slot, int index, const PinholeIntrinsics& cam) {
  const char* why = "";
  CHECK_TEXT(slot.bind(board_buffers(), build_board(), index, cam, DepthSensorKind::kStructuredLight, false, false,
                       &why) == Status::kOk,
             why);
}

inline SensorFrame sensor_frame(const std::vector<uint16_t>& depth, const PinholeIntrinsics& cam, uint64_t stamp_us) {
  SensorFrame s;
  s.depth = ImageView<const uint16_t>(depth.data(), cam.width, cam.height);
  s.stamp_us = stamp_us;
  return s;
}

//! view_centre() scratch for images up to 160x120.
struct CentreScratch {
  static constexpr std::size_t kN = std::size_t(160 / 2 + 1) * (120 / 2 + 1);
  float xs[kN], ys[kN], zs[kN];
  ViewCentreScratch view() { return ViewCentreScratch{xs, ys, zs, kN}; }
};

//! Rotation angle between two poses in degrees and translation distance in metres.
inline void pose_distance(const Pose& a, const Pose& b, float& dt_m, float& deg) {
  // acos of the trace loses precision near 1 in float: the quaternion form, as the tracking tests.
  const Eigen::Quaternionf q(Mat3f(a.R.transpose() * b.R));
  deg = 2.0f * std::atan2(q.vec().norm(), std::fabs(q.w())) * 57.2957795f;
  dt_m = (a.t - b.t).norm();
}

//! Depth agreement of a raycast map with a rendered image, over the pixels whose rendered surface
//! lies inside the space by at least `margin_m` (the raycast sees nothing beyond the space).
struct DepthAgreement {
  std::size_t both = 0;           //!< such pixels with a raycast depth too
  std::size_t rendered = 0;       //!< such pixels (with a rendered depth inside the space)
  float median_abs_m = 0;         //!< median |raycast - rendered|
  float p90_abs_m = 0;            //!< 90th percentile
  float mean_signed_m = 0;        //!< mean raycast - rendered (a misplaced frame biases it)
};

inline DepthAgreement compare_depth(const ImageView<float>& raycast, const std::vector<uint16_t>& rendered,
                                    const PinholeIntrinsics& cam, const Pose& T_world_cam, const TsdfVolume& volume,
                                    float margin_m) {
  const Vec3f lo = volume.origin_m() + Vec3f::Constant(margin_m);
  const Vec3f hi = volume.origin_m() + Vec3f::Constant(float(volume.dim()) * volume.voxel_m() - margin_m);
  DepthAgreement a;
  std::vector<float> abs_err;
  double sum = 0;
  for (int v = 0; v < raycast.height; ++v)
    for (int u = 0; u < raycast.width; ++u) {
      const uint16_t r = rendered[std::size_t(v) * raycast.width + u];
      if (r == 0) continue;
      const Vec3f p = T_world_cam * cam.back_project(float(u), float(v), float(r) / cam.depth_scale);
      if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) continue;
      ++a.rendered;
      const float d = raycast.at(u, v);
      if (!(d > 0)) continue;
      const float e = d - float(r) / cam.depth_scale;
      abs_err.push_back(std::fabs(e));
      sum += e;
    }
  a.both = abs_err.size();
  if (a.both == 0) return a;
  std::sort(abs_err.begin(), abs_err.end());
  a.median_abs_m = abs_err[a.both / 2];
  a.p90_abs_m = abs_err[a.both * 9 / 10];
  a.mean_signed_m = float(sum / double(a.both));
  return a;
}

}  // namespace pipeline_test
