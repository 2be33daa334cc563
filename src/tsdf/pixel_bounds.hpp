// Per-pixel z-depth bounds of the raycast: the range in which each pixel's ray passes through
// the boxes of the surface bricks (the blocks that can hold a crossing, see prepare_raycast).
// The 8x8 tiles' bounds take the nearest and farthest corner of every box over 64 pixels: on
// bin_rig_a a hit ray started 19 voxels before its surface and a missing ray marched 35 voxels.
// The exact entry and exit of each pixel's ray into each box are far tighter.
//
// No extra memory: prepare_raycast keeps the bounds in the depth map the raycast is about to
// write (two uint16 in each float's 4 bytes, read by the pixel's own ray before it writes its
// depth). Private to src/.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <utility>

#include "edgefuse/core/image.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/sensor/pinhole.hpp"

namespace edgefuse {
namespace pixel_bounds {

// A pixel's bounds: z-depths near_q * unit_m .. far_q * unit_m, rounded outward; near_q > far_q
// when no box lies on the ray.
struct Packed {
  uint16_t near_q, far_q;
};

inline Packed load(const float& slot) {
  uint32_t w;
  std::memcpy(&w, &slot, sizeof w);
  return Packed{uint16_t(w & 0xffffu), uint16_t(w >> 16)};
}
inline void store(float& slot, Packed p) {
  const uint32_t w = uint32_t(p.near_q) | (uint32_t(p.far_q) << 16);
  std::memcpy(&slot, &w, sizeof w);
}
inline constexpr Packed kNone{0xffffu, 0u};

//! The quantum of the bounds: the sensor's range in 65,000 steps (0.15 mm at 10 m).
inline float unit_m(const PinholeIntrinsics& intr) { return intr.max_range_m / 65000.0f; }

//! Sets every pixel of `depth` to "no box".
inline void clear(const ImageView<float>& depth) {
  for (int v = 0; v < depth.height; ++v) {
    float* row = depth.row(v);
    for (int u = 0; u < depth.width; ++u) store(row[u], kNone);
  }
}

//! Widens the bounds of pixels [u0, u1] x [v0, v1] by the z range in which their rays cross
//! the world box [lo, hi]. Rays are x = c + z R (rx, ry, 1) with z the z-depth.
//! \param depth the bounds (the raycast's depth map)
//! \param intr sensor intrinsics (ray of each pixel, quantum)
//! \param T_world_cam sensor pose
//! \param lo box corner with the smallest coordinates (world, metres)
//! \param hi box corner with the largest coordinates
//! \param u0 first pixel column  \param u1 last pixel column
//! \param v0 first pixel row  \param v1 last pixel row
inline void add_box(const ImageView<float>& depth, const PinholeIntrinsics& intr, const Pose& T_world_cam,
                    const Vec3f& lo, const Vec3f& hi, int u0, int u1, int v0, int v1) {
  const float inv_unit = 1.0f / unit_m(intr);
  const float z_cap = 65000.0f * unit_m(intr);  // the sensor's range: a larger z is clipped anyway
  // Box faces relative to the sensor centre, and the ray's change per pixel column.
  const float lo_c[3] = {lo.x() - T_world_cam.t.x(), lo.y() - T_world_cam.t.y(), lo.z() - T_world_cam.t.z()};
  const float hi_c[3] = {hi.x() - T_world_cam.t.x(), hi.y() - T_world_cam.t.y(), hi.z() - T_world_cam.t.z()};
  const Vec3f du = T_world_cam.R.col(0) / intr.fx;
  for (int v = v0; v <= v1; ++v) {
    const float ry = (float(v) - intr.cy) / intr.fy;
    const Vec3f d0 = T_world_cam.R * Vec3f((float(u0) - intr.cx) / intr.fx, ry, 1.0f);
    float* row = depth.row(v);
    // Branch-free so that the compiler can vectorise it over the row's pixels.
    for (int u = u0; u <= u1; ++u) {
      const float k = float(u - u0);
      float dd[3] = {d0.x() + k * du.x(), d0.y() + k * du.y(), d0.z() + k * du.z()};
      // One division for the three reciprocals. A ray (nearly) parallel to an axis gets a tiny
      // component of the right sign: its slab on that axis then spans every z or none.
      for (int a = 0; a < 3; ++a) {
        const float tiny = dd[a] < 0.0f ? -1e-6f : 1e-6f;
        dd[a] = (dd[a] < 1e-6f && dd[a] > -1e-6f) ? tiny : dd[a];
      }
      const float r = 1.0f / (dd[0] * dd[1] * dd[2]);
      const float inv[3] = {dd[1] * dd[2] * r, dd[0] * dd[2] * r, dd[0] * dd[1] * r};
      float z_in = 0.0f, z_out = z_cap;
      for (int a = 0; a < 3; ++a) {
        const float t1 = lo_c[a] * inv[a], t2 = hi_c[a] * inv[a];
        const float t_lo = t1 < t2 ? t1 : t2, t_hi = t1 < t2 ? t2 : t1;
        z_in = t_lo > z_in ? t_lo : z_in;
        z_out = t_hi < z_out ? t_hi : z_out;
      }
      // 0 <= z_in, z_out <= z_cap: truncation is floor; a quantum of slack each way covers the
      // rounding of the arithmetic above. A ray that misses the box leaves the pixel unchanged.
      const bool hit = z_in <= z_out;
      const int qn = int(z_in * inv_unit) - 1, qf = int((z_out > 0.0f ? z_out : 0.0f) * inv_unit) + 2;
      const uint32_t near_q = hit ? uint32_t(qn < 0 ? 0 : qn) : 0xffffu;
      const uint32_t far_q = hit ? uint32_t(qf > 65535 ? 65535 : qf) : 0u;
      uint32_t w;
      std::memcpy(&w, &row[u], sizeof w);
      const uint32_t old_near = w & 0xffffu, old_far = w >> 16;
      w = (near_q < old_near ? near_q : old_near) | ((far_q > old_far ? far_q : old_far) << 16);
      std::memcpy(&row[u], &w, sizeof w);
    }
  }
}

}  // namespace pixel_bounds
}  // namespace edgefuse
