// The scalar the hot kernels compute with: float, or Q16.16 Fixed in the fixed-point build.
//
// Kernels are templates over `Real` and use only the helpers below, so the float and the
// fixed-point build run the same algorithm; both instantiations are compiled into every build
// (the tests compare them), and `real_t` selects the one the application uses.
#pragma once

#include <cmath>
#include <cstdint>

#include "edgefuse/math/fixed.hpp"

namespace edgefuse {

#if defined(EDGEFUSE_FIXED_POINT) && EDGEFUSE_FIXED_POINT
using real_t = Fixed;
inline constexpr bool kFixedPointBuild = true;
#else
using real_t = float;
inline constexpr bool kFixedPointBuild = false;
#endif

//! Convert a float to the kernel scalar (rounding as documented in fixed.hpp).
template <class Real>
constexpr Real real_from(float v);
template <>
constexpr float real_from<float>(float v) { return v; }
template <>
constexpr Fixed real_from<Fixed>(float v) { return Fixed::from_float(v); }

//! Convert an integer to the kernel scalar (exact within range).
template <class Real>
constexpr Real real_from_int(int32_t v);
template <>
constexpr float real_from_int<float>(int32_t v) { return float(v); }
template <>
constexpr Fixed real_from_int<Fixed>(int32_t v) { return Fixed::from_int(v); }

//! A stored TSDF value (int16, +-32768 = +-trunc) as a fraction of the truncation.
inline float tsdf_fraction(float, int16_t q) { return float(q) * (1.0f / 32768.0f); }
inline Fixed tsdf_fraction(Fixed, int16_t q) { return Fixed::from_raw(int32_t(q) * 2); }

inline float to_float(float v) { return v; }
inline float to_float(Fixed v) { return v.to_float(); }

inline float real_sqrt(float v) { return v > 0.0f ? std::sqrt(v) : 0.0f; }
inline Fixed real_sqrt(Fixed v) { return sqrt(v); }

//! Largest integer <= v. Written out because std::floor / std::lround are library calls on
//! baseline x86-64 and ARMv7 and sit in the innermost loops (|v| < 2^31 assumed).
inline int32_t floor_int(float v) {
  const int32_t i = int32_t(v);  // truncates towards zero
  return i - (v < float(i) ? 1 : 0);
}
inline int32_t floor_int(Fixed v) { return v.floor_to_int(); }

//! Nearest integer, ties away from zero (same rule in both builds).
inline int32_t round_int(float v) { return v >= 0.0f ? int32_t(v + 0.5f) : -int32_t(0.5f - v); }
inline int32_t round_int(Fixed v) { return v.round_to_int(); }

//! Raw 16-bit depth to metres (raw / depth_scale). The fixed-point form multiplies by a 32-bit
//! reciprocal so that scales like 5000 keep full precision (1/5000 is not representable in Q16).
template <class Real>
struct DepthScale;
template <>
struct DepthScale<float> {
  float inv = 0.001f;
  DepthScale() = default;
  explicit DepthScale(float depth_scale) : inv(1.0f / depth_scale) {}
  float metres(uint16_t raw) const { return float(raw) * inv; }
};
template <>
struct DepthScale<Fixed> {
  uint64_t recip_q32 = 0;  //!< round(2^32 / depth_scale)
  DepthScale() = default;
  explicit DepthScale(float depth_scale) : recip_q32(uint64_t(std::llround(4294967296.0 / double(depth_scale)))) {}
  Fixed metres(uint16_t raw) const { return Fixed::from_raw(int32_t((uint64_t(raw) * recip_q32 + 32768u) >> 16)); }
};

}  // namespace edgefuse
