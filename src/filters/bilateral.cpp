#include "edgefuse/filters/bilateral.hpp"

#include <cmath>

#include "view_checks.hpp"

namespace edgefuse {
namespace {
constexpr uint64_t kMaxSigmaTerm = uint64_t(1) << 47;  // keeps raw * sigma_quad_q48 below 2^63
constexpr uint64_t kMaxIndexScale = uint64_t(BilateralKernel::kRangeSize) << 16;
}  // namespace

bool BilateralParams::valid() const {
  return sigma_space_px > 0.0f && sigma_space_px < 1e6f && radius_px >= 1 && radius_px <= BilateralKernel::kMaxRadius &&
         sigma_range_m >= 0.0f && sigma_range_per_m >= 0.0f && sigma_range_m + sigma_range_per_m > 0.0f &&
         sigma_range_m < 1e6f && sigma_range_per_m < 1e6f;
}

Status BilateralKernel::prepare(const BilateralParams& params, float depth_scale) {
  prepared = false;
  if (!params.valid() || !(depth_scale > 0.0f) || !(depth_scale < 1e9f)) return Status::kInvalidArgument;
  const double sc = double(params.sigma_range_m) * depth_scale * 65536.0;
  const double sq = double(params.sigma_range_per_m) / depth_scale * 281474976710656.0;  // 2^48
  if (!(sc < double(kMaxSigmaTerm)) || !(sq < double(kMaxSigmaTerm))) return Status::kInvalidArgument;
  radius = params.radius_px;
  const int n = 2 * radius + 1;
  const double two_s2 = 2.0 * double(params.sigma_space_px) * double(params.sigma_space_px);
  for (int dy = -radius; dy <= radius; ++dy)
    for (int dx = -radius; dx <= radius; ++dx)
      spatial[(dy + radius) * n + dx + radius] = uint16_t(std::lround(kOne * std::exp(-(dx * dx + dy * dy) / two_s2)));
  for (int i = 0; i < kRangeSize; ++i) {
    const double t = (i + 0.5) / kStepsPerSigma;
    range[i] = uint16_t(std::lround(kOne * std::exp(-0.5 * t * t)));
  }
  sigma_const_q16 = uint64_t(std::llround(sc));
  sigma_quad_q48 = uint64_t(std::llround(sq));
  index_scale_q16 = 0;
  if (sigma_quad_q48 == 0)
    index_scale_q16 = (uint64_t(kStepsPerSigma) << 32) / (sigma_const_q16 > 0 ? sigma_const_q16 : 1);
  prepared = true;
  return Status::kOk;
}

Status bilateral_filter(ImageView<const uint16_t> depth, const BilateralKernel& k, ImageView<uint16_t> out) {
  using namespace filters_detail;
  if (!k.prepared) return Status::kNotInitialised;
  if (!usable(depth) || !usable(out) || !same_size(depth, out) || overlap(depth, out)) return Status::kInvalidArgument;
  const int w = depth.width, h = depth.height, r = k.radius, n = 2 * r + 1;
  for (int v = 0; v < h; ++v) {
    const uint16_t* centre_row = depth.row(v);
    uint16_t* o = out.row(v);
    const int v0 = v - r > 0 ? v - r : 0, v1 = v + r < h - 1 ? v + r : h - 1;
    for (int u = 0; u < w; ++u) {
      const int32_t zc = centre_row[u];
      if (zc == 0) {
        o[u] = 0;
        continue;
      }
      // Table steps per raw unit of |dz| at this depth: S / sigma_r(zc), Q16.
      uint64_t scale = k.index_scale_q16;
      if (k.sigma_quad_q48 != 0) {
        const uint64_t z = uint64_t(zc);
        const uint64_t sigma_q16 = k.sigma_const_q16 + ((((z * k.sigma_quad_q48) >> 16) * z) >> 16);
        scale = (uint64_t(BilateralKernel::kStepsPerSigma) << 32) / (sigma_q16 > 0 ? sigma_q16 : 1);
      }
      // Above kRangeSize << 16 every |dz| >= 1 falls off the table anyway; the clamp keeps the
      // per-tap product a 32 x 32 -> 64-bit multiply (one instruction on ARMv7 too).
      const uint32_t index_scale = uint32_t(scale < kMaxIndexScale ? scale : kMaxIndexScale);
      const int u0 = u - r > 0 ? u - r : 0, u1 = u + r < w - 1 ? u + r : w - 1;
      uint32_t sum_w = 0;
      int64_t sum_wd = 0;  // weighted depth differences to the centre: smaller numbers, same mean
      for (int vv = v0; vv <= v1; ++vv) {
        const uint16_t* row = depth.row(vv);
        const uint16_t* ws = k.spatial + (vv - v + r) * n + r;  // ws[du] for du = uu - u
        for (int uu = u0; uu <= u1; ++uu) {
          const int32_t zn = row[uu];
          if (zn == 0) continue;
          const int32_t d = zn - zc;
          const uint64_t index = (uint64_t(uint32_t(d >= 0 ? d : -d)) * index_scale) >> 16;
          if (index >= uint64_t(BilateralKernel::kRangeSize)) continue;
          const uint32_t wgt = uint32_t(ws[uu - u]) * k.range[index];
          sum_w += wgt;
          sum_wd += int64_t(wgt) * d;
        }
      }
      // The centre itself always contributes kOne^2, so sum_w > 0. Round to nearest, ties away
      // from zero; the mean of valid depths is >= 1, so the pixel stays valid.
      const uint64_t mag = (uint64_t(sum_wd >= 0 ? sum_wd : -sum_wd) + sum_w / 2) / sum_w;
      o[u] = uint16_t(sum_wd >= 0 ? zc + int32_t(mag) : zc - int32_t(mag));
    }
  }
  return Status::kOk;
}

}  // namespace edgefuse
