// Step 1 of integration: the bricks a depth frame updates (integrate.hpp, select_band_bricks).
//
// A voxel is written only where eq. (1) gives d > -rho, and it carries information only in the
// truncation band or where it may undo a surface. So instead of every brick in the frustum (most of
// them free space in front of the surface, or behind it), the list holds
//   - the bricks around each pixel's measurement: the region whose voxels take that pixel as their
//     nearest one (its image cell) between (lowest depth they may interpolate) - trunc - free
//     margin and (highest) + rho; the brick loop then updates their voxels, band and free alike.
//     The free margin (TsdfParams::free_margin_m, 2 trunc by default) keeps the space just in
//     front of surfaces observed, which the localiser's verification reads (measured on bin_rig_a
//     with tracked poses: without it a bracket hypothesis claimed a box's place);
//   - every brick holding surface (kBrickSurface) inside the frustum, so that a surface the
//     camera now sees through is carved (a removed object leaves the map).
// Free space away from both stays as it was; VoxelBlockGrid integrates the same band (without the
// carving).
//
// The region is bounded conservatively, so no band voxel is missed: the depth a voxel reads is
// interpolated from the 2x2 pixels around its projection, which include its nearest pixel and lie
// within the frame's depth jump of it (integrate.cpp depth_at), hence within the 3x3 pixels around
// the nearest one; |ray| >= 1 shrinks trunc and rho along z; a voxel whose nearest pixel is (u, v)
// projects within half a pixel of it, at most 0.71 z / f from the pixel's ray.
#include <cmath>

#include "edgefuse/tsdf/integrate.hpp"
#include "frustum.hpp"

namespace edgefuse {
namespace {

struct BrickLister {
  uint8_t* flags;
  uint32_t* list;
  std::size_t count;
  int nb;

  void add(int bx, int by, int bz) {
    const std::size_t b = (std::size_t(bz) * nb + std::size_t(by)) * nb + std::size_t(bx);
    if (flags[b] & kBrickListed) return;
    flags[b] |= kBrickListed;
    list[count++] = uint32_t(b);
  }
  //! Lists every brick of the box [lo, hi] (brick coordinates, clipped to the volume).
  void add_box(const int lo[3], const int hi[3]) {
    int a[3], b[3];
    for (int k = 0; k < 3; ++k) {
      a[k] = lo[k] < 0 ? 0 : lo[k];
      b[k] = hi[k] >= nb ? nb - 1 : hi[k];
      if (a[k] > b[k]) return;
    }
    for (int z = a[2]; z <= b[2]; ++z)
      for (int y = a[1]; y <= b[1]; ++y)
        for (int x = a[0]; x <= b[0]; ++x) add(x, y, z);
  }
};

// Lowest and highest raw depth among the 3x3 pixels around (u, v) within `jump_raw` of its own
// `raw` (the depths a voxel whose nearest pixel is (u, v) may interpolate).
inline void neighbourhood_range(const ImageView<const uint16_t>& depth, int u, int v, uint32_t raw, uint32_t jump_raw,
                                uint32_t& lo, uint32_t& hi) {
  lo = raw;
  hi = raw;
  const int u0 = u > 0 ? u - 1 : 0, u1 = u + 1 < depth.width ? u + 1 : u;
  const int v0 = v > 0 ? v - 1 : 0, v1 = v + 1 < depth.height ? v + 1 : v;
  for (int y = v0; y <= v1; ++y) {
    const uint16_t* row = depth.row(y);
    for (int x = u0; x <= u1; ++x) {
      const uint32_t q = row[x];
      if (q == 0 || q + jump_raw < raw || q > raw + jump_raw) continue;
      lo = q < lo ? q : lo;
      hi = q > hi ? q : hi;
    }
  }
}

// Lists the bricks around every measured pixel (see the top of the file).
void list_band(BrickLister& out, const TsdfVolume& volume, const PinholeIntrinsics& intr, const DepthFrame& frame,
               const Pose& T_world_cam) {
  const TsdfParams& p = volume.params();
  const float inv_scale = 1.0f / intr.depth_scale;
  const float jump_m = frame.jump_m > p.trunc_m ? frame.jump_m : p.trunc_m;
  const uint32_t jump_raw = uint32_t(std::ceil(jump_m * intr.depth_scale));
  const float inv_brick = 1.0f / (kBrickSide * p.voxel_m);
  const float front_m = p.trunc_m + (p.free_margin_m > 0.0f ? p.free_margin_m : 2.0f * p.trunc_m);
  // Camera-frame metres -> brick coordinates.
  const Mat3f R = T_world_cam.R * inv_brick;
  const Vec3f centre = (T_world_cam.t - volume.origin_m()) * inv_brick;
  const float half_cell = 0.71f / (intr.fx < intr.fy ? intr.fx : intr.fy) * inv_brick;  // per metre of z
  const float z_min = intr.min_range_m - jump_m, z_max = intr.max_range_m + jump_m;
  int last_lo[3] = {1, 1, 1}, last_hi[3] = {0, 0, 0};  // the box listed last (consecutive pixels repeat it)
  for (int v = 0; v < intr.height; ++v) {
    const uint16_t* row = frame.depth.row(v);
    const Vec3f ray_v = R * Vec3f(-intr.cx / intr.fx, (float(v) - intr.cy) / intr.fy, 1.0f);
    const Vec3f ray_du = R.col(0) * (1.0f / intr.fx);
    for (int u = 0; u < intr.width; ++u) {
      const uint32_t raw = row[u];
      if (raw == 0) continue;
      const float z = float(raw) * inv_scale;
      if (z < z_min || z > z_max) continue;
      uint32_t lo, hi;
      neighbourhood_range(frame.depth, u, v, raw, jump_raw, lo, hi);
      float z_near = float(lo) * inv_scale - front_m;
      const float z_far = float(hi) * inv_scale + p.weight.rho_m;
      z_near = z_near > 0.0f ? z_near : 0.0f;
      const Vec3f ray = ray_v + ray_du * float(u);  // brick units per metre of z
      const Vec3f a = centre + ray * z_near, b = centre + ray * z_far;
      const float margin = half_cell * z_far;
      int box_lo[3], box_hi[3];
      for (int k = 0; k < 3; ++k) {
        box_lo[k] = int(std::floor((a[k] < b[k] ? a[k] : b[k]) - margin));
        box_hi[k] = int(std::floor((a[k] > b[k] ? a[k] : b[k]) + margin));
      }
      if (box_lo[0] == last_lo[0] && box_lo[1] == last_lo[1] && box_lo[2] == last_lo[2] &&
          box_hi[0] == last_hi[0] && box_hi[1] == last_hi[1] && box_hi[2] == last_hi[2])
        continue;
      out.add_box(box_lo, box_hi);
      for (int k = 0; k < 3; ++k) {
        last_lo[k] = box_lo[k];
        last_hi[k] = box_hi[k];
      }
    }
  }
}

// Lists the surface bricks inside the frustum that are not listed yet.
void list_surface(BrickLister& out, const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam) {
  const Pose T_cam_world = T_world_cam.inverse();
  const float vs = volume.voxel_m();
  const float radius = 0.5f * std::sqrt(3.0f) * kBrickSide * vs;
  const float far_z = intr.max_range_m + volume.params().trunc_m;
  const FrustumPlanes planes = frustum_planes(intr);
  const Vec3f half = Vec3f::Constant(0.5f * kBrickSide * vs);
  const std::size_t bricks = volume.brick_count();
  for (std::size_t b = 0; b < bricks; ++b) {
    if ((out.flags[b] & (kBrickSurface | kBrickListed)) != kBrickSurface) continue;
    int bx, by, bz;
    volume.brick_coords(b, bx, by, bz);
    const Vec3f c = T_cam_world * (volume.origin_m() + Vec3f(float(bx), float(by), float(bz)) * (kBrickSide * vs) + half);
    if (!planes.may_see(c, radius, far_z)) continue;
    out.add(bx, by, bz);
  }
}

}  // namespace

std::size_t select_band_bricks(TsdfVolume& volume, const PinholeIntrinsics& intr, const DepthFrame& frame,
                               const Pose& T_world_cam) {
  if (!volume.initialised() || frame.depth.empty() || frame.depth.width != intr.width ||
      frame.depth.height != intr.height || intr.validate() != Status::kOk)
    return 0;
  BrickLister out{volume.brick_flags(), volume.brick_list(), 0, volume.bricks_per_axis()};
  list_band(out, volume, intr, frame, T_world_cam);
  list_surface(out, volume, intr, T_world_cam);
  return out.count;
}

}  // namespace edgefuse
