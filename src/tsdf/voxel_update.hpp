// The per-voxel running average shared by every sensor model's integration (pinhole, line
// scanner): integer blending with a reciprocal table, so float and fixed builds store identical
// voxels and no hardware division runs per voxel. Private to src/.
#pragma once

#include <cstdint>

namespace edgefuse {
namespace voxel_update {

// 2^32 / n rounded up, for n = 1 .. 511: the running average divides by (old + new weight) <= 263
// without a hardware division per voxel.
struct Reciprocals {
  uint32_t v[512] = {};
  constexpr Reciprocals() {
    for (uint32_t n = 1; n < 512; ++n) v[n] = uint32_t((uint64_t(1) << 32) / n + 1);
  }
};
inline constexpr Reciprocals kReciprocals;

// Weighted running average of two integer samples, rounded to nearest (ties away from zero).
// |num| < 2^24, so num * (2^32/den + 1) >> 32 is the exact quotient up to 2^-8.
inline int32_t blend(int32_t old_value, int32_t old_weight, int32_t sample, int32_t sample_weight) {
  const int32_t num = old_value * old_weight + sample * sample_weight;
  const uint32_t den = uint32_t(old_weight + sample_weight);
  const uint64_t mag = uint64_t(num >= 0 ? num : -num) + den / 2;
  const int32_t q = int32_t((mag * kReciprocals.v[den]) >> 32);
  return num >= 0 ? q : -q;
}

inline uint8_t cap_weight(int32_t w, uint8_t max_weight) { return uint8_t(w > max_weight ? max_weight : w); }

// Scales a weight by a per-pixel trust in 1/255 (255 = full). The weight's unit is 1/8 of a
// full sample, too coarse for a sample worth a few hundredths (ToF next to structured light:
// (1.4 / 6.7)^2 = 0.04 of a sample). Such a sub-unit sample:
//   - fills a voxel that holds less than one full sample (old_weight < kWeightUnitsPerSample) at
//     the minimum weight of one unit: where only the noisy sensor sees, its samples all count
//     alike, as they should;
//   - is skipped where the voxel already holds at least one full sample: one unit would give it
//     several times its share against the better sensor's samples (rounding to nearest).
// fill_units (DepthFrame::sub_unit_fill_units) is where the first case stops: 8 (one full
// sample) by default; a mixed set (fusion_rules.hpp) lowers it below the support rule's 4 so that
// a voxel seen only by sub-unit samples never passes as half a full sample.
inline int32_t scale_by_trust(int32_t w, uint32_t trust_255, int32_t old_weight, int32_t fill_units = 8) {
  if (trust_255 >= 255u) return w;
  if (trust_255 == 0u) return 0;
  const int32_t s = int32_t((uint32_t(w) * trust_255 + 127u) / 255u);
  if (s > 0) return s;
  return old_weight < fill_units ? 1 : 0;
}

}  // namespace voxel_update
}  // namespace edgefuse
