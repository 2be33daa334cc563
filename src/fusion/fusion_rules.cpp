#include "edgefuse/fusion/fusion_rules.hpp"

#include <cstddef>

namespace edgefuse {

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
