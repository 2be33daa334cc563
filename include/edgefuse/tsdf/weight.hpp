// The exponential update weight of Bylow et al. (RSS 2013), paper eq. (2).
//
// d is the signed distance of eq. (1): positive in front of the measured surface, negative behind.
//   w(d) = 1                              d >= -eps
//          exp(-sigma * (|d| - eps)^2)    -rho < d < -eps
//          0                              d <= -rho
// The paper's restatement writes exp(-sigma (d - eps)^2) with its own sign of d; written in |d|
// the weight is continuous at -eps, which is what Bylow et al. intend (their d is positive behind
// the surface). Behind the surface a measurement is less trustworthy the farther back the voxel is:
// the surface may have been thinner than the voxel, or seen at a grazing angle.
//
// Defaults (WeightParams::defaults_for): eps = trunc / 4, rho = trunc, sigma chosen so that the
// weight has fallen to e^-3 (5 %) at d = -rho. Why: eps must cover the sensor's depth noise so that
// a noisy sample just behind the surface still counts fully -- with trunc = 4 voxels that is one
// voxel, above the noise of the Xtion (1.4 mm at 0.7 m) at 2 mm voxels and of Kinect at 1 cm
// voxels; rho = trunc because nothing behind the truncation band is stored anyway; e^-3 at -rho
// keeps the fall-off smooth (the same end value as the authors' commented-out code).
#pragma once

#include <cmath>
#include <cstdint>

namespace edgefuse {

struct WeightParams {
  float eps_m = 0.0025f;        //!< full weight down to d = -eps
  float rho_m = 0.01f;          //!< no update at or below d = -rho
  float sigma_per_m2 = 53333;   //!< fall-off rate between -eps and -rho

  //! The documented defaults for a truncation distance.
  //! \param trunc_m truncation distance in metres (> 0)
  static WeightParams defaults_for(float trunc_m) {
    WeightParams p;
    p.eps_m = 0.25f * trunc_m;
    p.rho_m = trunc_m;
    const float band = p.rho_m - p.eps_m;
    p.sigma_per_m2 = 3.0f / (band * band);
    return p;
  }
  bool valid() const { return eps_m >= 0 && rho_m > eps_m && sigma_per_m2 >= 0; }
};

//! Eq. (2) in floating point (reference; the kernels use WeightTable, built from it).
//! \param d_m signed distance in metres
//! \param p weight parameters
inline float bylow_weight(float d_m, const WeightParams& p) {
  if (d_m >= -p.eps_m) return 1.0f;
  if (d_m <= -p.rho_m) return 0.0f;
  const float x = -d_m - p.eps_m;
  return std::exp(-p.sigma_per_m2 * x * x);
}

//! Eq. (2) sampled over -rho < d < -eps into 256 integer steps, so that the float and the
//! fixed-point kernels apply bit-identical weights and no exp() runs per voxel.
struct WeightTable {
  static constexpr int kSize = 256;
  static constexpr int kOne = 256;  //!< table value for weight 1.0
  uint16_t shape[kSize] = {};       //!< w at the centre of each step, in 1/256

  //! \param p weight parameters (must be valid())
  void build(const WeightParams& p) {
    for (int i = 0; i < kSize; ++i) {
      const float d = -p.eps_m - (float(i) + 0.5f) * (p.rho_m - p.eps_m) / float(kSize);
      shape[i] = uint16_t(std::lround(bylow_weight(d, p) * kOne));
    }
  }
};

}  // namespace edgefuse
