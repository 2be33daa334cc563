// Explicit little-endian loads/stores: the formats are little-endian whatever the host is.
#pragma once

#include <cstdint>
#include <cstring>

namespace edgefuse::io::detail {

inline uint64_t load_le(const unsigned char* p, int size) {
  uint64_t v = 0;
  for (int i = size - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
inline uint32_t load_le_u32(const unsigned char* p) { return uint32_t(load_le(p, 4)); }
inline float load_le_f32(const unsigned char* p) {
  const uint32_t u = load_le_u32(p);
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}
inline double load_le_f64(const unsigned char* p) {
  const uint64_t u = load_le(p, 8);
  double d;
  std::memcpy(&d, &u, 8);
  return d;
}

inline void store_le(unsigned char* p, uint64_t v, int size) {
  for (int i = 0; i < size; ++i) p[i] = static_cast<unsigned char>(v >> (8 * i));
}
inline void store_le_f32(unsigned char* p, float f) {
  uint32_t u;
  std::memcpy(&u, &f, 4);
  store_le(p, u, 4);
}

}  // namespace edgefuse::io::detail
