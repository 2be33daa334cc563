// A small tracking rig for the tests: a rendered scene, a 64^3 space, static buffers for the raycast
// maps, the frame pyramid and the ICP row sums, and one call that runs the per-frame loop
// (raycast at the tracker's pose -> pyramid -> track -> integrate when pushed), as the firmware does.
// Setup (rendering, buffers) may allocate; run_frame() must not.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "edgefuse/tracking/icp.hpp"
#include "edgefuse/tracking/tracker.hpp"
#include "edgefuse/tsdf/integrate.hpp"
#include "edgefuse/tsdf/raycast.hpp"
#include "scenes.hpp"

namespace edgefuse_test {

constexpr int kRigW = 320, kRigH = 240;
constexpr int kRigDim = 64;
const edgefuse::Vec3f kRigCentre(0.0f, 0.0f, 0.82f);  //!< the space spans z 0.50 .. 1.14 m

inline edgefuse::PinholeIntrinsics rig_camera() {
  edgefuse::PinholeIntrinsics c;
  c.width = kRigW;
  c.height = kRigH;
  c.fx = c.fy = 500.0f;  // 35 x 27 degrees: the view stays inside the 64 cm space
  c.cx = 159.5f;
  c.cy = 119.5f;
  c.depth_scale = 10000.0f;  // 0.1 mm steps
  c.min_range_m = 0.1f;
  c.max_range_m = 3.0f;
  return c;
}

//! Static buffers of one rig (per numeric build).
template <class Real>
struct RigBuffers {
  static constexpr std::size_t kPyr = edgefuse::pyramid_pixels(kRigW, kRigH);
  static constexpr std::size_t kPix = std::size_t(kRigW) * kRigH;
  edgefuse::Point3<Real> pyr_vertex[kPyr];
  edgefuse::Point3<Real> pyr_normal[kPyr];
  alignas(8) unsigned char icp_rows[kRigH * edgefuse::kIcpRowBytes];
  float depth_m[kPix];
  Vec3f vertex[kPix], normal[kPix];
  uint16_t frame[kPix];
  VolumeStorage<kRigDim> storage;
  SensorBuffers<Real> sensor;
};

template <class Real>
struct Rig {
  edgefuse::PinholeIntrinsics cam = rig_camera();
  RigBuffers<Real>& buf;
  edgefuse::TsdfVolume volume;
  edgefuse::FramePyramid<Real> pyramid;
  edgefuse::IcpWorkspace<Real> ws;
  edgefuse::RaycastMaps maps;
  edgefuse::FrameScratch scratch;
  edgefuse::ImageView<const Real> norms;
  edgefuse::Tracker tracker;
  edgefuse::PyramidParams pyramid_params;
  const edgefuse::RowRunner* runner = nullptr;

  //! \param b static buffers  \param centre volume centre  \param voxel voxel size
  Rig(RigBuffers<Real>& b, const Vec3f& centre, float voxel) : buf(b) {
    using namespace edgefuse;
    volume.init(b.storage.view(false), kRigDim, centre - Vec3f::Constant(0.5f * kRigDim * voxel),
                TsdfParams::defaults_for(voxel, 4 * voxel));
    bind_pyramid<Real>(cam, b.pyr_vertex, b.pyr_normal, RigBuffers<Real>::kPyr, pyramid);
    ws = IcpWorkspace<Real>::bind(b.icp_rows, sizeof(b.icp_rows));
    maps.depth_m = ImageView<float>(b.depth_m, cam.width, cam.height);
    maps.vertex = ImageView<Vec3f>(b.vertex, cam.width, cam.height);
    maps.normal = ImageView<Vec3f>(b.normal, cam.width, cam.height);
    scratch = b.sensor.scratch();
    norms = b.sensor.ray_norms(cam);
  }

  //! One frame of the loop; the depth is copied into the static frame buffer first.
  edgefuse::Status run_frame(const std::vector<uint16_t>& depth, edgefuse::TrackResult& r) {
    using namespace edgefuse;
    for (std::size_t i = 0; i < depth.size(); ++i) buf.frame[i] = depth[i];
    const ImageView<const uint16_t> d(buf.frame, cam.width, cam.height);
    Status s = raycast<Real>(volume, cam, tracker.raycast_pose(), maps);
    if (s == Status::kOk) s = build_pyramid<Real>(d, pyramid_params, pyramid);
    if (s == Status::kOk) s = tracker.track<Real>(pyramid, maps, cam, ws, r, runner);
    if (s == Status::kOk && r.push) s = integrate<Real>(volume, cam, norms, DepthFrame{d, {}}, r.T_world_cam, scratch);
    return s;
  }
};

//! A box, a sphere and a second box in front of a concave corner of three planes (two walls in a V
//! and a floor rising towards the back, all seen at 30..50 degrees incidence), so every direction
//! is pinned down by large surfaces with long lever arms. Everything the camera sees beyond 0.5 m
//! lies inside a 64^3 space of 1 cm centred at kRigCentre.
inline Scene box_sphere_corner() {
  Scene s;
  edgefuse::Pose R;
  R.R = Eigen::AngleAxisf(0.5f, Vec3f(0.3f, 1.0f, 0.2f).normalized()).toRotationMatrix();
  s.add_box(Vec3f(-0.09f, 0.02f, 0.78f), Vec3f(0.06f, 0.05f, 0.04f), R);
  s.add_sphere(Vec3f(0.1f, -0.03f, 0.82f), 0.07f);
  edgefuse::Pose R2;
  R2.R = Eigen::AngleAxisf(-0.7f, Vec3f(0.1f, 0.4f, 1.0f).normalized()).toRotationMatrix();
  s.add_box(Vec3f(0.05f, 0.09f, 0.9f), Vec3f(0.04f, 0.03f, 0.04f), R2, {50, 50, 200});
  const Vec3f corner(0.0f, 0.05f, 1.02f);
  for (const Vec3f& n : {Vec3f(-0.5f, 0.0f, -0.866f), Vec3f(0.5f, 0.0f, -0.866f), Vec3f(0.0f, -0.6f, -0.8f)})
    s.add_plane(n, -n.normalized().dot(corner));
  return s;
}

//! A smooth camera path looking into box_sphere_corner(): ~4 mm and ~0.4 degrees per frame.
inline std::vector<edgefuse::Pose> known_motion(int frames) {
  std::vector<edgefuse::Pose> poses;
  for (int i = 0; i < frames; ++i) {
    const float s = float(i);
    const Vec3f eye(-0.02f + 0.003f * s, -0.01f + 0.0015f * s, 0.002f * s);
    const Vec3f target(0.03f * std::sin(s / 3.0f), 0.01f * s / float(frames), 0.8f);
    poses.push_back(look_at(eye, target, Vec3f(0.02f * std::sin(s / 5.0f), 1, 0)));
  }
  return poses;
}

//! Adds structured-light-like noise to a rendered depth image: gaussian with sigma = sigma_1m * z^2
//! (Box-Muller on a fixed LCG, so every platform draws the same numbers).
inline void add_depth_noise(std::vector<uint16_t>& depth, float depth_scale, float sigma_1m, uint32_t seed) {
  uint32_t state = seed * 2654435761u + 12345u;
  auto uniform = [&state]() {
    state = state * 1664525u + 1013904223u;
    return (float(state >> 8) + 0.5f) * (1.0f / 16777216.0f);
  };
  for (uint16_t& d : depth) {
    if (d == 0) continue;
    const float z = float(d) / depth_scale;
    const float g = std::sqrt(-2.0f * std::log(uniform())) * std::cos(6.2831853f * uniform());
    const float noisy = z + g * sigma_1m * z * z;
    d = uint16_t(std::lround(std::max(noisy, 0.0f) * depth_scale));
  }
}

//! Rotation angle between two poses in degrees and translation distance in metres.
inline void pose_error(const edgefuse::Pose& a, const edgefuse::Pose& b, float& dt_m, float& deg) {
  const Eigen::Quaternionf q(edgefuse::Mat3f(a.R.transpose() * b.R));
  deg = 2.0f * std::atan2(q.vec().norm(), std::fabs(q.w())) * 180.0f / float(M_PI);
  dt_m = (a.t - b.t).norm();
}

}  // namespace edgefuse_test
