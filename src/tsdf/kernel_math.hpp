// Small helpers shared by the integration and raycast kernels (private to src/).
#pragma once

#include <cstdint>

#include "edgefuse/math/real.hpp"

namespace edgefuse {

//! Nearest pixel index of a coordinate; false outside [-0.5, size - 0.5). Same rounding in both
//! builds: pixel centres are integers, a coordinate exactly between two pixels goes up.
inline bool pixel_of(float x, int size, int& index) {
  if (!(x >= -0.5f) || !(x < float(size) - 0.5f)) return false;
  index = int(x + 0.5f);
  return true;
}
inline bool pixel_of(Fixed x, int size, int& index) {
  const int32_t r = x.raw();
  if (r < -(Fixed::kOne / 2) || int64_t(r) >= (int64_t(size) << Fixed::kFracBits) - Fixed::kOne / 2) return false;
  index = int((int64_t(r) + Fixed::kOne / 2) >> Fixed::kFracBits);
  return true;
}

}  // namespace edgefuse
