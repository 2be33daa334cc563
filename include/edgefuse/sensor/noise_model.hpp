// Per-sensor trust: each sensor model states its range noise sigma(z) (and, for
// a ToF camera, sigma(z, amplitude)); integration weighs a sample by (sigma_ref / sigma)^2, the
// inverse-variance weight relative to a reference noise, so a running average over sensors is
// the maximum-likelihood fusion of their measurements. This answers the paper's question "how much
// do I trust a certain sensor".
//
// Models (sigma of the z-depth, metres):
//   structured light (Nguyen, Izadi & Lovell 2012, Kinect v1 / Xtion): a + b (z - z0)^2,
//     defaults a = 1.2 mm, b = 1.9 mm/m^2, z0 = 0.4 m (1.4 mm at 0.7 m, 4.6 mm at 1.5 m);
//   time of flight: k z / sqrt(a_n) with a_n the normalised amplitude (amplitude / amplitude_ref),
//     shot-noise limited, capped at sigma_max; defaults k = 5 mm/m, amplitude_ref = 20000,
//     sigma_max = 20 mm (PMD CamBoard nano class; 6.7 mm median on bin_rig_a);
//   constant: sigma = a (a line scanner: 20 um for a Micro-Epsilon class profile scanner).
// Trust = min(1, (sigma_ref / sigma)^2), stored per pixel in 1/255. sigma_ref is the noise that
// earns full weight; the fusion command uses the voxel size / 2 (finer measurements cannot be
// told apart in the voxel grid). The weight's resolution is 1/8 of a sample (volume.hpp), so a
// pixel with any trust keeps at least that much weight (integrate.cpp).
#pragma once

#include <cmath>
#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/core/status.hpp"

namespace edgefuse {

enum class NoiseKind : uint8_t { kConstant, kStructuredLight, kTimeOfFlight };

struct NoiseModel {
  NoiseKind kind = NoiseKind::kConstant;
  float a_m = 0.0012f;          //!< constant term (constant: the whole sigma)
  float b_per_m = 0.0019f;      //!< structured light: quadratic coefficient (m / m^2)
  float z0_m = 0.4f;            //!< structured light: depth of the smallest noise
  float k = 0.005f;             //!< ToF: sigma per metre of depth at a_n = 1
  float amplitude_ref = 20000;  //!< ToF: raw amplitude of a_n = 1
  float sigma_max_m = 0.02f;    //!< ToF: cap (phase noise wraps no further)

  static NoiseModel structured_light() { NoiseModel m; m.kind = NoiseKind::kStructuredLight; return m; }
  static NoiseModel time_of_flight() { NoiseModel m; m.kind = NoiseKind::kTimeOfFlight; return m; }
  //! \param sigma_m the sensor's constant range noise
  static NoiseModel constant(float sigma_m) { NoiseModel m; m.kind = NoiseKind::kConstant; m.a_m = sigma_m; return m; }

  //! Positive noise terms.
  bool valid() const { return a_m > 0 && b_per_m >= 0 && k > 0 && amplitude_ref > 0 && sigma_max_m > 0; }

  //! Noise of a z-depth measurement.
  //! \param z_m z-depth in metres
  //! \param amplitude raw amplitude (ToF only; <= 0 means unknown: sigma_max)
  float sigma_m(float z_m, float amplitude = 0.0f) const {
    switch (kind) {
      case NoiseKind::kStructuredLight: return a_m + b_per_m * (z_m - z0_m) * (z_m - z0_m);
      case NoiseKind::kTimeOfFlight: {
        if (!(amplitude > 0.0f)) return sigma_max_m;
        const float an = amplitude / amplitude_ref;
        const float s = k * z_m / std::sqrt(an);
        return s < sigma_max_m ? s : sigma_max_m;
      }
      case NoiseKind::kConstant: break;
    }
    return a_m;
  }
  //! Trust in (0, cap] relative to sigma_ref (full trust at or below it).
  //! \param sigma_ref_m noise that earns full weight  \param z_m z-depth  \param amplitude raw (ToF)
  //! \param cap largest trust returned (1: a pinhole trust map in 1/255; a line scanner may exceed 1,
  //!        see kProfileTrustMax in integrate_profile.hpp)
  float trust(float sigma_ref_m, float z_m, float amplitude = 0.0f, float cap = 1.0f) const {
    return trust_of_sigma(sigma_ref_m, sigma_m(z_m, amplitude), cap);
  }
  //! trust() of a noise already evaluated (sigma_m > 0).
  //! \param sigma_ref_m noise that earns full weight  \param sigma_m the measurement's noise  \param cap as trust()
  static float trust_of_sigma(float sigma_ref_m, float sigma_m, float cap = 1.0f) {
    const float r = sigma_ref_m / sigma_m;
    const float t = r * r;
    return t < cap ? t : cap;
  }
};

//! Fills a per-pixel trust map (1/255) for a depth image: 0 where there is no depth.
//! \param model the sensor's noise model (valid())
//! \param sigma_ref_m noise that earns full trust (> 0)
//! \param depth raw depth image
//! \param depth_scale raw / depth_scale = metres
//! \param amplitude ToF amplitude image (same size) or empty
//! \param trust output, same size as depth
//! \param sigma_max_m noise gate (0: none): a pixel noisier than this gets trust 0 (no sample).
//!        A truncated SDF cannot hold a measurement whose noise is comparable to its truncation: the
//!        clipping at +-trunc biases its average and its noise leaves zero crossings in the band.
//! \param median_sigma_m optional output: the median modelled noise of the pixels that get a sample
//!        (trust > 0), in 0.25 mm bins up to 64 mm (the bin's centre; 0 without any such pixel). The
//!        fusion rules' depth-jump limit and sensor classes (fusion_rules.hpp) follow it; it comes
//!        from the same per-pixel noise as the trust, with a histogram on the stack (no heap).
Status build_trust_map(const NoiseModel& model, float sigma_ref_m, ImageView<const uint16_t> depth, float depth_scale,
                       ImageView<const uint16_t> amplitude, ImageView<uint8_t> trust, float sigma_max_m = 0.0f,
                       float* median_sigma_m = nullptr);

}  // namespace edgefuse
