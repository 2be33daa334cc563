// Per-pixel near bound of the raycast: the z-depth at which each pixel's ray first enters the box
// of a surface brick (the cells that can hold a crossing, see prepare_raycast). The 8x8 tiles'
// near bound is the nearest corner of every box over 64 pixels: on bin_rig_a a hit ray started
// 19 voxels before its surface; from its own entry it starts 10 voxels before it, and a ray that
// meets no box is not marched at all.
//
// No extra memory: prepare_raycast keeps the bound in the depth map the raycast is about to write
// (each pixel's own ray reads it before it writes its depth). Private to src/.
#pragma once

#include "edgefuse/core/image.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/sensor/pinhole.hpp"

namespace edgefuse {
namespace pixel_bounds {

//! The bound of a pixel whose ray meets no box.
inline constexpr float kNoBox = 1e30f;

//! Sets every pixel of `depth` to kNoBox.
inline void clear(const ImageView<float>& depth) {
  for (int v = 0; v < depth.height; ++v) {
    float* row = depth.row(v);
    for (int u = 0; u < depth.width; ++u) row[u] = kNoBox;
  }
}

//! Lowers the bound of pixels [u0, u1] x [v0, v1] to the z-depth where their rays enter the world
//! box [lo, hi] (rays x = c + z R (rx, ry, 1), z >= 0 the z-depth). Branch-free float code over
//! contiguous pixels, so that the compiler vectorises it (the splat runs ~2 boxes per pixel).
//! \param depth the bounds (the raycast's depth map)
//! \param intr sensor intrinsics (ray of each pixel)
//! \param T_world_cam sensor pose
//! \param lo box corner with the smallest coordinates (world, metres)
//! \param hi box corner with the largest coordinates
//! \param u0 first pixel column  \param u1 last pixel column
//! \param v0 first pixel row  \param v1 last pixel row
inline void add_box(const ImageView<float>& depth, const PinholeIntrinsics& intr, const Pose& T_world_cam,
                    const Vec3f& lo, const Vec3f& hi, int u0, int u1, int v0, int v1) {
  // Box faces relative to the sensor centre, and the ray's change per pixel column.
  const float lo_c[3] = {lo.x() - T_world_cam.t.x(), lo.y() - T_world_cam.t.y(), lo.z() - T_world_cam.t.z()};
  const float hi_c[3] = {hi.x() - T_world_cam.t.x(), hi.y() - T_world_cam.t.y(), hi.z() - T_world_cam.t.z()};
  const Vec3f du = T_world_cam.R.col(0) / intr.fx;
  for (int v = v0; v <= v1; ++v) {
    const float ry = (float(v) - intr.cy) / intr.fy;
    const Vec3f d0 = T_world_cam.R * Vec3f((float(u0) - intr.cx) / intr.fx, ry, 1.0f);
    float* row = depth.row(v);
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
      float z_in = 0.0f, z_out = kNoBox;
      for (int a = 0; a < 3; ++a) {
        const float t1 = lo_c[a] * inv[a], t2 = hi_c[a] * inv[a];
        const float t_lo = t1 < t2 ? t1 : t2, t_hi = t1 < t2 ? t2 : t1;
        z_in = t_lo > z_in ? t_lo : z_in;
        z_out = t_hi < z_out ? t_hi : z_out;
      }
      const float entry = z_in <= z_out ? z_in : kNoBox;
      row[u] = entry < row[u] ? entry : row[u];
    }
  }
}

}  // namespace pixel_bounds
}  // namespace edgefuse
