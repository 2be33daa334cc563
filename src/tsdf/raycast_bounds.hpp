// Per-pixel march bounds of the raycast: prepare_raycast projects the
// marked 2^3 blocks (block_mask.hpp) into the image and keeps, for each pixel, the z-depth range
// in which its ray can meet a zero crossing. A ray then starts a few voxels before its own
// surface and stops a few voxels behind it; a pixel that no marked block covers is not marched.
//
// Storage: no memory of its own. Each pixel's bound is packed into the 4 bytes of that pixel's
// depth-map float (two int16: the near z and the negated far z, in steps of max_range / 65534,
// offset by -32768 so that a signed 16-bit minimum applies: SSE2's pminsw, NEON's vmin.s16),
// which RayMarcher::start reads before it clears the pixel. Negating the far z makes both halves
// minima, so merging a block into a pixel, and widening the bounds (dilate), are element-wise
// minima over int16s.
// A block is bounded by its crossing cube's box (not its sphere), and footprints are widened by
// 3x3 (kDilate): fewer pixels marched in vain, rays start closer.
// Private to src/.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "edgefuse/core/image.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/sensor/pinhole.hpp"
#include "edgefuse/tsdf/volume.hpp"
#include "lanes.hpp"

namespace edgefuse {
namespace raycast_bounds {

//! Quantisation of z-depth (max_range_m maps to kTop steps).
struct Quant {
  static constexpr int32_t kTop = 65000;  // the halves stay below kEmpty
  float unit_m = 0.0f;    //!< metres per step
  float inv_unit = 0.0f;  //!< steps per metre
  //! \param max_range_m the sensor's farthest z-depth (no bound needs more)
  explicit Quant(float max_range_m) : unit_m(max_range_m / float(kTop)), inv_unit(float(kTop) / max_range_m) {}
  //! Largest step at or below z_m, clamped to [0, kTop].
  int32_t floor_q(float z_m) const {
    const float q = z_m * inv_unit;
    return q <= 0.0f ? 0 : (q >= float(kTop) ? kTop : int32_t(q));
  }
  //! Smallest step at or above z_m, clamped to [0, kTop].
  int32_t ceil_q(float z_m) const {
    const float q = z_m * inv_unit;
    if (q <= 0.0f) return 0;
    if (q >= float(kTop)) return kTop;
    const int32_t i = int32_t(q);
    return float(i) < q ? i + 1 : i;
  }
};

//! Both halves of a pixel that no block covers (a byte pattern: clear() is a memset).
inline constexpr int16_t kEmpty = 0x7F7F;
//! The near half of a step count (0..kTop), and the far half.
inline int16_t near_half(int32_t near_q) { return int16_t(near_q - 32768); }
inline int16_t far_half(int32_t far_q) { return int16_t(32767 - far_q); }

// The depth map seen as int16 pairs (may_alias: the floats are not read as floats until the march
// has cleared them).
using alias_i16 = int16_t __attribute__((__may_alias__));

// GCC vector extensions (lanes.hpp): four blocks projected at once, eight int16 halves minimised
// at once.
namespace lanes {
using namespace lane_types;
inline S8 load8(const alias_i16* p) {
  S8 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void store8(alias_i16* p, S8 v) { std::memcpy(p, &v, sizeof v); }
inline S8 min8(S8 a, S8 b) { return a < b ? a : b; }
//! Four pixels' halves: `pair` (nh, fh repeated) in pixels [from, to] of the four, kEmpty in the
//! others (a minimum with kEmpty leaves a pixel as it is).
inline S8 pair_lanes(S8 pair, int from, int to) {
  const S8 lane = S8{0, 0, 1, 1, 2, 2, 3, 3};
  const S8 none = S8{kEmpty, kEmpty, kEmpty, kEmpty, kEmpty, kEmpty, kEmpty, kEmpty};
  return (lane >= int16_t(from)) & (lane <= int16_t(to)) ? pair : none;
}
}  // namespace lanes

//! Sets every pixel of the depth map to "no bound".
inline void clear(const ImageView<float>& depth) {
  for (int v = 0; v < depth.height; ++v) {
    std::memset(depth.row(v), 0x7F, sizeof(float) * std::size_t(depth.width));
  }
}

//! True when every row of `depth` starts on 16 bytes and holds whole groups of four pixels: then
//! merge_rect() uses only 16-byte loads and stores at those boundaries.
inline bool four_pixel_aligned(const ImageView<float>& depth) {
  return reinterpret_cast<uintptr_t>(depth.data) % 16 == 0 && depth.stride % 4 == 0 && depth.width % 4 == 0;
}

//! Merges the halves (near_half / far_half, kEmpty for "none") into pixels [u0, u1] x [v0, v1]
//! (inclusive, inside the image), four pixels per vector minimum.
//! With `aligned` (four_pixel_aligned()), each row is the aligned groups of four pixels that hold
//! [u0, u1], the lanes outside it set to kEmpty (a minimum with kEmpty leaves a pixel as it is).
//! Footprints overlap (~7 blocks per pixel at 1 cm / 640x480): a load of a group some earlier
//! store wrote only in part cannot be forwarded from the store buffer and stalls, and measured,
//! unaligned groups made the splat slower than scalar writes despite half the instructions.
//! Otherwise: unaligned groups, the last four pixels of a row as one overlapping group, and scalar
//! pixels for rects narrower than four.
inline void merge_rect(const ImageView<float>& depth, int u0, int u1, int v0, int v1, int16_t nh, int16_t fh,
                       bool aligned = false) {
  using namespace lanes;
  const S8 pair = S8{nh, fh, nh, fh, nh, fh, nh, fh};
  const int n = u1 - u0 + 1;
  if (aligned) {
    const int g0 = u0 & ~3, g1 = u1 & ~3;  // first and last group
    const S8 first = pair_lanes(pair, u0 - g0, g0 == g1 ? u1 - g1 : 3);
    const S8 last = pair_lanes(pair, 0, u1 - g1);
    for (int v = v0; v <= v1; ++v) {
      alias_i16* p = reinterpret_cast<alias_i16*>(depth.row(v)) + 2 * g0;
      alias_i16* const end = p + 2 * (g1 - g0);
      store8(p, min8(load8(p), first));
      if (p == end) continue;
      for (p += 8; p < end; p += 8) store8(p, min8(load8(p), pair));
      store8(end, min8(load8(end), last));
    }
  } else if (n >= 4) {
    for (int v = v0; v <= v1; ++v) {
      alias_i16* p = reinterpret_cast<alias_i16*>(depth.row(v)) + 2 * u0;
      alias_i16* last = p + 2 * (n - 4);
      for (; p < last; p += 8) store8(p, min8(load8(p), pair));
      store8(last, min8(load8(last), pair));
    }
  } else {
    for (int v = v0; v <= v1; ++v) {
      alias_i16* p = reinterpret_cast<alias_i16*>(depth.row(v)) + 2 * u0;
      for (int u = u0; u <= u1; ++u, p += 2) {
        p[0] = p[0] < nh ? p[0] : nh;
        p[1] = p[1] < fh ? p[1] : fh;
      }
    }
  }
}

//! Reads a pixel's bound; false when no block covers it. Call before the pixel is written.
//! \param pixel the pixel's float in the depth map prepared by prepare_raycast
//! \param q the frame's quantisation
//! \param near_m, far_m the z range, out
inline bool read(const float& pixel, const Quant& q, float& near_m, float& far_m) {
  int16_t h[2];
  std::memcpy(h, &pixel, sizeof h);
  if (h[0] == kEmpty) return false;
  near_m = float(int32_t(h[0]) + 32768) * q.unit_m;
  far_m = float(32767 - int32_t(h[1])) * q.unit_m;
  return true;
}

// Footprints are written shrunk by kDilate pixels on every side (one pixel when they are at most
// 2 kDilate + 1 wide), and one min filter over the image widens them all back: ~25 pixel writes
// per block become a few, plus 2 (2 kDilate + 1) vector minima per pixel. kDilate is 1, not 2: a
// footprint narrower than 2 kDilate + 1 pixels is widened to that
// square anyway, and at 2 mm voxels from ~0.6 m (fx ~ 290 px) most block footprints are 3-5
// pixels wide: 5x5 squares covered pixels whose rays then marched without a hit.
inline constexpr int kDilate = 1;
//! Widest image dilate() handles (its row buffers live on the stack); wider images splat whole
//! footprints.
inline constexpr int kDilateWidthMax = 1024;

//! Square min filter of half-size kDilate over both halves of every pixel, in place.
//! Only where something was written: each row's first and last covered pixels are found from its
//! ends (8 bytes per test: an empty pixel is the byte pattern of kEmpty); the row pass filters
//! each row between them (plus kDilate), the column pass the box of all of them (plus kDilate).
//! Everything outside is empty before and after.
//! \param depth the depth map holding the packed bounds (width <= kDilateWidthMax)
inline void dilate(const ImageView<float>& depth) {
  const int w = depth.width, h = depth.height;
  constexpr int kPad = 2 * kDilate;  // int16s of "empty" on either side of a row copy
  constexpr uint64_t kEmptyWord = 0x7F7F7F7F7F7F7F7Full;
  // Rows: each output is the minimum of the row's 2 kDilate + 1 pixels around it, in one pass
  // over a padded copy of the covered span (every pixel is two int16s: the neighbours are 2 d
  // apart).
  alias_i16 tmp[2 * kDilateWidthMax + 2 * kPad];
  int box_u0 = w, box_u1 = -1, box_v0 = h, box_v1 = -1;
  for (int v = 0; v < h; ++v) {
    alias_i16* row = reinterpret_cast<alias_i16*>(depth.row(v));
    const auto empty_pair = [&](int u0) {  // pixels u0, u0 + 1 hold no bound
      uint64_t word;
      std::memcpy(&word, row + 2 * u0, sizeof word);
      return word == kEmptyWord;
    };
    int a = 0, b = w - 1;  // first and last pixel that may hold a bound
    while (a + 1 < w && empty_pair(a)) a += 2;
    while (b - 1 >= a && empty_pair(b - 1)) b -= 2;
    if (w >= 2 && a == b && empty_pair(std::min(a, w - 2))) continue;  // a lone pixel left: the pair holds it
    if (a > b) continue;
    // [a, b] now holds every covered pixel (the pair tests may leave one empty pixel at an end).
    box_v0 = std::min(box_v0, v), box_v1 = v;
    a = std::max(a - kDilate, 0), b = std::min(b + kDilate, w - 1);
    box_u0 = std::min(box_u0, a), box_u1 = std::max(box_u1, b);
    const int n2 = 2 * (b - a + 1);
    for (int k = 0; k < kPad; ++k) tmp[k] = tmp[kPad + n2 + k] = kEmpty;
    std::memcpy(tmp + kPad, row + 2 * a, sizeof(int16_t) * std::size_t(n2));
    alias_i16* out = row + 2 * a;
    // Eight int16s (four pixels) per vector minimum, reading the copy: a last group that overlaps
    // the one before it writes the same minima again. (GCC left this loop scalar at kDilate = 1.)
    const auto filter8 = [&](int k) {
      const alias_i16* c = tmp + kPad + k;
      lanes::S8 m = lanes::load8(c);
      for (int d = 1; d <= kDilate; ++d) m = lanes::min8(lanes::min8(m, lanes::load8(c - 2 * d)), lanes::load8(c + 2 * d));
      lanes::store8(out + k, m);
    };
    if (n2 >= 8) {
      for (int k = 0; k + 8 < n2; k += 8) filter8(k);
      filter8(n2 - 8);
    } else {
      for (int k = 0; k < n2; ++k) {
        int16_t m = tmp[kPad + k];
        for (int d = 1; d <= kDilate; ++d) {
          m = m < tmp[kPad + k - 2 * d] ? m : tmp[kPad + k - 2 * d];
          m = m < tmp[kPad + k + 2 * d] ? m : tmp[kPad + k + 2 * d];
        }
        out[k] = m;
      }
    }
  }
  if (box_v1 < 0) return;
  // Columns: row v becomes the minimum of rows v - kDilate .. v + kDilate. The rows above and
  // this one are already being overwritten, so their row-filtered values are kept in a ring;
  // rows beyond [v0, v1] (empty, or beyond the image) are stood in for by this row's own copy.
  const int v0 = std::max(box_v0 - kDilate, 0), v1 = std::min(box_v1 + kDilate, h - 1);
  const int a2 = 2 * box_u0, n2 = 2 * (box_u1 - box_u0 + 1);
  alias_i16 ring[kDilate + 1][2 * kDilateWidthMax];
  for (int v = v0; v <= v1; ++v) {
    alias_i16* row = reinterpret_cast<alias_i16*>(depth.row(v)) + a2;
    alias_i16* own = ring[v % (kDilate + 1)];
    std::memcpy(own, row, sizeof(int16_t) * std::size_t(n2));
    const alias_i16* others[2 * kDilate];
    for (int d = 1; d <= kDilate; ++d) {
      others[2 * d - 2] = v - d >= v0 ? ring[(v - d) % (kDilate + 1)] : own;
      others[2 * d - 1] = v + d <= v1 ? reinterpret_cast<const alias_i16*>(depth.row(v + d)) + a2 : own;
    }
    for (int k = 0; k < n2; ++k) {
      int16_t m = own[k];
      for (int i = 0; i < 2 * kDilate; ++i) m = m < others[i][k] ? m : others[i][k];
      row[k] = m;
    }
  }
}

// How far a zero crossing can lie from a marked block's centre: the block's voxel centres are
// within half a voxel of it on each axis, and a crossing lies in a cell with a marked corner, i.e.
// within one more voxel on each axis: a world-axis-aligned cube of half-size 1.5 voxels. The splat
// bounds it by the cube's own extent along each sensor axis (Splatter::ext_), 1.5 to 2.6 voxels
// depending on the view, which is tighter than its bounding sphere (radius 2.6 voxels).
inline constexpr float kCubeHalfVoxels = 1.5f;

// Masks of a brick's 4x4x4 blocks (bit z*16 + y*4 + x) on its faces.
inline constexpr uint64_t kX0 = 0x1111111111111111ull, kX3 = kX0 << 3;
inline constexpr uint64_t kY0 = 0x000F000F000F000Full, kY3 = kY0 << 12;
inline constexpr uint64_t kZ0 = 0xFFFFull, kZ3 = kZ0 << 48;

//! Blocks of a brick whose neighbour on the -axis / +axis side is marked, given the brick's mask
//! and the masks of its neighbour bricks on that side.
inline uint64_t lower_marked(int axis, uint64_t m, uint64_t nb) {
  if (axis == 0) return ((m << 1) & ~kX0) | ((nb & kX3) >> 3);
  if (axis == 1) return ((m << 4) & ~kY0) | ((nb & kY3) >> 12);
  return (m << 16) | ((nb & kZ3) >> 48);
}
inline uint64_t upper_marked(int axis, uint64_t m, uint64_t nb) {
  if (axis == 0) return ((m >> 1) & ~kX3) | ((nb & kX0) << 3);
  if (axis == 1) return ((m >> 4) & ~kY3) | ((nb & kY0) << 12);
  return (m >> 16) | ((nb & kZ0) << 48);
}

// Which blocks bound the march. The crossing regions (cubes of half-size 1.5 voxels around the
// marked blocks' centres, see kCubeHalfVoxels) of face neighbours overlap on their common face, so
// walking a ray back from its crossing, it leaves each cube through a face turned towards the
// sensor into the next marked block's cube, until it reaches a block whose neighbour on that side
// is unmarked. Those "front" blocks alone bound the near end of every ray; the far end likewise
// the "back" blocks. Per axis, `toward` says on which side the sensor is (-1: lower coordinates,
// +1: higher, 0: either, when the sensor is level with the brick: both sides count).
struct Sides {
  uint64_t front = 0, back = 0;
};
//! \param m the brick's mask
//! \param lower, upper masks of the face-neighbour bricks below / above on x, y, z (0 if none)
//! \param toward the sensor's side per axis (-1, +1, 0: both)
inline Sides front_back(uint64_t m, const uint64_t lower[3], const uint64_t upper[3], const int toward[3]) {
  uint64_t cover_front = ~uint64_t(0), cover_back = ~uint64_t(0);  // blocks hidden on every side
  for (int a = 0; a < 3; ++a) {
    const uint64_t lo = lower_marked(a, m, lower[a]), hi = upper_marked(a, m, upper[a]);
    if (toward[a] <= 0) cover_front &= lo, cover_back &= hi;
    if (toward[a] >= 0) cover_front &= hi, cover_back &= lo;
  }
  Sides s;
  s.front = m & ~cover_front;
  s.back = m & ~cover_back;
  return s;
}

// Splats the front and back blocks of surface bricks into the per-pixel bounds; built once per
// raycast with the frame's constants.
class Splatter {
 public:
  //! \param depth the depth map that receives the packed bounds (cleared by clear())
  //! \param intr the sensor
  //! \param T_cam_world maps world points into the sensor frame
  //! \param voxel_m the voxel size
  //! \param dilate true: blocks write their footprints shrunk by kDilate (at least the middle
  //!        pixel), and dilate() must run after the last brick; false: whole footprints
  Splatter(const ImageView<float>& depth, const PinholeIntrinsics& intr, const Pose& T_cam_world, float voxel_m,
           bool dilate)
      : depth_(depth),
        intr_(intr),
        q_(intr.max_range_m),
        dilate_(dilate),
        aligned_(four_pixel_aligned(depth)) {
    // Block centres are a lattice: block (i, j, k) of a brick sits at i a + j b + k c from the
    // brick's block (0, 0, 0), a, b, c being 2 voxels along world x, y, z in the sensor frame.
    for (int a = 0; a < 3; ++a) step_[a] = T_cam_world.R.col(a) * (2.0f * voxel_m);
    // The crossing cube's half extent along sensor axis a: the largest |R(a, :) d| over the
    // cube's offsets d in [-h, h]^3 is h (|R(a, 0)| + |R(a, 1)| + |R(a, 2)|). Every crossing near
    // a block at sensor-frame centre c thus lies in the sensor-axis box c +- ext_ (exact for the
    // cube's projection on each axis; at most the old sphere's radius, 1.5 sqrt(3) voxels, which
    // it reaches when the axis runs along a cube diagonal). The z range of a block is therefore
    // c_z +- ext_[2] and its footprint the box's (footprints(), centres()).
    for (int a = 0; a < 3; ++a)
      ext_[a] = kCubeHalfVoxels * voxel_m *
                (std::fabs(T_cam_world.R(a, 0)) + std::fabs(T_cam_world.R(a, 1)) + std::fabs(T_cam_world.R(a, 2)));
    for (int bit = 0; bit < 64; ++bit) {
      const Vec3f o = float(bit & 3) * step_[0] + float((bit >> 2) & 3) * step_[1] + float(bit >> 4) * step_[2];
      ox_[bit] = o.x();
      oy_[bit] = o.y();
      oz_[bit] = o.z();
    }
  }

  //! Splats one brick.
  //! \param sides the brick's front and back blocks (bit (z/2)*16 + (y/2)*4 + x/2)
  //! \param c0 sensor-frame centre of the brick's block (0, 0, 0)
  void brick(const Sides& sides, const Vec3f& c0) const {
    if (dilate_ && brick_radius(c0)) {
      centres(sides, c0);
    } else {
      footprints(sides, c0);
    }
  }

 private:
  // True when every block's footprint lies within kCentresRadius pixels of its projected centre
  // (then centres() writes few rows and columns); false also when a block may be near or behind
  // the sensor plane. For a point q of the box c +- ext_, q_x / q_z - c_x / c_z = ((q_x - c_x) c_z
  // - c_x (q_z - c_z)) / (q_z c_z), so |q_x / q_z - c_x / c_z| <= (ext_x + |c_x / c_z| ext_z) /
  // (c_z - ext_z) for every point of the box (no sphere around it); over the brick it is bounded
  // with the block centres' smallest z and largest |x|, |y| (the lattice's extreme corners).
  bool brick_radius(const Vec3f& c0) const {
    float lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = hi[a] = c0(a);
      for (int k = 0; k < 3; ++k) {
        const float e = 3.0f * step_[k](a);
        (e < 0.0f ? lo[a] : hi[a]) += e;
      }
    }
    const float z_min = lo[2] - ext_[2];
    if (!(z_min > 0.05f * lo[2])) return false;  // near the sensor: footprints grow fast
    const float ax = std::max(-lo[0], hi[0]) / lo[2], ay = std::max(-lo[1], hi[1]) / lo[2];
    const float r_u = intr_.fx * (ext_[0] + ax * ext_[2]) / z_min;
    const float r_v = intr_.fy * (ext_[1] + ay * ext_[2]) / z_min;
    return r_u <= kCentresRadius && r_v <= kCentresRadius;  // centres() relies on it
  }

  // The fast path: each block's box footprint, as footprints() computes it, four blocks at a
  // time, written shrunk by kDilate (dilate() widens it back). brick_radius() bounds every block's
  // footprint by the brick's radius, so the rows and columns to write are few (kCentresSpan).
  // A group of fewer than four repeats its last block (a repeated minimum changes nothing).
  void centres(const Sides& sides, const Vec3f& c0) const {
    using namespace lanes;
    const int w = intr_.width, h = intr_.height;
    const F4 eps_px = splat_f(0.01f);  // rounding of the projection
    const F4 cx = splat_f(c0.x()), cy = splat_f(c0.y()), cz = splat_f(c0.z());
    const F4 ex = splat_f(ext_[0]), ey = splat_f(ext_[1]), ez = splat_f(ext_[2]);
    const F4 fx = splat_f(intr_.fx), fy = splat_f(intr_.fy), pcx = splat_f(intr_.cx), pcy = splat_f(intr_.cy);
    const F4 one = splat_f(1.0f), zero_f = splat_f(0.0f);
    const F4 px_lo = splat_f(-kShift), px_hi = splat_f(3.0f * kShift), shift = splat_f(kShift);
    const F4 inv_unit = splat_f(q_.inv_unit), top = splat_f(float(Quant::kTop));
    const I4 zero = splat_i(0), empty = splat_i(kEmpty), ishift = splat_i(kIShift);
    const int16_t w1 = int16_t(w - 1), h1 = int16_t(h - 1);
    const S8 zero8 = S8{0, 0, 0, 0, 0, 0, 0, 0}, last8 = S8{w1, w1, w1, w1, h1, h1, h1, h1};
    const S8 span8 = zero8 + int16_t(2 * kDilate), dil8 = zero8 + int16_t(kDilate);
    uint64_t mask = sides.front | sides.back;
    while (mask != 0) {
      int bit[4];
      int n = 0;
      for (; n < 4 && mask != 0; ++n) {
        bit[n] = __builtin_ctzll(mask);
        mask &= mask - 1;
      }
      for (int l = n; l < 4; ++l) bit[l] = bit[n - 1];
      const F4 z = cz + F4{oz_[bit[0]], oz_[bit[1]], oz_[bit[2]], oz_[bit[3]]};
      const F4 x = cx + F4{ox_[bit[0]], ox_[bit[1]], ox_[bit[2]], ox_[bit[3]]};
      const F4 y = cy + F4{oy_[bit[0]], oy_[bit[1]], oy_[bit[2]], oy_[bit[3]]};
      // footprints()' box lane-wise: the box has x in [x - ex, x + ex] and z in [z_lo, z_hi]
      // (z_lo > 0: brick_radius() checked the brick's smallest z), so x / z lies between the
      // four ratios of those ends (likewise y). One division for both reciprocals.
      const F4 z_lo = z - ez, z_hi = z + ez;
      const F4 inv = one / (z_lo * z_hi);
      const F4 i_lo = z_hi * inv, i_hi = z_lo * inv;
      const F4 xa = x - ex, xb = x + ex, ya = y - ey, yb = y + ey;
      const F4 u_lo = fx * min_f(xa * i_lo, xa * i_hi) + pcx, u_hi = fx * max_f(xb * i_lo, xb * i_hi) + pcx;
      const F4 v_lo = fy * min_f(ya * i_lo, ya * i_hi) + pcy, v_hi = fy * max_f(yb * i_lo, yb * i_hi) + pcy;
      // floor_px lane-wise: iu0 = -floor_px(eps - u_lo) (the first pixel at or after u_lo - eps),
      // iu1 = floor_px(u_hi + eps); the clamp keeps the conversion defined for blocks far off
      // the axis (a clamped end lies outside any image, and the test below drops the block).
      const I4 iu0 = ishift - __builtin_convertvector(min_f(max_f(eps_px - u_lo, px_lo), px_hi) + shift, I4);
      const I4 iu1 = __builtin_convertvector(min_f(max_f(u_hi + eps_px, px_lo), px_hi) + shift, I4) - ishift;
      const I4 iv0 = ishift - __builtin_convertvector(min_f(max_f(eps_px - v_lo, px_lo), px_hi) + shift, I4);
      const I4 iv1 = __builtin_convertvector(min_f(max_f(v_hi + eps_px, px_lo), px_hi) + shift, I4) - ishift;
      // The pixel ends lie in [-12288, 12288]: as int16 (u in lanes 0-3, v in 4-7) the shrink and
      // the clamps below are 8 lanes of single minima and maxima.
      S8 lo = __builtin_convertvector(__builtin_shufflevector(iu0, iv0, 0, 1, 2, 3, 4, 5, 6, 7), S8);
      S8 hi = __builtin_convertvector(__builtin_shufflevector(iu1, iv1, 0, 1, 2, 3, 4, 5, 6, 7), S8);
      const S8 in = (hi >= zero8) & (lo <= last8);  // lane l and l + 4 both: the block is in the image
      // Quant::floor_q / ceil_q lane-wise: clamped into [0, kTop], truncated, and rounded up
      // where the truncation lost a fraction.
      const F4 qn = min_f(max_f(z_lo * inv_unit, zero_f), top);
      const F4 qf = min_f(max_f(z_hi * inv_unit, zero_f), top);
      const I4 tf = __builtin_convertvector(qf, I4);
      const I4 near_q = __builtin_convertvector(qn, I4);
      const I4 far_q = tf - (__builtin_convertvector(tf, F4) < qf);  // true lanes are -1
      const I4 is_front = I4{int32_t(sides.front >> bit[0]), int32_t(sides.front >> bit[1]),
                             int32_t(sides.front >> bit[2]), int32_t(sides.front >> bit[3])} & 1;
      const I4 is_back = I4{int32_t(sides.back >> bit[0]), int32_t(sides.back >> bit[1]),
                            int32_t(sides.back >> bit[2]), int32_t(sides.back >> bit[3])} & 1;
      const I4 nh = is_front != zero ? near_q - 32768 : empty;
      const I4 fh = is_back != zero ? 32767 - far_q : empty;
      // shrink() and clamp() lane-wise.
      const S8 mid = (lo + hi) >> 1;
      const S8 wide = hi - lo >= span8;
      lo = wide ? lo + dil8 : mid;
      hi = wide ? hi - dil8 : mid;
      lo = lo > last8 ? last8 : lo;
      lo = lo < zero8 ? zero8 : lo;
      hi = hi > last8 ? last8 : hi;
      hi = hi < zero8 ? zero8 : hi;
      for (int l = 0; l < n; ++l) {
        if ((in[l] & in[l + 4]) == 0) continue;
        const int16_t nh_l = int16_t(nh[l]), fh_l = int16_t(fh[l]);
        const int u0 = lo[l], u1 = hi[l], v0 = lo[l + 4], v1 = hi[l + 4];
        // Rects at most four pixels wide (most of them at kDilate = 1): one masked vector of four
        // pixels per row, lanes beyond the rect kEmpty (measured on bin_rig_a: prepare -14 % thread
        // CPU against per-pixel writes, whose loop lengths of 1-5 mispredict; merge_rect's aligned
        // groups gave no gain). Wider rects, and rects at the right border, pixel by pixel in
        // bounded loops with an early exit.
        if (u1 - u0 < 4 && u0 + 4 <= w) {
          const S8 val = pair_lanes(S8{nh_l, fh_l, nh_l, fh_l, nh_l, fh_l, nh_l, fh_l}, 0, u1 - u0);
          for (int j = 0; j < kCentresSpan && v0 + j <= v1; ++j) {
            alias_i16* p = reinterpret_cast<alias_i16*>(depth_.row(v0 + j)) + 2 * u0;
            store8(p, min8(load8(p), val));
          }
          continue;
        }
        for (int j = 0; j < kCentresSpan && v0 + j <= v1; ++j) {
          alias_i16* p = reinterpret_cast<alias_i16*>(depth_.row(v0 + j)) + 2 * u0;
          for (int i = 0; i < kCentresSpan && u0 + i <= u1; ++i, p += 2) {
            p[0] = p[0] < nh_l ? p[0] : nh_l;
            p[1] = p[1] < fh_l ? p[1] : fh_l;
          }
        }
      }
    }
  }

  // Largest footprint radius (pixels) of the bricks centres() takes: a box of half-width r spans
  // at most 2 (r + eps) + 1 pixels, 2 kDilate fewer after the shrink; one more for rounding.
  // (kDilate + 2: at kDilate = 1 the bricks of r in (2, 3] px, most of bin_rig_a's, took the
  // scalar per-block path otherwise: prepare +13 % instructions.)
  static constexpr float kCentresRadius = float(kDilate + 2);
  static constexpr int kCentresSpan = 2 * (kDilate + 2) + 2 - 2 * kDilate;
  static constexpr float kShift = 4096.0f;
  static constexpr int kIShift = 4096;

  // The general path: each block's whole footprint (near the sensor, or without dilation).
  void footprints(const Sides& sides, const Vec3f& c0) const {
    const int d = dilate_ ? kDilate : 0;  // dilate() widens every written pixel by d
    const float eps_px = 0.01f;  // rounding of the projection
    uint64_t mask = sides.front | sides.back;
    while (mask != 0) {
      const int bit = __builtin_ctzll(mask);
      mask &= mask - 1;
      const Vec3f c(c0.x() + ox_[bit], c0.y() + oy_[bit], c0.z() + oz_[bit]);
      const float z_lo = c.z() - ext_[2], z_hi = c.z() + ext_[2];
      if (!(z_hi > 0.0f)) continue;  // behind the sensor
      const int16_t nh = (sides.front >> bit) & 1u ? near_half(q_.floor_q(z_lo)) : kEmpty;
      const int16_t fh = (sides.back >> bit) & 1u ? far_half(q_.ceil_q(z_hi)) : kEmpty;
      if (!(z_lo > 1e-3f)) {  // straddles the sensor plane: may cover any pixel
        merge_rect(depth_, 0, intr_.width - 1, 0, intr_.height - 1, nh, fh, aligned_);
        continue;
      }
      // The box's points have x in [c.x - ext_x, c.x + ext_x] and z in [z_lo, z_hi]: x / z lies
      // between the four ratios of those ends (likewise y). One division for both reciprocals.
      const float inv = 1.0f / (z_lo * z_hi);
      const float i_lo = z_hi * inv, i_hi = z_lo * inv;
      const float xa = c.x() - ext_[0], xb = c.x() + ext_[0], ya = c.y() - ext_[1], yb = c.y() + ext_[1];
      const float u_lo = intr_.fx * std::min(xa * i_lo, xa * i_hi) + intr_.cx;
      const float u_hi = intr_.fx * std::max(xb * i_lo, xb * i_hi) + intr_.cx;
      const float v_lo = intr_.fy * std::min(ya * i_lo, ya * i_hi) + intr_.cy;
      const float v_hi = intr_.fy * std::max(yb * i_lo, yb * i_hi) + intr_.cy;
      // The pixels the box can cover: [iu0, iu1] x [iv0, iv1] (not yet clipped to the image).
      int iu0 = -floor_px(eps_px - u_lo), iu1 = floor_px(u_hi + eps_px);
      int iv0 = -floor_px(eps_px - v_lo), iv1 = floor_px(v_hi + eps_px);
      if (iu1 < 0 || iv1 < 0 || iu0 >= intr_.width || iv0 >= intr_.height) continue;
      // Write the footprint shrunk by d (at least its middle pixel), so that the widened result is
      // the footprint again.
      shrink(iu0, iu1, d);
      shrink(iv0, iv1, d);
      iu0 = clamp(iu0, intr_.width), iu1 = clamp(iu1, intr_.width);
      iv0 = clamp(iv0, intr_.height), iv1 = clamp(iv1, intr_.height);
      merge_rect(depth_, iu0, iu1, iv0, iv1, nh, fh, aligned_);
    }
  }

  static void shrink(int& lo, int& hi, int d) {
    if (hi - lo >= 2 * d) {
      lo += d;
      hi -= d;
    } else {
      lo = hi = (lo + hi) >> 1;
    }
  }
  // Clamping a range's ends into the image keeps every image pixel within d of it that was
  // within d of the range.
  static int clamp(int i, int size) { return i < 0 ? 0 : (i >= size ? size - 1 : i); }

  // floor() of a pixel coordinate without a libm call: clamped far outside any image (the result
  // only needs to stay outside it), shifted positive and truncated.
  static int floor_px(float x) {
    x = std::min(std::max(x, -4096.0f), 12288.0f);
    return int(x + 4096.0f) - 4096;
  }

  const ImageView<float>& depth_;
  const PinholeIntrinsics& intr_;
  const Quant q_;
  const bool dilate_;
  const bool aligned_;  // merge_rect() may use aligned groups of four pixels
  Vec3f step_[3];
  float ext_[3];  // half extents of a block's crossing cube along the sensor axes (metres)
  float ox_[64], oy_[64], oz_[64];  // block (bit) centre minus block 0's, sensor frame
};

}  // namespace raycast_bounds
}  // namespace edgefuse
