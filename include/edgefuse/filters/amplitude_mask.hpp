// Amplitude (magnitude) threshold for time-of-flight frames (paper: "magnitude threshold").
//
// A ToF pixel's depth noise grows as 1 / sqrt(amplitude) (phase noise of the correlation
// measurement), so pixels that received little light -- dark or shiny surfaces, grazing angles,
// far range -- are dropped rather than fused with a low weight.
#pragma once

#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/core/status.hpp"

namespace edgefuse {

struct AmplitudeMaskParams {
  //! Smallest kept amplitude (raw units of the amplitude image). Default 400: in bin_rig_a the
  //! amplitude is 20000 * a_n (a_n = normalised amplitude) and the camera itself reports no depth
  //! below a_n = 0.02 = raw 400. At that amplitude the model's noise 0.005 z / sqrt(a_n) is
  //! 0.035 z (2.5 cm at 0.7 m, capped at 2 cm), i.e. as large as a fusion truncation band of 4 voxels
  //! of 5 mm: a weaker return cannot place the surface inside the band. Raising it trades coverage
  //! of dark objects (the can, reflectivity 0.15, returns a_n ~ 0.05..0.09) for less noise.
  uint16_t min_amplitude = 400;

  //! min_amplitude > 0 (0 would keep everything: disable the step instead).
  bool valid() const { return min_amplitude > 0; }
};

//! out = depth where amplitude >= min_amplitude, else 0. In place allowed (out.data == depth.data
//! with the same stride).
//! \param depth raw z-depth, 0 = invalid
//! \param amplitude amplitude image pixel-registered to depth (same size)
//! \param params threshold
//! \param out masked depth, same size as depth
//! \return kInvalidArgument on bad params, empty views, size mismatch or partial overlap
Status amplitude_mask(ImageView<const uint16_t> depth, ImageView<const uint16_t> amplitude,
                      const AmplitudeMaskParams& params, ImageView<uint16_t> out);

}  // namespace edgefuse
