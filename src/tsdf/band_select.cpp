// Step 1 of integration: the bricks a depth frame updates (integrate.hpp, select_band_bricks).
//
// A voxel is written only where eq. (1) gives d > -rho, and it carries information only in the
// truncation band or where it may undo a surface. So instead of every brick in the frustum (most of
// them free space in front of the surface, or behind it), the list holds
//   - the bricks around each pixel's measurement (kBrickBand): the region whose voxels take that
//     pixel as their nearest one (its image cell) between (lowest depth they may interpolate) -
//     trunc and (highest) + rho; the brick loop updates all their voxels, band and free alike;
//   - in front of that, the free margin (TsdfParams::free_margin_m, by default the larger of
//     2 trunc and kDefaultFreeMarginM): bricks
//     listed only there get their +1 samples where the frame sees them free with every pixel
//     valid (no voxel loop: none of their voxels is in the band). This keeps the space just in
//     front of surfaces observed, which the localiser's verification reads (measured: without it
//     a bracket hypothesis claimed a box's place on the tracked bin_rig_a map; volume.hpp);
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

#include "edgefuse/tsdf/frame_scratch.hpp"
#include "edgefuse/tsdf/integrate.hpp"
#include "frustum.hpp"

namespace edgefuse {
namespace {

struct BrickLister {
  TsdfVolume& volume;
  uint8_t* flags;
  uint32_t* list;
  std::size_t count;
  int nb;

  //! Lists brick (bx, by, bz) once, giving it a pool slot; `band` marks it kBrickBand (its voxels
  //! all go through the brick loop), else it stays margin-only unless some other region lists it
  //! as band. A full pool leaves the brick out (TsdfVolume::store_brick counts it); the last
  //! quarter of the pool is kept for band bricks, so that free margin (about two thirds of the
  //! bricks a frame lists on bin_rig_a) cannot crowd out surface.
  void add(int bx, int by, int bz, bool band) {
    const std::size_t b = (std::size_t(bz) * nb + std::size_t(by)) * nb + std::size_t(bx);
    if (!(flags[b] & kBrickListed)) {
      if (!band && !volume.brick_stored(b) && volume.bricks_in_use() >= margin_limit()) return;
      if (!volume.store_brick(b)) return;
      list[count++] = uint32_t(b);
    }
    flags[b] |= band ? uint8_t(kBrickListed | kBrickBand) : uint8_t(kBrickListed);
  }
  uint32_t margin_limit() const { return volume.pool_bricks() - volume.pool_bricks() / 4u; }
  //! Lists every brick of the box [lo, hi] (brick coordinates, clipped to the volume).
  void add_box(const int lo[3], const int hi[3], bool band) {
    int a[3], b[3];
    for (int k = 0; k < 3; ++k) {
      a[k] = lo[k] < 0 ? 0 : lo[k];
      b[k] = hi[k] >= nb ? nb - 1 : hi[k];
      if (a[k] > b[k]) return;
    }
    for (int z = a[2]; z <= b[2]; ++z)
      for (int y = a[1]; y <= b[1]; ++y)
        for (int x = a[0]; x <= b[0]; ++x) add(x, y, z, band);
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

// The frame's geometry in brick coordinates (brick units; camera-frame metres times R).
struct BandGeometry {
  Mat3f R;             //!< camera-frame metres -> brick units (world rotation / brick edge)
  Vec3f centre;        //!< sensor centre in brick coordinates
  float inv_fx, inv_fy, cx, cy;
  float inv_scale;     //!< raw depth -> metres
  float trunc_m;       //!< the band reaches this far in front of the lowest depth
  float margin_m;      //!< free margin listed in front of the band (margin-only bricks)
  float rho_m;         //!< the band reaches this far behind the highest depth
  float half_cell;     //!< half a pixel's diagonal in brick units per metre of z
  float z_min, z_max;  //!< pixels outside this z-depth range list nothing
  uint32_t jump_raw;   //!< the frame's depth jump in raw units
  uint32_t flat_raw;   //!< a tile whose depths span at most this is listed as one box

  //! Brick coordinates of the point at z-depth z_m on the ray through image point (u, v).
  Vec3f at(float u, float v, float z_m) const {
    return centre + R * Vec3f((u - cx) * inv_fx * z_m, (v - cy) * inv_fy * z_m, z_m);
  }
};

// Extends [lo, hi] by the brick coordinates of p.
inline void grow(Vec3f& lo, Vec3f& hi, const Vec3f& p) {
  lo = lo.cwiseMin(p);
  hi = hi.cwiseMax(p);
}

// Lists the bricks of the region between z-depths z0 and z1 (z0 <= z1) over the image rectangle
// [u0, u1] x [v0, v1], widened by `widen` brick units: the region is convex, so the bounding box
// of its corners holds it.
void list_chunk(BrickLister& out, const BandGeometry& g, float u0, float u1, float v0, float v1, float z0, float z1,
                float widen, bool band) {
  Vec3f lo = g.at(u0, v0, z0), hi = lo;
  for (const float z : {z0, z1})
    for (const float u : {u0, u1})
      for (const float v : {v0, v1}) grow(lo, hi, g.at(u, v, z));
  int box_lo[3], box_hi[3];
  for (int k = 0; k < 3; ++k) {
    box_lo[k] = int(std::floor(lo[k] - widen));
    box_hi[k] = int(std::floor(hi[k] + widen));
  }
  out.add_box(box_lo, box_hi, band);
}

// Lists the band (from the lowest depth lo_m minus trunc to the highest hi_m plus rho) and, in
// front of it, the free margin (margin-only) of the image rectangle [u0, u1] x [v0, v1].
void list_span(BrickLister& out, const BandGeometry& g, float u0, float u1, float v0, float v1, float lo_m, float hi_m,
               float widen_per_m) {
  const float band_near = std::fmax(lo_m - g.trunc_m, 0.0f), band_far = hi_m + g.rho_m;
  const float widen = widen_per_m * band_far;
  list_chunk(out, g, u0, u1, v0, v1, band_near, band_far, widen, true);
  const float margin_near = std::fmax(band_near - g.margin_m, 0.0f);
  if (margin_near < band_near) list_chunk(out, g, u0, u1, v0, v1, margin_near, band_near, widen, false);
}

// Lists the region of pixel (u, v) holding raw depth `raw`: its ray over the depths its voxels
// may read, widened by half a pixel.
void list_pixel(BrickLister& out, const BandGeometry& g, const ImageView<const uint16_t>& depth, int u, int v,
                uint32_t raw) {
  const float z = float(raw) * g.inv_scale;
  if (z < g.z_min || z > g.z_max) return;
  uint32_t lo, hi;
  neighbourhood_range(depth, u, v, raw, g.jump_raw, lo, hi);
  list_span(out, g, float(u), float(u), float(v), float(v), float(lo) * g.inv_scale, float(hi) * g.inv_scale,
            g.half_cell);
}

// Lists the region of the side x side tile at pixel (u0, v0) as one box when its valid depths (with the
// pixels around it that its voxels may interpolate from) span at most flat_raw; returns false
// otherwise (depth edges: pixel by pixel instead). Pixels without depth list nothing: a voxel
// whose nearest pixel has none is not updated. The box holds the image rectangle of the tile's
// pixels (half a pixel around them) over the depths its voxels may read.
bool list_flat_tile(BrickLister& out, const BandGeometry& g, const ImageView<const uint16_t>& depth, int u0, int v0,
                    int side) {
  const int u1 = u0 + side - 1, v1 = v0 + side - 1;
  if (u1 >= depth.width || v1 >= depth.height) return false;
  const int a0 = u0 > 0 ? u0 - 1 : 0, a1 = u1 + 1 < depth.width ? u1 + 1 : u1;
  const int b0 = v0 > 0 ? v0 - 1 : 0, b1 = v1 + 1 < depth.height ? v1 + 1 : v1;
  uint32_t lo = 0xffff, hi = 0;
  for (int y = b0; y <= b1; ++y) {
    const uint16_t* row = depth.row(y);
    for (int x = a0; x <= a1; ++x) {
      const uint32_t q = row[x];
      lo = q != 0 && q < lo ? q : lo;  // a pixel without depth is nobody's nearest valid pixel
      hi = q > hi ? q : hi;
    }
  }
  if (hi == 0) return true;  // nothing measured
  if (hi - lo > g.flat_raw) return false;
  const float near_lo = float(lo) * g.inv_scale, far_hi = float(hi) * g.inv_scale;
  if (near_lo < g.z_min || far_hi > g.z_max) return false;
  list_span(out, g, float(u0) - 0.5f, float(u1) + 0.5f, float(v0) - 0.5f, float(v1) + 0.5f, near_lo, far_hi, 0.0f);
  return true;
}

// Lists the bricks around every measured pixel (see the top of the file): 8x8 tiles on a smooth
// surface as one box each (most of a frame; the per-pixel boxes of a tile overlap the same few
// bricks), at depth edges 4x4 quarters, and the quarters that hold the edge pixel by pixel.
void list_band(BrickLister& out, const TsdfVolume& volume, const PinholeIntrinsics& intr, const DepthFrame& frame,
               const Pose& T_world_cam) {
  const TsdfParams& p = volume.params();
  const float jump_m = frame.jump_m > p.trunc_m ? frame.jump_m : p.trunc_m;
  const float brick_m = kBrickSide * p.voxel_m;
  BandGeometry g;
  g.R = T_world_cam.R * (1.0f / brick_m);
  g.centre = (T_world_cam.t - volume.origin_m()) * (1.0f / brick_m);
  g.inv_fx = 1.0f / intr.fx;
  g.inv_fy = 1.0f / intr.fy;
  g.cx = intr.cx;
  g.cy = intr.cy;
  g.inv_scale = 1.0f / intr.depth_scale;
  g.trunc_m = p.trunc_m;
  g.margin_m = p.free_margin_m > 0.0f ? p.free_margin_m : std::fmax(2.0f * p.trunc_m, kDefaultFreeMarginM);
  g.rho_m = p.weight.rho_m;
  g.half_cell = 0.71f / (intr.fx < intr.fy ? intr.fx : intr.fy) / brick_m;
  g.z_min = intr.min_range_m - jump_m;
  g.z_max = intr.max_range_m + jump_m;
  g.jump_raw = uint32_t(std::ceil(jump_m * intr.depth_scale));
  // A tile spanning up to a brick in depth: its box is at most about one brick deeper than its
  // pixels' boxes together.
  g.flat_raw = uint32_t(brick_m * intr.depth_scale);
  const ImageView<const uint16_t>& depth = frame.depth;
  constexpr int kTile = FrameScratch::kTile, kHalfTile = kTile / 2;
  for (int v0 = 0; v0 < intr.height; v0 += kTile)
    for (int u0 = 0; u0 < intr.width; u0 += kTile) {
      if (list_flat_tile(out, g, depth, u0, v0, kTile)) continue;
      // A depth edge or the image border: quarter tiles, then the pixels of those that still span one.
      for (int q = 0; q < 4; ++q) {
        const int qu = u0 + (q & 1) * kHalfTile, qv = v0 + (q >> 1) * kHalfTile;
        if (list_flat_tile(out, g, depth, qu, qv, kHalfTile)) continue;
        const int v_end = qv + kHalfTile < intr.height ? qv + kHalfTile : intr.height;
        const int u_end = qu + kHalfTile < intr.width ? qu + kHalfTile : intr.width;
        for (int v = qv; v < v_end; ++v) {
          const uint16_t* row = depth.row(v);
          for (int u = qu; u < u_end; ++u)
            if (row[u] != 0) list_pixel(out, g, depth, u, v, row[u]);
        }
      }
    }
}

// Lists the surface bricks inside the frustum that are not listed yet.
void list_surface(BrickLister& out, const TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam) {
  const BrickFrustum frustum(volume, intr, T_world_cam);
  const std::size_t bricks = volume.brick_count();
  for (std::size_t b = 0; b < bricks; ++b) {
    if ((out.flags[b] & (kBrickSurface | kBrickListed)) != kBrickSurface) continue;
    int bx, by, bz;
    volume.brick_coords(b, bx, by, bz);
    if (frustum.sees(bx, by, bz)) out.add(bx, by, bz, true);
  }
}

}  // namespace

std::size_t select_band_bricks(TsdfVolume& volume, const PinholeIntrinsics& intr, const DepthFrame& frame,
                               const Pose& T_world_cam) {
  if (!volume.initialised() || frame.depth.empty() || frame.depth.width != intr.width ||
      frame.depth.height != intr.height || intr.validate() != Status::kOk)
    return 0;
  BrickLister out{volume, volume.brick_flags(), volume.brick_list(), 0, volume.bricks_per_axis()};
  list_band(out, volume, intr, frame, T_world_cam);
  list_surface(out, volume, intr, T_world_cam);
  return out.count;
}

}  // namespace edgefuse
