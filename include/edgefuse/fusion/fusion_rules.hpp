// Noise rules of multi-sensor fusion, shared by `edgefuse fuse --sensors`, `edgefuse localize
// --sensors` and edgefused's sensors.fuse (figures: docs/BENCHMARKS.md, "Multi-sensor fusion").
//
// 1. Depth discontinuity follows the frame's noise: integration drops a sample whose 2x2 pixels
//    differ by more than jump_sigmas x the frame's median modelled noise (never below the
//    truncation: DepthFrame::jump_m).
// 2. Support rule of extraction (weight units of volume.hpp: 8 = one sample at sigma_ref, weight
//    (sigma_ref / sigma)^2): a zero crossing is emitted only when both of its voxels hold at least
//    W. The unit is coarse: a sample worth less than half a unit (sigma > 4 sigma_ref: the ToF
//    on bin_rig_a, 6.7 mm against sigma_ref 1 mm = 0.18 unit) is stored as one whole unit while the
//    voxel holds less than one sample, and skipped after (voxel_update.hpp). So a stored weight up
//    to 8 may be up to 8 such samples whose evidence is 8 x 0.18 = 1.4 units (sigma_eff >= 2.4 mm),
//    and only a weight of 9 or more proves a sample of at least one unit.
//    * kMinSupportWeight (4): half a sample, one Xtion frame at 0.7 m (sigma 1.4 mm); the rule for
//      a single sensor, and of every set once rule 3 applies.
//    * kEvidenceSupportWeight (9): the evidence rule of a set that mixes a sub-unit sensor with a
//      wide-field sensor whose frames weigh at least one unit: a point must have the accuracy of one
//      frame of the best wide-field sensor. A sub-unit sensor can not reach that alone (20 ToF frames
//      of 6.7 mm average to 1.5 mm, one Xtion frame is 1.4 mm), and its stored weights can not be
//      told from a good sensor's below 9 - so the fused cloud keeps the good sensors' surface where
//      it has more than one unit-sized sample, the ToF adds weight only where it agrees with them.
// 3. Sub-unit fill of a mixed set: rule 2's
//    9 also drops the good sensor's crossings seen by one frame (4 units). Instead, in a set that
//    mixes a sub-unit camera with a unit-sized one, sub-unit samples fill a voxel only up to
//    kSubUnitFillUnits (3 < kMinSupportWeight; DepthFrame::sub_unit_fill_units) rather than 8: a
//    voxel seen only by the ToF never passes support 4 (its real evidence, 1.4 units after 8 samples,
//    is below half a reference sample anyway), so the support rule returns to 4 for every set; where
//    the ToF arrives first its samples weigh 3 units against a good frame's 4, not 8.
#pragma once

#include <cstdint>

#include "edgefuse/sensor/noise_model.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse {

//! Depth discontinuity in frame-noise sigmas: 2 sqrt(2), two standard deviations of the difference
//! of two pixels' noise (the truncation stays the floor: the Xtion's 1.4 mm gives 4 mm < 8 mm).
inline constexpr float kJumpSigmas = 2.83f;
//! Support rule: half a full-trust sample (one Xtion frame at 0.7 m, or four sub-unit samples).
inline constexpr uint8_t kMinSupportWeight = 4;
//! Evidence rule of a mixed set: more than a voxel of sub-unit samples alone can hold.
inline constexpr uint8_t kEvidenceSupportWeight = kWeightUnitsPerSample + 1;

// A frame's median modelled noise comes out of its trust map: build_trust_map(..., &median_sigma_m)
// (sensor/noise_model.hpp), the same per-pixel noise in the same pass.

//! Mean of a camera's frames' median noise: the set's rules (sub-unit fill, support) follow it.
struct NoiseMean {
  double sum_m = 0.0;   //!< sum of the frames' median noise
  uint32_t frames = 0;  //!< frames summed
  //! \param median_sigma_m one frame's median noise
  void add(float median_sigma_m) {
    sum_m += median_sigma_m;
    ++frames;
  }
  //! The mean (0 before any frame).
  float mean_m() const { return frames > 0 ? float(sum_m / double(frames)) : 0.0f; }
};

//! DepthFrame::jump_m of a frame with median noise median_sigma_m: jump_sigmas x it, at most 1 m
//! (integration's bound); 0 (the truncation) when jump_sigmas is 0.
//! \param median_sigma_m the frame's median noise (build_trust_map's)  \param jump_sigmas the rule's K
float noise_jump_m(float median_sigma_m, float jump_sigmas);

//! Whether a sensor of this median noise gives sub-unit samples (stored as one unit, see above).
//! \param median_sigma_m its median noise  \param sigma_ref_m the trust reference (full weight)
bool sub_unit_sensor(float median_sigma_m, float sigma_ref_m);

//! Sub-unit fill of a mixed set (rule 3): below the support rule's kMinSupportWeight.
inline constexpr int kSubUnitFillUnits = 3;

//! Whether a set of pinhole sensors holds both a sub-unit sensor and one whose samples weigh at
//! least one unit (line scanners are not wide-field and weigh more than a unit).
//! \param median_sigma_m each camera's median noise (0: no data, ignored)  \param cameras count
//! \param sigma_ref_m the trust reference
bool mixed_sub_unit_set(const float* median_sigma_m, int cameras, float sigma_ref_m);

//! Default DepthFrame::sub_unit_fill_units of a set: kSubUnitFillUnits when it is mixed
//! (mixed_sub_unit_set), else kWeightUnitsPerSample (one full sample).
//! \param median_sigma_m each camera's median noise (0: no data, ignored)  \param cameras count
//! \param sigma_ref_m the trust reference
int default_sub_unit_fill(const float* median_sigma_m, int cameras, float sigma_ref_m);

//! Default support rule of a set of pinhole sensors: kEvidenceSupportWeight when the set is mixed
//! (mixed_sub_unit_set) and its sub-unit samples filled voxels up to kMinSupportWeight or more,
//! else kMinSupportWeight (with the mixed set's default fill, kSubUnitFillUnits: 4).
//! \param median_sigma_m each camera's median noise (0: no data, ignored)  \param cameras count
//! \param sigma_ref_m the trust reference
//! \param sub_unit_fill_units the fill the frames were integrated with (DepthFrame::sub_unit_fill_units)
uint8_t default_support_weight(const float* median_sigma_m, int cameras, float sigma_ref_m,
                               int sub_unit_fill_units = kWeightUnitsPerSample);

}  // namespace edgefuse
