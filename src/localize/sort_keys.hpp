// Grid cell keys and a deterministic (key, index) sort used for voxel-grid subsampling.
#pragma once

#include <algorithm>
#include <cstdint>

#include "edgefuse/math/pose.hpp"
#include "edgefuse/math/real.hpp"

namespace edgefuse {

struct KeyIndex {
  uint64_t key;
  uint64_t index;
};

//! 21 bits per axis (cells offset by 2^20: +-1 million cells).
inline uint64_t cell_key(const Vec3f& p, float inv_cell) {
  const uint64_t x = uint64_t(int64_t(floor_int(p.x() * inv_cell)) + (1 << 20)) & 0x1FFFFF;
  const uint64_t y = uint64_t(int64_t(floor_int(p.y() * inv_cell)) + (1 << 20)) & 0x1FFFFF;
  const uint64_t z = uint64_t(int64_t(floor_int(p.z() * inv_cell)) + (1 << 20)) & 0x1FFFFF;
  return (z << 42) | (y << 21) | x;
}

//! Sorts by key, ties by index (std::sort allocates nothing).
inline void sort_key_index(KeyIndex* a, std::size_t n) {
  std::sort(a, a + n, [](const KeyIndex& l, const KeyIndex& r) {
    return l.key < r.key || (l.key == r.key && l.index < r.index);
  });
}

}  // namespace edgefuse
