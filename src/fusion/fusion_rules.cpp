#include "edgefuse/fusion/fusion_rules.hpp"

#include <cstddef>

namespace edgefuse {

float median_sigma_m(const NoiseModel& noise, ImageView<const uint16_t> depth, float depth_scale,
                     ImageView<const uint16_t> amplitude) {
  // Histogram of 0.25 mm bins up to 64 mm (the ToF model caps at 20 mm): a median without sorting.
  constexpr int kBins = 256;
  constexpr float kBinM = 0.00025f;
  uint32_t hist[kBins] = {};
  uint32_t n = 0;
  for (int v = 0; v < depth.height; ++v)
    for (int u = 0; u < depth.width; ++u) {
      const uint16_t raw = depth.at(u, v);
      if (raw == 0) continue;
      const float a = amplitude.empty() ? 0.0f : float(amplitude.at(u, v));
      const int b = int(noise.sigma_m(float(raw) / depth_scale, a) / kBinM);
      ++hist[b < 0 ? 0 : (b >= kBins ? kBins - 1 : b)];
      ++n;
    }
  uint32_t seen = 0;
  for (int b = 0; b < kBins; ++b) {
    seen += hist[b];
    if (2 * seen >= n && n > 0) return (float(b) + 0.5f) * kBinM;
  }
  return 0.0f;
}

float noise_jump_m(float median_sigma_m, float jump_sigmas) {
  if (!(jump_sigmas > 0.0f) || !(median_sigma_m > 0.0f)) return 0.0f;
  const float j = jump_sigmas * median_sigma_m;
  return j < 1.0f ? j : 1.0f;
}

bool sub_unit_sensor(float median_sigma_m, float sigma_ref_m) {
  // A sample weighs kWeightUnitsPerSample (sigma_ref / sigma)^2 units, rounded: below half a unit
  // it is stored as one (voxel_update.hpp scale_by_trust). Equivalent: sigma > sigma_ref sqrt(16).
  if (!(median_sigma_m > 0.0f) || !(sigma_ref_m > 0.0f)) return false;
  const float r = sigma_ref_m / median_sigma_m;
  return float(kWeightUnitsPerSample) * r * r < 0.5f;
}

bool mixed_sub_unit_set(const float* median_sigma_m, int cameras, float sigma_ref_m) {
  bool sub = false, unit = false;
  for (int i = 0; i < cameras; ++i) {
    if (!(median_sigma_m[i] > 0.0f)) continue;
    if (sub_unit_sensor(median_sigma_m[i], sigma_ref_m))
      sub = true;
    else
      unit = true;
  }
  return sub && unit;
}

int default_sub_unit_fill(const float* median_sigma_m, int cameras, float sigma_ref_m) {
  return mixed_sub_unit_set(median_sigma_m, cameras, sigma_ref_m) ? kSubUnitFillUnits : kWeightUnitsPerSample;
}

uint8_t default_support_weight(const float* median_sigma_m, int cameras, float sigma_ref_m, int sub_unit_fill_units) {
  // A fill below the support rule can not make a sub-unit-only voxel pass it: half a sample suffices.
  return mixed_sub_unit_set(median_sigma_m, cameras, sigma_ref_m) && sub_unit_fill_units >= kMinSupportWeight
             ? kEvidenceSupportWeight
             : kMinSupportWeight;
}

}  // namespace edgefuse
