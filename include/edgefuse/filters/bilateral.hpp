// Bilateral filter on raw depth (paper: depth "pre-filtered with a bilateral filter").
//
// out(p) = sum_n ws(n - p) wr(z_n - z_p) z_n / sum_n ws wr over the valid pixels n of the
// (2 radius + 1)^2 window around a valid pixel p: a spatial gaussian ws (sigma in pixels) and a
// range gaussian wr on the depth difference (sigma in metres, sigma_r(z_p) = sigma_range_m +
// sigma_range_per_m * z_p^2, the quadratic growth of structured-light and ToF noise with depth).
// The full 2D window is evaluated: the bilateral filter is not separable (the range weight couples
// the axes), and the window is small. Invalid pixels (0) contribute nothing and stay invalid;
// a valid pixel stays valid (its own weight is always the largest).
//
// No exp() per pixel: prepare() samples ws into an integer kernel and wr into a table indexed by
// |dz| / sigma_r (kStepsPerSigma steps per sigma, zero beyond kRangeSigmas sigma); the sums are
// 64-bit integer, so the float and the fixed-point builds give bit-identical output. The only
// per-pixel division besides the final average is 1 / sigma_r(z_p) when sigma_range_per_m != 0.
#pragma once

#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/core/status.hpp"

namespace edgefuse {

struct BilateralParams {
  //! Spatial sigma in pixels. Default 1.5 px: with radius 2 the window edge is at 1.33 sigma
  //! (weight 0.41, corners 0.17), so the 5x5 window is used fully; smoothing wider than ~2 px would
  //! round the 2 mm features the fusion is meant to keep (paper: 2 mm buttons visible).
  float sigma_space_px = 1.5f;
  //! Window half size in pixels, 1..BilateralKernel::kMaxRadius. Default 2 (5x5 = 25 taps).
  int radius_px = 2;
  //! Constant part of the range sigma, metres. Default 0 (pure quadratic model).
  float sigma_range_m = 0.0f;
  //! Quadratic part k of sigma_r = sigma_range_m + k z^2, 1/m. Default 0.01 for structured light
  //! (Xtion / Kinect v1 class), whose noise grows as z^2 (Khoshelham & Elberink 2012: ~0.0016 z^2;
  //! bin_rig_a's Xtion model: 1.4 mm at 0.7 m plus disparity steps of 0.0028 z^2). sigma_r = 4.9 mm
  //! at 0.7 m is ~3.5 times that noise: noise differences between neighbours keep >= 0.9 of their
  //! weight, steps of 4 sigma_r (2 cm at 0.7 m) and more get none. Measured on bin_rig_a xtion frames
  //! 0-1 against the exact depth: RMS error 1.37 -> 0.80 mm on surfaces and 1.36 -> 0.88 mm within
  //! 2 px of a depth jump; k = 0.006 gives 0.85 / 0.89 mm, and k >= 0.02 starts rounding the edges
  //! (1.05 mm there; 3.4 mm at k = 0.08). For ToF use time_of_flight().
  float sigma_range_per_m = 0.01f;

  //! Range sigma for time-of-flight depth: the bin_rig_a ToF noise 0.005 z / sqrt(a_n) with
  //! a_n = rho cos(theta) (0.5 m / r)^2 is 0.01 z r / sqrt(rho cos(theta)), ~0.013 z^2 on the bin
  //! floor (6.7 mm median at 0.7 m, up to 2 cm on the dark can). k = 0.04 puts sigma_r (2 cm at
  //! 0.7 m) at ~3 times the median noise, as the structured-light default. Measured on bin_rig_a tof
  //! frames 0-1 after the jump-edge filter, against the exact depth (pixels within 2.5 sigma of it):
  //! RMS error 6.7 -> 3.0 mm more than 2 px from a depth jump, 9.2 -> 7.8 mm within 2 px; k = 0.03
  //! gives 3.3 / 8.1 mm, k = 0.05 gains ~0.1 mm while blurring steps up to 10 cm (4 sigma_r).
  static BilateralParams time_of_flight() {
    BilateralParams p;
    p.sigma_range_per_m = 0.04f;
    return p;
  }
  //! Positive spatial sigma, radius in 1..4, non-negative range terms with a positive sum.
  bool valid() const;
};

//! Integer tables and the sigma model in raw units, built by prepare().
struct BilateralKernel {
  static constexpr int kMaxRadius = 4;  //!< 9x9 window at most
  static constexpr int kMaxTaps = (2 * kMaxRadius + 1) * (2 * kMaxRadius + 1);
  static constexpr int kStepsPerSigma = 32;  //!< range table resolution
  static constexpr int kRangeSigmas = 4;     //!< wr = 0 beyond 4 sigma (exp(-8) < 1/2048 of kOne)
  static constexpr int kRangeSize = kStepsPerSigma * kRangeSigmas;
  static constexpr int kOne = 1024;  //!< table value of weight 1.0 (products fit 20 bits)

  int radius = 0;                   //!< window half size
  uint16_t spatial[kMaxTaps] = {};  //!< ws, row-major (2 radius + 1)^2
  uint16_t range[kRangeSize] = {};  //!< wr at the centre of each 1/kStepsPerSigma step of |dz| / sigma
  uint64_t sigma_const_q16 = 0;     //!< constant part of sigma_r in raw units, Q16
  uint64_t sigma_quad_q48 = 0;      //!< k / depth_scale in Q48: sigma_r (raw, Q16) += raw^2 * this >> 32
  uint64_t index_scale_q16 = 0;     //!< table steps per raw unit, Q16, when sigma_r is constant
  bool prepared = false;            //!< prepare() succeeded

  //! \param params filter parameters
  //! \param depth_scale raw value / depth_scale = metres (> 0)
  //! \return kInvalidArgument when params are invalid or the sigma model does not fit the tables
  Status prepare(const BilateralParams& params, float depth_scale);
};

//! Bilateral-filtered depth. Not in place: out must not overlap depth.
//! \param depth raw z-depth, 0 = invalid
//! \param kernel prepared tables
//! \param out filtered depth, same size as depth
//! \return kNotInitialised before prepare(); kInvalidArgument on size mismatch, empty views or overlap
Status bilateral_filter(ImageView<const uint16_t> depth, const BilateralKernel& kernel, ImageView<uint16_t> out);

}  // namespace edgefuse
