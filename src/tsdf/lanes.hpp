// The GCC vector types shared by the float kernels (row_projection.hpp, raycast_bounds.hpp,
// raycast.cpp): 16 bytes as 4 floats or int32s, 8 int16s or 2 uint64s. GCC compiles them to SSE2
// on x86-64, NEON on aarch64 and armhf and scalar code where neither exists, so every build
// compiles the same source (no intrinsics). Private to src/.
#pragma once

#include <cstdint>

namespace edgefuse {
namespace lane_types {

typedef float F4 __attribute__((vector_size(16)));
typedef int32_t I4 __attribute__((vector_size(16)));
typedef int16_t S8 __attribute__((vector_size(16)));
typedef uint64_t U2 __attribute__((vector_size(16)));

inline F4 splat_f(float x) { return F4{x, x, x, x}; }
inline I4 splat_i(int32_t x) { return I4{x, x, x, x}; }
inline F4 min_f(F4 a, F4 b) { return a < b ? a : b; }
inline F4 max_f(F4 a, F4 b) { return a > b ? a : b; }

}  // namespace lane_types
}  // namespace edgefuse
