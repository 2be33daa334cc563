// Shared by extract_points.cpp and marching_cubes.cpp (private to src/tsdf): brick-major grid
// neighbour steps, the TSDF gradient and the sample (position, normal, colour) at an edge's zero crossing.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse {
namespace extract_detail {

//! Step between neighbouring voxels inside a brick along x, y, z.
inline constexpr std::ptrdiff_t kInBrickStep[3] = {1, kBrickSide, kBrickSide * kBrickSide};

inline bool in_band(int16_t t) { return t > -kTsdfMax && t < kTsdfMax; }

//! Read-only view of a volume: its arrays, and the neighbour steps of its brick pool (inside a
//! brick a fixed stride, across a brick face through the index).
struct Grid {
  const TsdfVolume& volume;
  const int16_t* tsdf;
  const uint8_t* weight;
  const Rgb8* colour;            //!< null without colour
  const uint8_t* colour_weight;  //!< null without colour
  const uint8_t* flags;
  int dim;
  int nb;                       //!< bricks per axis
  Vec3f origin;
  float voxel;

  explicit Grid(const TsdfVolume& v)
      : volume(v),
        tsdf(v.tsdf()),
        weight(v.weight()),
        colour(v.colour()),
        colour_weight(v.colour_weight()),
        flags(v.brick_flags()),
        dim(v.dim()),
        nb(v.bricks_per_axis()),
        origin(v.origin_m()),
        voxel(v.voxel_m()) {}

  //! Index of the +1 neighbour along axis d of voxel c (index idx); c[d] + 1 must lie in the grid.
  std::size_t up(std::size_t idx, const int c[3], int d) const {
    if ((c[d] & (kBrickSide - 1)) != kBrickSide - 1) return idx + std::size_t(kInBrickStep[d]);
    int n[3] = {c[0], c[1], c[2]};
    ++n[d];
    return volume.index(n[0], n[1], n[2]);
  }
  //! Index of the -1 neighbour along axis d of voxel c (index idx); c[d] - 1 must lie in the grid.
  std::size_t down(std::size_t idx, const int c[3], int d) const {
    if ((c[d] & (kBrickSide - 1)) != 0) return idx - std::size_t(kInBrickStep[d]);
    int n[3] = {c[0], c[1], c[2]};
    --n[d];
    return volume.index(n[0], n[1], n[2]);
  }
};

//! TSDF gradient at voxel c (index idx) in stored units per voxel. Central differences; where a
//! neighbour is outside the volume, unobserved or truncated (its value clamped), the one-sided
//! difference towards the other neighbour; truncated neighbours are used only when nothing better
//! exists; 0 along an axis without observed neighbours.
inline Vec3f gradient(const Grid& g, const int c[3], std::size_t idx) {
  const float t0 = float(g.tsdf[idx]);
  Vec3f grad;
  for (int d = 0; d < 3; ++d) {
    int tier_p = 0, tier_m = 0;  // 0: unusable, 1: observed but truncated, 2: observed, in band
    float tp = 0.0f, tm = 0.0f;
    if (c[d] + 1 < g.dim) {
      const std::size_t j = g.up(idx, c, d);
      if (g.weight[j] != 0) {
        tp = float(g.tsdf[j]);
        tier_p = in_band(g.tsdf[j]) ? 2 : 1;
      }
    }
    if (c[d] > 0) {
      const std::size_t j = g.down(idx, c, d);
      if (g.weight[j] != 0) {
        tm = float(g.tsdf[j]);
        tier_m = in_band(g.tsdf[j]) ? 2 : 1;
      }
    }
    float v = 0.0f;
    if (tier_p == tier_m && tier_p > 0)
      v = 0.5f * (tp - tm);
    else if (tier_p > tier_m)
      v = tp - t0;
    else if (tier_m > tier_p)
      v = t0 - tm;
    grad[d] = v;
  }
  return grad;
}

struct EdgeSample {
  Vec3f position;
  Vec3f normal;
  Rgba8 colour;
};

inline uint8_t lerp_u8(uint8_t a, uint8_t b, float s) {
  return uint8_t(float(a) + (float(b) - float(a)) * s + 0.5f);
}

//! The zero crossing on the edge from voxel a = c (index ia) to its +1 neighbour along `axis`
//! (index ib); the caller guarantees tsdf[ia] and tsdf[ib] have different signs (< 0 vs >= 0).
inline void edge_sample(const Grid& g, const int c[3], std::size_t ia, int axis, std::size_t ib, EdgeSample& out) {
  const float ta = float(g.tsdf[ia]);
  const float tb = float(g.tsdf[ib]);
  const float s = ta / (ta - tb);  // in [0, 1]
  Vec3f p(float(c[0]) + 0.5f, float(c[1]) + 0.5f, float(c[2]) + 0.5f);
  p[axis] += s;
  out.position = g.origin + p * g.voxel;

  int cb[3] = {c[0], c[1], c[2]};
  ++cb[axis];
  Vec3f n = gradient(g, c, ia) * (1.0f - s) + gradient(g, cb, ib) * s;
  const float len = n.norm();
  if (len > 1e-6f) {
    n /= len;
  } else {  // no usable neighbourhood: the edge direction, towards the positive end
    n = Vec3f::Zero();
    n[axis] = tb > ta ? 1.0f : -1.0f;
  }
  out.normal = n;

  Rgba8 col;  // a = 0: never seen in colour
  if (g.colour != nullptr) {
    const bool ca = g.colour_weight[ia] != 0;
    const bool cbw = g.colour_weight[ib] != 0;
    if (ca && cbw) {
      const Rgb8& x = g.colour[ia];
      const Rgb8& y = g.colour[ib];
      col.r = lerp_u8(x.r, y.r, s);
      col.g = lerp_u8(x.g, y.g, s);
      col.b = lerp_u8(x.b, y.b, s);
      col.a = 255;
    } else if (ca || cbw) {
      const Rgb8& x = g.colour[ca ? ia : ib];
      col.r = x.r;
      col.g = x.g;
      col.b = x.b;
      col.a = 255;
    }
  }
  out.colour = col;
}

}  // namespace extract_detail
}  // namespace edgefuse
