// Trilinear reads of the TSDF and colour at continuous grid coordinates (private to src/).
// Grid coordinates are in voxel units with integers at voxel centres: g = (p - origin)/voxel - 0.5.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/math/real.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse {

//! Trilinear colour over the 8 corners of a cell, from the corners seen in colour only (a corner
//! never coloured does not pull the result towards black); alpha 0 when none was seen.
//! \param colour, colour_weight the volume's colour arrays  \param idx the corners' linear indices
//! (corner i: +x for bit 0, +y for bit 1, +z for bit 2)  \param f the position inside the cell
template <class Index>
inline Rgba8 blend_corner_colours(const Rgb8* colour, const uint8_t* colour_weight, const Index idx[8],
                                  const float f[3]) {
  Rgba8 out;
  float sum_w = 0, r = 0, g = 0, b = 0;
  for (int i = 0; i < 8; ++i) {
    if (colour_weight[idx[i]] == 0) continue;
    const float w = ((i & 1) ? f[0] : 1 - f[0]) * ((i & 2) ? f[1] : 1 - f[1]) * ((i & 4) ? f[2] : 1 - f[2]);
    const Rgb8 c = colour[idx[i]];
    sum_w += w;
    r += w * c.r;
    g += w * c.g;
    b += w * c.b;
  }
  if (!(sum_w > 1e-6f)) return out;
  out.r = uint8_t(r / sum_w + 0.5f);
  out.g = uint8_t(g / sum_w + 0.5f);
  out.b = uint8_t(b / sum_w + 0.5f);
  out.a = 255;
  return out;
}

template <class Real>
class TsdfSampler {
 public:
  explicit TsdfSampler(const TsdfVolume& v)
      : v_(v), tsdf_(v.tsdf()), weight_(v.weight()), colour_(v.colour()), colour_weight_(v.colour_weight()),
        last_(v.dim() - 1) {}

  //! True when the trilinear cell with base `cell` lies inside the grid.
  bool in_grid(const int cell[3]) const {
    return cell[0] >= 0 && cell[1] >= 0 && cell[2] >= 0 && cell[0] < last_ && cell[1] < last_ && cell[2] < last_;
  }

  //! TSDF as a fraction of the truncation (-1..1); false when a corner is unobserved or outside.
  bool sample(Real gx, Real gy, Real gz, Real& out) const {
    const int cell[3] = {floor_int(gx), floor_int(gy), floor_int(gz)};
    if (!in_grid(cell)) return false;
    std::size_t idx[8];
    corners(cell, idx);
    int16_t q[8];
    for (int i = 0; i < 8; ++i) {
      q[i] = tsdf_[idx[i]];
      if (q[i] == kTsdfUnobserved) return false;
    }
    const Real fx = gx - real_from_int<Real>(cell[0]);
    const Real fy = gy - real_from_int<Real>(cell[1]);
    const Real fz = gz - real_from_int<Real>(cell[2]);
    Real c[8];
    for (int i = 0; i < 8; ++i) c[i] = tsdf_fraction(Real(), q[i]);
    // Corner i has offsets (i & 1, (i >> 1) & 1, (i >> 2) & 1).
    const Real c00 = c[0] + (c[1] - c[0]) * fx, c10 = c[2] + (c[3] - c[2]) * fx;
    const Real c01 = c[4] + (c[5] - c[4]) * fx, c11 = c[6] + (c[7] - c[6]) * fx;
    const Real c0 = c00 + (c10 - c00) * fy, c1 = c01 + (c11 - c01) * fy;
    out = c0 + (c1 - c0) * fz;
    return true;
  }

  //! Gradient by central differences of the 6 voxels around the voxel nearest to g (in stored
  //! units per two voxels; only its direction is used). False at unobserved or truncated
  //! neighbours, whose clamped values would bend the direction.
  bool gradient(Real gx, Real gy, Real gz, float grad[3]) const {
    const Real half = real_from<Real>(0.5f);
    const int c[3] = {floor_int(gx + half), floor_int(gy + half), floor_int(gz + half)};
    if (c[0] < 1 || c[1] < 1 || c[2] < 1 || c[0] >= last_ || c[1] >= last_ || c[2] >= last_) return false;
    for (int a = 0; a < 3; ++a) {
      int lo[3] = {c[0], c[1], c[2]}, hi[3] = {c[0], c[1], c[2]};
      --lo[a];
      ++hi[a];
      const int16_t ql = tsdf_[v_.index(lo[0], lo[1], lo[2])], qh = tsdf_[v_.index(hi[0], hi[1], hi[2])];
      if (ql == kTsdfUnobserved || qh == kTsdfUnobserved || ql == kTsdfMax || qh == kTsdfMax || ql == -kTsdfMax ||
          qh == -kTsdfMax)
        return false;
      grad[a] = float(int32_t(qh) - int32_t(ql));
    }
    return true;
  }

  //! Trilinear colour over the corners seen in colour; a = 0 when none was.
  Rgba8 colour(Real gx, Real gy, Real gz) const {
    Rgba8 out;
    if (colour_ == nullptr) return out;
    const int cell[3] = {floor_int(gx), floor_int(gy), floor_int(gz)};
    if (!in_grid(cell)) return out;
    std::size_t idx[8];
    corners(cell, idx);
    const float f[3] = {to_float(gx - real_from_int<Real>(cell[0])), to_float(gy - real_from_int<Real>(cell[1])),
                        to_float(gz - real_from_int<Real>(cell[2]))};
    return blend_corner_colours(colour_, colour_weight_, idx, f);
  }

 private:
  // Linear indices of the 8 corners of the cell with base `cell` (corner i: offsets of its bits).
  void corners(const int cell[3], std::size_t idx[8]) const {
    if ((cell[0] & 7) != 7 && (cell[1] & 7) != 7 && (cell[2] & 7) != 7) {
      const std::size_t base = v_.index(cell[0], cell[1], cell[2]);  // the cell lies in one brick
      for (int i = 0; i < 8; ++i) idx[i] = base + std::size_t((i & 1) + ((i >> 1) & 1) * 8 + ((i >> 2) & 1) * 64);
      return;
    }
    for (int i = 0; i < 8; ++i) idx[i] = v_.index(cell[0] + (i & 1), cell[1] + ((i >> 1) & 1), cell[2] + ((i >> 2) & 1));
  }

  const TsdfVolume& v_;
  const int16_t* tsdf_;
  const uint8_t* weight_;
  const Rgb8* colour_;
  const uint8_t* colour_weight_;
  int last_;
};

}  // namespace edgefuse
