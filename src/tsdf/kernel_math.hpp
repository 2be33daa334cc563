// Small helpers shared by the integration and raycast kernels (private to src/).
#pragma once

#include <cstdint>

#include "edgefuse/math/real.hpp"

namespace edgefuse {

//! Nearest pixel index of a coordinate; false outside [-0.5, size - 0.5). Same rounding in both
//! builds: pixel centres are integers, a coordinate exactly between two pixels goes up.
inline bool pixel_of(float x, int size, int& index) {
  // x >= -0.5 and x < size - 0.5, tested on the rounded x + 0.5 itself (the same decisions: near
  // -0.5 the sum is exact, and below size it stays in x's binade): two compares instead of four
  // operations and a conversion. NaN fails the first test. |x| < 2^31 is assumed, as by
  // floor_int (the kernels' projections are bounded by the volume: |x| < ~1e6 pixels).
  const float shifted = x + 0.5f;
  if (!(shifted >= 0.0f)) return false;
  const int i = int(shifted);
  if (unsigned(i) >= unsigned(size)) return false;
  index = i;
  return true;
}
inline bool pixel_of(Fixed x, int size, int& index) {
  const int32_t r = x.raw();
  if (r < -(Fixed::kOne / 2) || int64_t(r) >= (int64_t(size) << Fixed::kFracBits) - Fixed::kOne / 2) return false;
  index = int((int64_t(r) + Fixed::kOne / 2) >> Fixed::kFracBits);
  return true;
}

}  // namespace edgefuse
