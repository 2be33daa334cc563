// Projections of four points at once for the integration kernel (private to src/): the voxels of
// one x-row of a 4^3 block, and the 8 corners of a box being classified (two groups of four).
//
// Why: projecting each voxel and testing its pixel was about a third of the voxel loop's
// instructions, and the 8 corner projections half of the box classification's. The points of a
// group are independent, so the float build computes them as one 4-lane vector (GCC vector
// extensions: SSE2 on x86-64, NEON on aarch64; lowered to scalar code where neither exists) and
// the fixed-point build lane by lane (Q16.16 has no vector unit to map to).
//
// Both give exactly what a scalar loop computes: the points come from the same additions in the
// same order (a row: p, p + s, (p + s) + s, ...), and each lane runs the same IEEE (or Q16.16)
// operations as the scalar voxel update, so the stored volume is bit-identical.
#pragma once

#include <cstdint>

#include "edgefuse/math/real.hpp"
#include "kernel_math.hpp"
#include "lanes.hpp"

namespace edgefuse {

constexpr int kRowLanes = 4;  //!< voxels per x-row of a 4^3 block

//! The projection of a row's voxels; lanes outside the mask project_row returns hold garbage.
template <class Real>
struct RowProjection {
  Real z[kRowLanes];       //!< camera-frame z of each voxel
  Real pu[kRowLanes];      //!< image coordinates (pixel centres are integers)
  Real pv[kRowLanes];
  int32_t iu[kRowLanes];   //!< nearest pixel
  int32_t iv[kRowLanes];
  int32_t pix[kRowLanes];  //!< its index in the depth image: iv * stride + iu
  //! floor(pu), floor(pv): the top-left pixel of the bilinear window (float build; the fixed-point
  //! build leaves them to lane_floor, which costs it a shift per voxel that reaches the lookup).
  int32_t u0[kRowLanes];
  int32_t v0[kRowLanes];
  int32_t win[kRowLanes];  //!< index of pixel (u0, v0) in the depth image (float build)
  int32_t tile[kRowLanes];     //!< index of the nearest pixel's 8x8 depth tile (float build)
  int32_t nearest[kRowLanes];  //!< raw depth of the nearest pixel
  Real z_near[kRowLanes];      //!< the same in metres
};

//! What the nearest-pixel tests of a row read.
template <class Real>
struct RowDepth {
  const uint16_t* px;      //!< depth pixels (index pix)
  DepthScale<Real> scale;  //!< raw depth -> metres
  Real jump;               //!< largest depth step interpolated across, metres
  Real minus_rho;          //!< -rho: a voxel further behind every depth it may read is not updated
};

//! Pinhole projection parameters of one frame, in the kernel scalar.
template <class Real>
struct LaneCamera {
  Real fx, fy, cx, cy;  //!< focal lengths and principal point in pixels
  int width, height;    //!< image size in pixels
  float width_f, height_f;  //!< the same as floats (exact)
  int stride;           //!< depth image row stride in pixels
  float stride_f;       //!< the same as a float (exact; stride * height < 2^24, see project_row)
  float tiles_x_f;      //!< 8x8-pixel depth tiles per image row, as a float
};

namespace lanes_detail {
using namespace lane_types;  // lanes.hpp

// Lane mask (bit k = lane k) of a comparison result (lanes 0 or -1): the lane bits ORed across
// the vector by two shuffles, fewer instructions than extracting each lane.
inline unsigned mask_of(I4 m) {
  const I4 bits = m & I4{1, 2, 4, 8};
  const I4 pairs = bits | __builtin_shufflevector(bits, bits, 2, 3, 0, 1);
  const I4 all = pairs | __builtin_shufflevector(pairs, pairs, 1, 0, 3, 2);
  return unsigned(all[0]);
}
}  // namespace lanes_detail

//! Projects the 4 voxels p0 + k s (k = 0..3) and reads their nearest pixels. Returns a lane mask:
//! bit k is set when voxel k lies at least `near_z` in front of the sensor, its nearest pixel is
//! inside the image and holds a depth, and the voxel is not certainly occluded (more than rho
//! behind that depth plus a depth jump: an interpolated depth is at most a jump beyond it).
//! \param cam projection parameters
//! \param p0 camera-frame centre of the row's first voxel
//! \param s camera-frame step from one voxel of the row to the next
//! \param near_z voxels closer than this are not projected
//! \param depth the depth image and the occlusion test's constants
//! \param out projections and nearest depths of the lanes in the mask
inline unsigned project_row(const LaneCamera<float>& cam, const float p0[3], const float s[3], float near_z,
                            const RowDepth<float>& depth, RowProjection<float>& out) {
  using namespace lanes_detail;
  // Lane k = p0 + s added k times, as a chain of vector additions that adds s (or 0) per lane:
  // the same roundings as p, p + s, (p + s) + s, ... (p0 + 0 = p0; a -0 turning +0 projects alike).
  const F4 m1 = {0.0f, 1.0f, 1.0f, 1.0f}, m2 = {0.0f, 0.0f, 1.0f, 1.0f}, m3 = {0.0f, 0.0f, 0.0f, 1.0f};
  F4 x = p0[0] + m1 * s[0], y = p0[1] + m1 * s[1], z = p0[2] + m1 * s[2];
  x += m2 * s[0];
  y += m2 * s[1];
  z += m2 * s[2];
  x += m3 * s[0];
  y += m3 * s[1];
  z += m3 * s[2];
  const F4 inv_z = 1.0f / z;  // lanes behind the near plane are masked below
  const F4 pu = cam.fx * (x * inv_z) + cam.cx;
  const F4 pv = cam.fy * (y * inv_z) + cam.cy;
  // pixel_of on each lane: index = int(x + 0.5) when 0 <= x + 0.5 < size (NaN fails).
  const F4 su = pu + 0.5f, sv = pv + 0.5f;
  const F4 zero = {};
  const I4 live = (z >= near_z) & (su >= 0.0f) & (su < cam.width_f) & (sv >= 0.0f) & (sv < cam.height_f);
  // Dead lanes are converted from 0: their coordinates may be out of int range.
  const I4 iu = __builtin_convertvector(live ? su : zero, I4);
  const I4 iv = __builtin_convertvector(live ? sv : zero, I4);
  const F4 iu_f = __builtin_convertvector(iu, F4), iv_f = __builtin_convertvector(iv, F4);
  // The pixel index in float: exact while stride * height < 2^24 (4096 x 4096), and SSE2 has no
  // 32-bit integer multiply (GCC emulates it with two 64-bit multiplies and three shuffles).
  const I4 pix = __builtin_convertvector(iv_f * cam.stride_f + iu_f, I4);
  // floor(x) from the nearest pixel i = int(x + 0.5), which is floor(x) or floor(x) + 1 for a
  // live lane (x >= -0.5): one less when x < i. The same integers as floor_int, per lane in the
  // vector instead of two conversions and a compare per voxel in the bilinear lookup. (A scalar
  // select `i - (x < i)` is compiled as a branch.)
  const I4 below_u = pu < iu_f, below_v = pv < iv_f;  // lanes 0 or -1
  const I4 u0 = iu + below_u, v0 = iv + below_v;
  const I4 win = pix + below_u - (below_v & I4{cam.stride, cam.stride, cam.stride, cam.stride});
  // The nearest pixels' depths and the first two exits of the voxel loop (no depth; occluded) for
  // the 4 lanes at once: the same operations per lane as the scalar tests, one mask test per
  // voxel instead of two data-dependent branches. Dead lanes read pixel 0 (their index is 0).
  const I4 nearest = {depth.px[pix[0]], depth.px[pix[1]], depth.px[pix[2]], depth.px[pix[3]]};
  const F4 z_near = __builtin_convertvector(nearest, F4) * depth.scale.inv;
  const I4 keep = live & (nearest != 0) & ((z_near + depth.jump) - z >= depth.minus_rho);
  // The 8x8 tile of the nearest pixel (free-space test), in float like pix.
  const I4 tile = __builtin_convertvector(__builtin_convertvector(iv >> 3, F4) * cam.tiles_x_f +
                                              __builtin_convertvector(iu >> 3, F4), I4);
  for (int k = 0; k < kRowLanes; ++k) {
    out.z[k] = z[k];
    out.pu[k] = pu[k];
    out.pv[k] = pv[k];
    out.iu[k] = iu[k];
    out.iv[k] = iv[k];
    out.pix[k] = pix[k];
    out.u0[k] = u0[k];
    out.v0[k] = v0[k];
    out.win[k] = win[k];
    out.tile[k] = tile[k];
    out.nearest[k] = nearest[k];
    out.z_near[k] = z_near[k];
  }
  return mask_of(keep);
}

//! Fixed point: the same lane by lane.
inline unsigned project_row(const LaneCamera<Fixed>& cam, const Fixed p0[3], const Fixed s[3], Fixed near_z,
                            const RowDepth<Fixed>& depth, RowProjection<Fixed>& out) {
  unsigned live = 0;
  Fixed p[3] = {p0[0], p0[1], p0[2]};
  for (int k = 0; k < kRowLanes; ++k, p[0] += s[0], p[1] += s[1], p[2] += s[2]) {
    out.z[k] = p[2];
    if (p[2] < near_z) continue;
    const Fixed inv_z = Fixed::from_int(1) / p[2];
    out.pu[k] = cam.fx * (p[0] * inv_z) + cam.cx;
    out.pv[k] = cam.fy * (p[1] * inv_z) + cam.cy;
    int iu, iv;
    if (!pixel_of(out.pu[k], cam.width, iu) || !pixel_of(out.pv[k], cam.height, iv)) continue;
    out.iu[k] = iu;
    out.iv[k] = iv;
    out.pix[k] = iv * cam.stride + iu;
    const uint16_t nearest = depth.px[out.pix[k]];
    if (nearest == 0) continue;
    const Fixed z_near = depth.scale.metres(nearest);
    if (z_near + depth.jump - p[2] < depth.minus_rho) continue;
    out.nearest[k] = nearest;
    out.z_near[k] = z_near;
    live |= 1u << k;
  }
  return live;
}

//! floor(pu) and floor(pv) of live lane k and the index of that pixel in the depth image:
//! precomputed in the float build, computed here in Q16.16.
inline void lane_floor(const RowProjection<float>& rp, int k, int /*stride*/, int& u0, int& v0, int& win) {
  u0 = rp.u0[k];
  v0 = rp.v0[k];
  win = rp.win[k];
}
inline void lane_floor(const RowProjection<Fixed>& rp, int k, int stride, int& u0, int& v0, int& win) {
  u0 = floor_int(rp.pu[k]);
  v0 = floor_int(rp.pv[k]);
  win = rp.pix[k] - (rp.iu[k] - u0) - (rp.iv[k] - v0) * stride;
}

//! Index of lane k's 8x8 depth tile: precomputed in the float build, computed here in Q16.16.
inline int lane_tile(const RowProjection<float>& rp, int k, int /*tiles_x*/) { return rp.tile[k]; }
inline int lane_tile(const RowProjection<Fixed>& rp, int k, int tiles_x) {
  return (rp.iv[k] >> 3) * tiles_x + (rp.iu[k] >> 3);
}

//! Image-space bounds of a box's 8 corners.
template <class Real>
struct BoxBounds {
  Real z_lo, z_hi;  //!< camera-frame z range
  //! Pixels a voxel of the box may read: floor(u_lo) - 1 .. floor(u_hi) + 2 (bilinear reaches one
  //! pixel further), likewise in v; u_lo, u_hi, v_lo, v_hi are the projected corners' ranges,
  //! u_lo and v_lo at most 2^20, u_hi and v_hi at least -2^20.
  int a0, a1, b0, b1;
};

//! Projects the 8 corners c0 + the spans of the set bits of k (added in axis order: corner 3 =
//! (c0 + s0) + s1). Returns false when a corner is closer than `near_z` (no bound then).
//! \param cam projection parameters
//! \param c0 camera-frame corner 0
//! \param span camera-frame edge vectors of the box along the three grid axes
//! \param near_z corners closer than this give no bound
//! \param out the bounds
inline bool project_box(const LaneCamera<float>& cam, const float c0[3], const float span[3][3], float near_z,
                        BoxBounds<float>& out) {
  using namespace lanes_detail;
  F4 lo[3], hi[3];  // corners 0-3 and 4-7, per coordinate
  for (int r = 0; r < 3; ++r) {
    const float c1 = c0[r] + span[0][r];
    lo[r] = F4{c0[r], c1, c0[r] + span[1][r], c1 + span[1][r]};
    hi[r] = lo[r] + span[2][r];
  }
  const I4 close = (lo[2] < near_z) | (hi[2] < near_z);
  if ((close[0] | close[1] | close[2] | close[3]) != 0) return false;
  const F4 inv_lo = 1.0f / lo[2], inv_hi = 1.0f / hi[2];
  const F4 u_a = cam.fx * (lo[0] * inv_lo) + cam.cx, u_b = cam.fx * (hi[0] * inv_hi) + cam.cx;
  const F4 v_a = cam.fy * (lo[1] * inv_lo) + cam.cy, v_b = cam.fy * (hi[1] * inv_hi) + cam.cy;
  // Lane-wise minimum / maximum of the two groups, then across the lanes by two shuffles each
  // (order-free: min and max of the same values are the same values; the corners are finite, in
  // front of the sensor). The image bounds are clamped to +-2^20, as in the scalar path.
  const F4 z_min = lo[2] < hi[2] ? lo[2] : hi[2], z_max = lo[2] > hi[2] ? lo[2] : hi[2];
  const F4 u_min = u_a < u_b ? u_a : u_b, u_max = u_a > u_b ? u_a : u_b;
  const F4 v_min = v_a < v_b ? v_a : v_b, v_max = v_a > v_b ? v_a : v_b;
  auto lane_min = [](F4 a) {  // across the lanes: swap pairs, then neighbours
    a = min_f(a, __builtin_shufflevector(a, a, 2, 3, 0, 1));
    a = min_f(a, __builtin_shufflevector(a, a, 1, 0, 3, 2));
    return a[0];
  };
  auto lane_max = [](F4 a) {
    a = max_f(a, __builtin_shufflevector(a, a, 2, 3, 0, 1));
    a = max_f(a, __builtin_shufflevector(a, a, 1, 0, 3, 2));
    return a[0];
  };
  out.z_lo = lane_min(z_min);
  out.z_hi = lane_max(z_max);
  // The four image bounds at once: rows (u_min, v_min, -u_max, -v_max) transposed, so that lane-
  // wise minima give (u_lo, v_lo, -u_hi, -v_hi) (a maximum is minus the minimum of the negated
  // values, exactly), clamped to +-2^20 (a minimum and a maximum: a corner far outside the image
  // must not overflow the int32 conversion), signs restored, floored (trunc, one less
  // where that is above: the same integers as floor_int) and widened by the bilinear margin.
  const F4 n_u = -u_max, n_v = -v_max;
  const F4 t0 = __builtin_shufflevector(u_min, v_min, 0, 4, 1, 5), t1 = __builtin_shufflevector(u_min, v_min, 2, 6, 3, 7);
  const F4 t2 = __builtin_shufflevector(n_u, n_v, 0, 4, 1, 5), t3 = __builtin_shufflevector(n_u, n_v, 2, 6, 3, 7);
  const F4 k0 = __builtin_shufflevector(t0, t2, 0, 1, 4, 5), k1 = __builtin_shufflevector(t0, t2, 2, 3, 6, 7);
  const F4 k2 = __builtin_shufflevector(t1, t3, 0, 1, 4, 5), k3 = __builtin_shufflevector(t1, t3, 2, 3, 6, 7);
  auto vmin = [](F4 a, F4 b) { return a < b ? a : b; };
  auto vmax = [](F4 a, F4 b) { return a > b ? a : b; };
  const F4 kBound = {float(1 << 20), float(1 << 20), float(1 << 20), float(1 << 20)};
  const F4 bounds = vmax(vmin(vmin(vmin(k0, k1), vmin(k2, k3)), kBound), -kBound) * F4{1.0f, 1.0f, -1.0f, -1.0f};
  const I4 t = __builtin_convertvector(bounds, I4);
  const I4 fl = t + (bounds < __builtin_convertvector(t, F4));
  const I4 px = fl + I4{-1, -1, 2, 2};
  out.a0 = px[0];
  out.b0 = px[1];
  out.a1 = px[2];
  out.b1 = px[3];
  return true;
}

//! Fixed point: the same corner by corner.
inline bool project_box(const LaneCamera<Fixed>& cam, const Fixed c0[3], const Fixed span[3][3], Fixed near_z,
                        BoxBounds<Fixed>& out) {
  Fixed corner[8][3];
  for (int r = 0; r < 3; ++r) {
    corner[0][r] = c0[r];
    corner[1][r] = c0[r] + span[0][r];
    corner[2][r] = c0[r] + span[1][r];
    corner[3][r] = corner[1][r] + span[1][r];
    for (int k = 0; k < 4; ++k) corner[k + 4][r] = corner[k][r] + span[2][r];
  }
  out.z_lo = out.z_hi = c0[2];
  Fixed u_lo = Fixed::from_int(1 << 20), v_lo = u_lo;
  Fixed u_hi = Fixed::from_int(-(1 << 20)), v_hi = u_hi;
  for (int k = 0; k < 8; ++k) {
    const Fixed* p = corner[k];
    if (p[2] < near_z) return false;
    const Fixed inv_z = Fixed::from_int(1) / p[2];
    const Fixed u = cam.fx * (p[0] * inv_z) + cam.cx, v = cam.fy * (p[1] * inv_z) + cam.cy;
    out.z_lo = p[2] < out.z_lo ? p[2] : out.z_lo;
    out.z_hi = p[2] > out.z_hi ? p[2] : out.z_hi;
    u_lo = u < u_lo ? u : u_lo;
    u_hi = u > u_hi ? u : u_hi;
    v_lo = v < v_lo ? v : v_lo;
    v_hi = v > v_hi ? v : v_hi;
  }
  out.a0 = floor_int(u_lo) - 1;
  out.a1 = floor_int(u_hi) + 2;
  out.b0 = floor_int(v_lo) - 1;
  out.b1 = floor_int(v_hi) + 2;
  return true;
}

}  // namespace edgefuse
