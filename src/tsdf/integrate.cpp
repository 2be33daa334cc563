#include "edgefuse/tsdf/integrate.hpp"

#include <cmath>

#include "kernel_math.hpp"
#include "block_mask.hpp"
#include "frustum.hpp"
#include "row_projection.hpp"
#include "voxel_update.hpp"

namespace edgefuse {
namespace {

using voxel_update::blend;
using voxel_update::cap_weight;

inline uint32_t min4(uint32_t a, uint32_t b, uint32_t c, uint32_t d) {
  const uint32_t ab = a < b ? a : b, cd = c < d ? c : d;
  return ab < cd ? ab : cd;
}
inline uint32_t max4(uint32_t a, uint32_t b, uint32_t c, uint32_t d) {
  const uint32_t ab = a > b ? a : b, cd = c > d ? c : d;
  return ab > cd ? ab : cd;
}

// round_int without a branch on the sign (float): the sign of a voxel's distance flips across
// the surface band from voxel to voxel, and GCC compiled round_int's select as a branch on it
// (callgrind's branch simulation: 2.7 % fewer mispredicts in the voxel loop without it).
// v + 0.5 truncated for v >= 0 and v - 0.5 truncated for v < 0 equal round_int's int(v + 0.5)
// and -int(0.5 - v) (-0 takes +0.5 in both: int(-0.5) = 0). Fixed point: round_int.
inline int32_t round_select(float v) { return int32_t(v + std::copysign(0.5f, v)); }
inline int32_t round_select(Fixed v) { return round_int(v); }

// What depth_at reads, held in locals of the voxel loop (the voxel stores through uint8_t
// pointers may alias the job, whose members would be reloaded after every store).
template <class Real>
struct DepthLookup {
  const uint16_t* px;         // depth pixels
  std::ptrdiff_t stride;      // row stride in pixels
  uint32_t last_u, last_v;    // width - 1, height - 1: the 2x2 pixels from (u0, v0) fit when u0 < last_u
  uint32_t jump_raw;          // largest raw step interpolated across
  DepthScale<Real> scale;
};

// Measured z-depth at the projection (pu, pv) of a voxel whose nearest pixel holds the raw depth
// `nearest`; (u0, v0) = (floor(pu), floor(pv)), at index `win` in the image.
// Bilinear over the 4 surrounding pixels when all are valid and within a depth jump of each other;
// the nearest pixel when some are missing (or at the border); false at a discontinuity or no data.
template <class Real>
inline bool depth_at(const DepthLookup<Real>& dl, Real pu, Real pv, int u0, int v0, std::ptrdiff_t win,
                     uint32_t nearest, Real& z) {
  if (uint32_t(u0) < dl.last_u && uint32_t(v0) < dl.last_v) {
    // (u0, v0) is the nearest pixel or its neighbour to the left / above.
    const uint16_t* r0 = dl.px + win;
    const uint16_t* r1 = r0 + dl.stride;
    const uint32_t q[4] = {r0[0], r0[1], r1[0], r1[1]};
    // Min / max without branches: 0 (no depth) is the smallest raw value, so min(q) != 0 says all
    // four are valid; only then is the bilinear test decided (the common case). The valid minimum
    // for the jump test below replaces missing pixels by the largest raw value.
    const uint32_t hi = max4(q[0], q[1], q[2], q[3]);
    const uint32_t lo_all = min4(q[0], q[1], q[2], q[3]);
    if (lo_all != 0 && hi - lo_all <= dl.jump_raw) {
      const Real a = dl.scale.metres(uint16_t(q[0])), b = dl.scale.metres(uint16_t(q[1]));
      const Real c = dl.scale.metres(uint16_t(q[2])), e = dl.scale.metres(uint16_t(q[3]));
      const Real fu = pu - real_from_int<Real>(u0), fv = pv - real_from_int<Real>(v0);
      const Real top = a + (b - a) * fu, bottom = c + (e - c) * fu;
      z = top + (bottom - top) * fv;
      return true;
    }
    if (nearest == 0) return false;
    // The nearest pixel is one of the four, so at least one is valid here.
    const uint32_t lo = lo_all != 0 ? lo_all
                                    : min4(q[0] ? q[0] : 0xffffu, q[1] ? q[1] : 0xffffu, q[2] ? q[2] : 0xffffu,
                                           q[3] ? q[3] : 0xffffu);
    if (hi > nearest + dl.jump_raw || nearest > lo + dl.jump_raw) return false;
  } else if (nearest == 0) {
    return false;
  }
  z = dl.scale.metres(uint16_t(nearest));
  return true;
}

// Folds the valid raw depths of row[u0..u1] into [lo, hi]; an invalid pixel (0) clears `all`.
inline void fold_depth_row(const uint16_t* row, int u0, int u1, uint32_t& lo, uint32_t& hi, bool& all) {
  for (int u = u0; u <= u1; ++u) {
    const uint32_t x = row[u];
    if (x == 0) {
      all = false;
      continue;
    }
    lo = x < lo ? x : lo;
    hi = x > hi ? x : hi;
  }
}

// Min / max valid raw depth per 8x8 tile.
void build_depth_tiles(const ImageView<const uint16_t>& depth, const DepthScale<float>& scale, DepthTile* tiles) {
  const int tx = FrameScratch::tiles_x(depth.width), ty = FrameScratch::tiles_y(depth.height);
  for (int j = 0; j < ty; ++j)
    for (int i = 0; i < tx; ++i) {
      uint32_t lo = 0xffff, hi = 0;
      bool all = true;
      const int v_end = (j + 1) * FrameScratch::kTile < depth.height ? (j + 1) * FrameScratch::kTile : depth.height;
      const int u_end = (i + 1) * FrameScratch::kTile < depth.width ? (i + 1) * FrameScratch::kTile : depth.width;
      for (int v = j * FrameScratch::kTile; v < v_end; ++v)
        fold_depth_row(depth.row(v), i * FrameScratch::kTile, u_end - 1, lo, hi, all);
      DepthTile& t = tiles[std::size_t(j) * tx + i];
      t.min_raw = hi == 0 ? 0 : uint16_t(lo);
      t.max_raw = uint16_t(hi);
      t.all_valid = all ? 1 : 0;
    }
  for (int j = 0; j + 1 < ty; ++j)
    for (int i = 0; i + 1 < tx; ++i) {
      DepthTile& t = tiles[std::size_t(j) * tx + i];
      const DepthTile* quad[4] = {&t, &t + 1, &t + tx, &t + tx + 1};
      uint32_t lo = 0xffff, hi = 0;
      bool all = true;
      for (const DepthTile* n : quad) {
        all = all && n->all_valid;
        if (n->max_raw == 0) continue;
        lo = n->min_raw < lo ? n->min_raw : lo;
        hi = n->max_raw > hi ? n->max_raw : hi;
      }
      t.min_raw2 = hi == 0 ? 0 : uint16_t(lo);
      t.max_raw2 = uint16_t(hi);
      t.all_valid2 = all ? 1 : 0;
    }
  // Neighbourhood minimum: the 2x2 pixels a voxel interpolates from lie within the 3x3 tiles
  // around the tile of its nearest pixel.
  for (int j = 0; j < ty; ++j)
    for (int i = 0; i < tx; ++i) {
      uint32_t lo = 0xffff;
      for (int b = j - 1; b <= j + 1; ++b)
        for (int a = i - 1; a <= i + 1; ++a)
          if (a >= 0 && b >= 0 && a < tx && b < ty) {
            const DepthTile& n = tiles[std::size_t(b) * tx + a];
            if (n.max_raw != 0 && n.min_raw < lo) lo = n.min_raw;
          }
      DepthTile& t = tiles[std::size_t(j) * tx + i];
      t.near_raw = lo == 0xffff ? 0 : uint16_t(lo);
      t.near_m = scale.metres(t.near_raw);
    }
}

enum class BrickClass { kSkip, kFreeSpace, kVoxels };

constexpr int kHalf = kBrickSide / 2;  // edge of the blocks a mixed brick is split into
// Boxes whose footprint (with the bilinear margin) has at most this many pixels are classified
// from the pixels themselves, larger ones from the 8x8 depth tiles.
constexpr int kExactFootprintPixels = 144;

// Every voxel of the cube of `side` voxels starting at local index `first` of the brick at `base`
// is seen at d >= trunc: a full-weight +1 sample, no projection needed.
inline void free_space_update(int16_t* tsdf, uint8_t* weight, std::size_t base, int first, int side,
                              uint8_t max_weight, int32_t full_weight, bool& surface) {
  for (int lz = 0; lz < side; ++lz)
    for (int ly = 0; ly < side; ++ly)
      for (int lx = 0; lx < side; ++lx) {
        const std::size_t idx = base + std::size_t(first + (lz << 6) + (ly << 3) + lx);
        const int32_t old_w = weight[idx];
        if (old_w == max_weight && tsdf[idx] == kTsdfMax) continue;
        const int32_t value = old_w == 0 ? kTsdfMax : blend(tsdf[idx], old_w, kTsdfMax, full_weight);
        tsdf[idx] = int16_t(value);
        weight[idx] = cap_weight(old_w + full_weight, max_weight);
        surface |= value < kTsdfMax;  // no branch on it
      }
}

// Classifies a box of voxels (a brick or a part of one) from its 8 corner voxel centres (camera
// frame: c0 plus any sum of the span vectors) against the depth tiles.
template <class Real>
BrickClass classify_box(const IntegrationJob<Real>& job, const LaneCamera<Real>& cam, const Real c0[3],
                        const Real span[3][3], Real near_z, bool stop_early) {
  BoxBounds<Real> box;
  if (!project_box(cam, c0, span, near_z, box)) return BrickClass::kVoxels;  // straddles the sensor plane: no bound
  const Real z_lo = box.z_lo, z_hi = box.z_hi;
  // Pixels a voxel of the brick may read (bilinear reaches one pixel further).
  int a0 = box.a0, a1 = box.a1, b0 = box.b0, b1 = box.b1;
  if (a1 < 0 || b1 < 0 || a0 >= job.width || b0 >= job.height) return BrickClass::kSkip;
  const bool inside = a0 >= 0 && b0 >= 0 && a1 < job.width && b1 < job.height;
  a0 = a0 < 0 ? 0 : a0;
  b0 = b0 < 0 ? 0 : b0;
  a1 = a1 >= job.width ? job.width - 1 : a1;
  b1 = b1 >= job.height ? job.height - 1 : b1;
  uint32_t lo = 0xffff, hi = 0;
  bool all = inside;
  if ((a1 - a0 + 1) * (b1 - b0 + 1) <= kExactFootprintPixels) {
    // A small footprint (a 4^3 block covers ~5x5 pixels at 2 mm and 0.7 m): its own pixels bound
    // it much more tightly than the 8x8 tiles around it, which often hold an invalid pixel or a
    // depth edge and would leave the block to the voxel loop.
    for (int v = b0; v <= b1; ++v) {
      fold_depth_row(job.frame.depth.row(v), a0, a1, lo, hi, all);
      // A brick's footprint: once the rows read so far rule out both the skip and free space
      // (below; hi only grows and lo only falls), so does the whole footprint, and the brick goes
      // to its blocks. Not for the blocks themselves: most of them are decided by a full scan,
      // and the per-row test would only add to it.
      if (stop_early && hi != 0) {
        const Real z_meas_lo = job.depth.metres(uint16_t(lo)), z_meas_hi = job.depth.metres(uint16_t(hi));
        if (!(z_lo - z_meas_hi > job.rho) &&
            !(z_meas_lo - z_hi > job.trunc && z_meas_lo >= job.min_z && z_meas_hi <= job.max_z))
          return BrickClass::kVoxels;
      }
    }
  } else {
    const int i0 = a0 / FrameScratch::kTile, i1 = a1 / FrameScratch::kTile;
    const int j0 = b0 / FrameScratch::kTile, j1 = b1 / FrameScratch::kTile;
    if (i1 > i0 && j1 > j0) {
      // 2x2-tile windows from i0 in steps of 2, the last one moved back to end at i1 (likewise
      // for j): the same tiles as the loop below, some read twice.
      for (int j = j0;; j += 2) {
        const int jj = j < j1 ? j : j1 - 1;
        for (int i = i0;; i += 2) {
          const int ii = i < i1 ? i : i1 - 1;
          const DepthTile& t = job.tiles[std::size_t(jj) * job.tiles_x + ii];
          all = all && t.all_valid2;
          if (t.max_raw2 != 0) {
            lo = t.min_raw2 < lo ? t.min_raw2 : lo;
            hi = t.max_raw2 > hi ? t.max_raw2 : hi;
          }
          if (ii + 1 >= i1) break;
        }
        if (jj + 1 >= j1) break;
      }
    } else {
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
          const DepthTile& t = job.tiles[std::size_t(j) * job.tiles_x + i];
          all = all && t.all_valid;
          if (t.max_raw == 0) continue;
          lo = t.min_raw < lo ? t.min_raw : lo;
          hi = t.max_raw > hi ? t.max_raw : hi;
        }
    }
  }
  if (hi == 0) return BrickClass::kSkip;  // no measurement under the brick
  const Real z_meas_lo = job.depth.metres(uint16_t(lo)), z_meas_hi = job.depth.metres(uint16_t(hi));
  // d = (z - p.z) |ray| and |ray| >= 1: behind every measurement by rho -> d < -rho everywhere.
  if (z_lo - z_meas_hi > job.rho) return BrickClass::kSkip;
  // In front of every measurement by trunc, every pixel valid and in range: d >= trunc everywhere.
  if (z_meas_lo - z_hi > job.trunc && z_meas_lo >= job.min_z && z_meas_hi <= job.max_z)
    return all ? BrickClass::kFreeSpace : BrickClass::kVoxels;  // holes: which voxels get +1 needs the loop
  return BrickClass::kVoxels;
}

// The first raw depth (0..65535, or 65536 for none) whose metres satisfy `pred`, which must be
// monotone in the depth (false below some raw value, true from it on): a binary search.
template <class Real, class Pred>
uint32_t first_raw_where(const DepthScale<Real>& scale, Pred pred) {
  uint32_t lo = 0, hi = 65536;
  while (lo < hi) {
    const uint32_t mid = (lo + hi) / 2;
    if (pred(scale.metres(uint16_t(mid)))) hi = mid; else lo = mid + 1;
  }
  return lo;
}

}  // namespace

template <class Real>
Status prepare_integration(const TsdfVolume& volume, const PinholeIntrinsics& intr, ImageView<const Real> ray_norms,
                           const DepthFrame& frame, const Pose& T_world_cam, float trust, FrameScratch& scratch,
                           IntegrationJob<Real>& job) {
  if (!volume.initialised()) return Status::kNotInitialised;
  if (intr.validate() != Status::kOk || !(trust > 0.0f) || trust > 1.0f) return Status::kInvalidArgument;
  if (frame.depth.empty() || frame.depth.width != intr.width || frame.depth.height != intr.height)
    return Status::kInvalidArgument;
  if (ray_norms.empty() || ray_norms.width != intr.width || ray_norms.height != intr.height)
    return Status::kInvalidArgument;
  if (!frame.colour.empty() && (frame.colour.width != intr.width || frame.colour.height != intr.height))
    return Status::kInvalidArgument;
  if (!frame.trust.empty() && (frame.trust.width != intr.width || frame.trust.height != intr.height))
    return Status::kInvalidArgument;
  if (!T_world_cam.R.allFinite() || !T_world_cam.t.allFinite()) return Status::kInvalidArgument;
  if (!scratch.fits(intr.width, intr.height)) return Status::kCapacityExceeded;
  // project_row computes pixel indices in float (exact below 2^24).
  if (int64_t(frame.depth.stride) * intr.height >= (int64_t(1) << 24)) return Status::kCapacityExceeded;

  const Pose T_cam_world = T_world_cam.inverse();
  const TsdfParams& p = volume.params();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) job.R[r * 3 + c] = real_from<Real>(T_cam_world.R(r, c));
    job.t[r] = real_from<Real>(T_cam_world.t(r));
    job.origin[r] = real_from<Real>(volume.origin_m()(r));
  }
  job.fx = real_from<Real>(intr.fx);
  job.fy = real_from<Real>(intr.fy);
  job.cx = real_from<Real>(intr.cx);
  job.cy = real_from<Real>(intr.cy);
  job.min_z = real_from<Real>(intr.min_range_m);
  job.max_z = real_from<Real>(intr.max_range_m);
  job.depth = DepthScale<Real>(intr.depth_scale);
  job.trunc = real_from<Real>(p.trunc_m);
  job.inv_trunc = real_from<Real>(1.0f / p.trunc_m);
  job.eps = real_from<Real>(p.weight.eps_m);
  job.rho = real_from<Real>(p.weight.rho_m);
  job.band_to_index = real_from<Real>(float(WeightTable::kSize) / (p.weight.rho_m - p.weight.eps_m));
  job.colour_band = real_from<Real>(p.colour_band_m > 0.0f ? p.colour_band_m : p.weight.eps_m);
  job.voxel = real_from<Real>(p.voxel_m);
  job.voxel_m = p.voxel_m;
  for (int r = 0; r < 3; ++r) job.origin_m[r] = volume.origin_m()(r);
  job.trust_q8 = uint32_t(std::lround(trust * 256.0f));
  if (job.trust_q8 == 0) job.trust_q8 = 1;
  if (!(frame.jump_m >= 0.0f) || frame.jump_m > 1.0f) return Status::kInvalidArgument;
  const float jump = std::round((frame.jump_m > p.trunc_m ? frame.jump_m : p.trunc_m) * intr.depth_scale);
  job.jump_raw = jump < 1.0f ? 1u : (jump > 65535.0f ? 65535u : uint32_t(jump));
  job.jump = job.depth.metres(uint16_t(job.jump_raw));
  if (frame.sub_unit_fill_units < 1 || frame.sub_unit_fill_units > 255) return Status::kInvalidArgument;
  job.sub_unit_fill = frame.sub_unit_fill_units;
  // Raw depths whose metres lie in [min_z, max_z]: an interval, as metres() is monotone.
  {
    const uint32_t lo = first_raw_where(job.depth, [&](Real m) { return m >= job.min_z; });
    const uint32_t end = first_raw_where(job.depth, [&](Real m) { return m > job.max_z; });
    job.raw_in_range_lo = lo < end ? lo : 0x10000u;  // empty: no raw passes
    job.raw_in_range_span = lo < end ? end - 1 - lo : 0u;
  }
  job.frame = frame;
  job.ray_norms = ray_norms;
  build_depth_tiles(frame.depth, DepthScale<float>(intr.depth_scale), scratch.depth_tiles);
  job.tiles = scratch.depth_tiles;
  job.tiles_x = FrameScratch::tiles_x(intr.width);
  job.tiles_y = FrameScratch::tiles_y(intr.height);
  job.width = intr.width;
  job.height = intr.height;
  return Status::kOk;
}

std::size_t select_bricks(TsdfVolume& volume, const PinholeIntrinsics& intr, const Pose& T_world_cam) {
  if (!volume.initialised()) return 0;
  const BrickFrustum frustum(volume, intr, T_world_cam);
  const int nb = volume.bricks_per_axis();
  uint32_t* list = volume.brick_list();
  std::size_t count = 0;
  for (int bz = 0; bz < nb; ++bz)
    for (int by = 0; by < nb; ++by)
      for (int bx = 0; bx < nb; ++bx)
        if (frustum.sees(bx, by, bz)) list[count++] = uint32_t(volume.brick_index(bx, by, bz));
  return count;
}

namespace {

// A tile's neighbourhood minimum in metres: converted once per tile for the float kernel (the
// same product as DepthScale<float>::metres), per voxel in Q16.16.
inline float tile_near(const DepthTile& t, const DepthScale<float>& /*scale*/) { return t.near_m; }
inline Fixed tile_near(const DepthTile& t, const DepthScale<Fixed>& scale) { return scale.metres(t.near_raw); }

// The brick loop, compiled once per combination of the per-frame switches so that the voxel loop
// of a plain depth frame (no colour, no trust map, not a colour pass: every frame of `edgefuse
// fuse` and `track` without colour) carries no tests of them: kColour = the frame's colour is
// fused (volume with colour), kExtras = a trust map or the colour-only pass, or a ray-norm map
// whose row stride differs from the depth image's (else it is read at the depth pixel's index).
// Same arithmetic in every instance, so the same voxels.
// Kept whole (~180 lines) on purpose: it is one loop nest (brick, row, voxel) whose per-brick
// state the compiler keeps in registers; splitting it into functions risks the measured speed.
template <class Real, bool kColour, bool kExtras>
void integrate_bricks_as(TsdfVolume& volume, const IntegrationJob<Real>& job, std::size_t begin, std::size_t end) {
  const uint32_t* list = volume.brick_list();
  int16_t* tsdf = volume.tsdf();
  uint8_t* weight = volume.weight();
  Rgb8* colour = kColour ? volume.colour() : nullptr;
  uint8_t* colour_weight = volume.colour_weight();
  uint8_t* flags = volume.brick_flags();
  const uint16_t* shape = volume.weight_table().shape;
  const uint8_t max_weight = volume.params().max_weight;
  const Real zero = real_from<Real>(0.0f);
  const Real q_scale = real_from<Real>(float(kTsdfMax));
  const int32_t full_weight = int32_t((uint32_t(WeightTable::kOne) * job.trust_q8 * kWeightUnitsPerSample + 32768u) >> 16);
  // Voxels closer than a voxel to the sensor plane are not projected (division by ~0).
  const Real near_z = job.voxel;
  const bool has_trust = kExtras && !job.frame.trust.empty();
  // Per-frame constants of the voxel loop held in locals: the voxel stores go through uint8_t
  // pointers, which may alias `job`, so its members would be reloaded after every store.
  const bool colour_only = kExtras && job.colour_only;
  const Real jump = job.jump, minus_rho = zero - job.rho, trunc = job.trunc, min_z = job.min_z, max_z = job.max_z;
  const DepthTile* const tiles = job.tiles;
  const int tiles_x_i = job.tiles_x;
  const Real eps = job.eps, minus_eps = zero - job.eps, band_to_index = job.band_to_index, inv_trunc = job.inv_trunc;
  const Real colour_band = job.colour_band, minus_colour_band = zero - job.colour_band;
  const uint32_t trust_q8 = job.trust_q8;
  const ImageView<const Real> ray_norms = job.ray_norms;
  const ImageView<const Rgb8> colour_px = job.frame.colour;
  const LaneCamera<Real> cam = {job.fx, job.fy, job.cx, job.cy, job.width, job.height, float(job.width), float(job.height),
                                job.frame.depth.stride, float(job.frame.depth.stride), float(job.tiles_x)};
  const DepthLookup<Real> dl = {job.frame.depth.data, std::ptrdiff_t(job.frame.depth.stride), uint32_t(job.width - 1),
                                uint32_t(job.height - 1), job.jump_raw, job.depth};
  const DepthScale<Real> scale = job.depth;
  const RowDepth<Real> row_depth = {job.frame.depth.data, job.depth, jump, minus_rho};
  const uint32_t raw_lo = job.raw_in_range_lo, raw_span = job.raw_in_range_span;

  // Camera-frame step between neighbouring voxels along each grid axis: column of R times voxel;
  // span: from the brick's first to its last voxel centre along each axis.
  Real step[3][3], span[3][3], half_span[3][3];
  for (int axis = 0; axis < 3; ++axis)
    for (int r = 0; r < 3; ++r) {
      step[axis][r] = job.R[r * 3 + axis] * job.voxel;
      span[axis][r] = step[axis][r] * real_from_int<Real>(kBrickSide - 1);
      half_span[axis][r] = step[axis][r] * real_from_int<Real>(kHalf - 1);
    }
  for (std::size_t i = begin; i < end; ++i) {
    const uint32_t brick = list[i];
    int bx, by, bz;
    volume.brick_coords(brick, bx, by, bz);
    // World centre of the brick's first voxel, then into the camera frame. Placed from the exact
    // voxel size once per brick: in Q16 the rounded voxel size times a grid index would shift
    // voxels by up to ~1e-3 relative, far from the origin (the raycast uses the exact 1/voxel).
    const Real w0[3] = {real_from<Real>(job.origin_m[0] + (float(bx * kBrickSide) + 0.5f) * job.voxel_m),
                        real_from<Real>(job.origin_m[1] + (float(by * kBrickSide) + 0.5f) * job.voxel_m),
                        real_from<Real>(job.origin_m[2] + (float(bz * kBrickSide) + 0.5f) * job.voxel_m)};
    Real c0[3];
    for (int r = 0; r < 3; ++r) c0[r] = job.R[r * 3] * w0[0] + job.R[r * 3 + 1] * w0[1] + job.R[r * 3 + 2] * w0[2] + job.t[r];

    const BrickClass cls = classify_box(job, cam, c0, span, near_z, true);
    // A brick without a pool slot (the frustum list of a colour pass) has nothing to update.
    if (cls == BrickClass::kSkip || !volume.brick_stored(brick)) continue;
    const std::size_t base = volume.brick_base(brick);
    bool surface = false, observed = false;
    if (colour_only && (cls == BrickClass::kFreeSpace || (flags[brick] & kBrickSurface) == 0)) continue;
    if (cls == BrickClass::kFreeSpace) {
      free_space_update(tsdf, weight, base, 0, kBrickSide, max_weight, full_weight, surface);
      flags[brick] |= surface ? (kBrickObserved | kBrickSurface) : kBrickObserved;
      if (flags[brick] & kBrickSurface) block_mask::refresh(volume, brick);
      continue;
    }
    // A mixed brick: classify its eight 4^3 blocks, so that only those the surface band passes
    // through are projected voxel by voxel. A brick listed only for the free margin in front of
    // the band (select_band_bricks) holds no band voxel: its blocks that need the voxel loop would
    // only get +1 samples between depth holes, and are left alone.
    const bool margin_only = (flags[brick] & (kBrickListed | kBrickBand)) == kBrickListed;
    for (int sb = 0; sb < 8; ++sb) {
      const int off[3] = {(sb & 1) * kHalf, ((sb >> 1) & 1) * kHalf, ((sb >> 2) & 1) * kHalf};
      Real cb[3];
      for (int r = 0; r < 3; ++r)
        cb[r] = c0[r] + step[0][r] * real_from_int<Real>(off[0]) + step[1][r] * real_from_int<Real>(off[1]) +
                step[2][r] * real_from_int<Real>(off[2]);
      const BrickClass sub = classify_box(job, cam, cb, half_span, near_z, false);
      if (sub == BrickClass::kSkip) continue;
      const int first = (off[2] << 6) | (off[1] << 3) | off[0];
      if (sub == BrickClass::kFreeSpace && colour_only) continue;
      if (sub == BrickClass::kFreeSpace) {
        free_space_update(tsdf, weight, base, first, kHalf, max_weight, full_weight, surface);
        observed = true;
        continue;
      }
      if (margin_only) continue;
      Real pz[3] = {cb[0], cb[1], cb[2]};
      for (int lz = 0; lz < kHalf; ++lz) {
        Real py[3] = {pz[0], pz[1], pz[2]};
        for (int ly = 0; ly < kHalf; ++ly) {
          const std::size_t row = base + std::size_t(first + (lz << 6) + (ly << 3));
          RowProjection<Real> rp;
          const unsigned live = project_row(cam, py, step[0], near_z, row_depth, rp);
          for (int r = 0; r < 3; ++r) py[r] += step[1][r];
#pragma GCC unroll 4
          for (int lx = 0; lx < kRowLanes; ++lx) {
            if (((live >> lx) & 1u) == 0) continue;
            const Real pu = rp.pu[lx], pv = rp.pv[lx], vz = rp.z[lx];
            const int iu = rp.iu[lx], iv = rp.iv[lx];
            // Cheap exits on the nearest pixel before interpolating: no data and certainly
            // occluded (project_row: the lane is not in `live`); certainly free space (every
            // pixel around is at least trunc beyond the voxel).
            const std::ptrdiff_t pix = rp.pix[lx];
            const uint16_t nearest = uint16_t(rp.nearest[lx]);
            const Real z_near = rp.z_near[lx];
            const std::size_t idx = row + std::size_t(lx);
            if (colour_only && (colour == nullptr || weight[idx] == 0)) continue;
            // The tile's neighbourhood minimum is at most the nearest pixel's depth, so a voxel less
            // than trunc in front of its nearest pixel cannot pass the free-space test: the tile is
            // read only for the others (same decisions, monotone roundings).
            if (z_near - vz >= trunc &&
                tile_near(tiles[lane_tile(rp, lx, tiles_x_i)], scale) - vz >= trunc &&
                uint32_t(nearest) - raw_lo <= raw_span) {  // min_z <= z_near <= max_z
              if (colour_only) continue;
              const int32_t old_w = weight[idx];
              if (old_w == max_weight && tsdf[idx] == kTsdfMax) continue;
              const int32_t value = old_w == 0 ? kTsdfMax : blend(tsdf[idx], old_w, kTsdfMax, full_weight);
              tsdf[idx] = int16_t(value);
              weight[idx] = cap_weight(old_w + full_weight, max_weight);
              observed = true;
              surface |= value < kTsdfMax;
              continue;
            }
            Real z;
            int u0, v0, win;
            lane_floor(rp, lx, cam.stride, u0, v0, win);
            if (!depth_at(dl, pu, pv, u0, v0, win, nearest, z)) continue;
            if (z < min_z || z > max_z) continue;
            // Eq. (1): (measured range) - (voxel range) along the ray = (z - p.z) |ray|.
            const Real d = (z - vz) * (kExtras ? ray_norms.at(iu, iv) : ray_norms.data[pix]);
            if (d <= minus_rho) continue;
            // Eq. (2) from the table: full weight in front of -eps.
            int32_t w = full_weight;
            if (d < minus_eps) {
              int32_t k = floor_int((zero - d - eps) * band_to_index);
              k = k < 0 ? 0 : (k >= WeightTable::kSize ? WeightTable::kSize - 1 : k);
              w = int32_t((shape[k] * trust_q8 * kWeightUnitsPerSample + 32768u) >> 16);
              if (w == 0) continue;
            }
            if (has_trust) {
              w = voxel_update::scale_by_trust(w, job.frame.trust.at(iu, iv), weight[idx], job.sub_unit_fill);
              if (w == 0) continue;
            }
            int32_t q = d >= trunc ? kTsdfMax : round_select(d * inv_trunc * q_scale);
            q = q > kTsdfMax ? kTsdfMax : (q < -kTsdfMax ? -kTsdfMax : q);

            if (!colour_only) {
              const int32_t old_w = weight[idx];
              const int32_t value = old_w == 0 ? q : blend(tsdf[idx], old_w, q, w);
              tsdf[idx] = int16_t(value);
              weight[idx] = cap_weight(old_w + w, max_weight);
              observed = true;
              // -kTsdfMax < value < kTsdfMax, without a branch
              surface |= uint32_t(value + (kTsdfMax - 1)) < uint32_t(2 * kTsdfMax - 1);
            }

            if (colour != nullptr && d < colour_band && d > minus_colour_band) {
              const Rgb8 c = colour_px.at(iu, iv);
              const int32_t cw = colour_weight[idx];
              Rgb8& v = colour[idx];
              if (cw == 0) {
                v = c;
              } else {
                v.r = uint8_t(blend(v.r, cw, c.r, w));
                v.g = uint8_t(blend(v.g, cw, c.g, w));
                v.b = uint8_t(blend(v.b, cw, c.b, w));
              }
              colour_weight[idx] = cap_weight(cw + w, max_weight);
            }
          }
        }
        for (int r = 0; r < 3; ++r) pz[r] += step[2][r];
      }
    }
    if (observed) flags[brick] |= kBrickObserved;
    if (surface) flags[brick] |= kBrickSurface;
    if (observed && (flags[brick] & kBrickSurface)) block_mask::refresh(volume, brick);
  }
}

}  // namespace

template <class Real>
void integrate_bricks(TsdfVolume& volume, const IntegrationJob<Real>& job, std::size_t begin, std::size_t end) {
  const bool with_colour = !job.frame.colour.empty() && volume.colour() != nullptr;
  const bool extras = job.colour_only || !job.frame.trust.empty() || job.ray_norms.stride != job.frame.depth.stride;
  if (with_colour)
    extras ? integrate_bricks_as<Real, true, true>(volume, job, begin, end)
           : integrate_bricks_as<Real, true, false>(volume, job, begin, end);
  else
    extras ? integrate_bricks_as<Real, false, true>(volume, job, begin, end)
           : integrate_bricks_as<Real, false, false>(volume, job, begin, end);
}

void finish_integration(TsdfVolume& volume, std::size_t count) {
  const uint32_t* list = volume.brick_list();
  uint8_t* flags = volume.brick_flags();
  const int nb = volume.bricks_per_axis();
  for (std::size_t i = 0; i < count; ++i) {
    const uint32_t brick = list[i];
    flags[brick] &= uint8_t(~(kBrickListed | kBrickBand));
    if ((flags[brick] & (kBrickSurface | kBrickDilated)) != kBrickSurface) continue;
    flags[brick] |= kBrickDilated;
    int bx, by, bz;
    volume.brick_coords(brick, bx, by, bz);
    for (int z = bz - 1; z <= bz + 1; ++z)
      for (int y = by - 1; y <= by + 1; ++y)
        for (int x = bx - 1; x <= bx + 1; ++x)
          if (x >= 0 && y >= 0 && z >= 0 && x < nb && y < nb && z < nb)
            flags[volume.brick_index(x, y, z)] |= kBrickNearSurface;
  }
}

template <class Real>
Status integrate(TsdfVolume& volume, const PinholeIntrinsics& intr, ImageView<const Real> ray_norms,
                 const DepthFrame& frame, const Pose& T_world_cam, FrameScratch& scratch, float trust) {
  IntegrationJob<Real> job;
  const Status s = prepare_integration(volume, intr, ray_norms, frame, T_world_cam, trust, scratch, job);
  if (s != Status::kOk) return s;
  const std::size_t count = select_band_bricks(volume, intr, frame, T_world_cam);
  integrate_bricks(volume, job, 0, count);
  finish_integration(volume, count);
  return Status::kOk;
}

#define EDGEFUSE_INSTANTIATE(Real)                                                                                  \
  template Status prepare_integration<Real>(const TsdfVolume&, const PinholeIntrinsics&, ImageView<const Real>,     \
                                            const DepthFrame&, const Pose&, float, FrameScratch&,                   \
                                            IntegrationJob<Real>&);                                                  \
  template void integrate_bricks<Real>(TsdfVolume&, const IntegrationJob<Real>&, std::size_t, std::size_t);        \
  template Status integrate<Real>(TsdfVolume&, const PinholeIntrinsics&, ImageView<const Real>, const DepthFrame&, \
                                  const Pose&, FrameScratch&, float);
EDGEFUSE_INSTANTIATE(float)
EDGEFUSE_INSTANTIATE(Fixed)
#undef EDGEFUSE_INSTANTIATE

}  // namespace edgefuse
