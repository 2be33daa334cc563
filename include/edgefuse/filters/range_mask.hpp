// Min / max range mask: invalidates depth outside the sensor's trusted z-depth interval.
//
// Sensors report values outside their specified range (Kinect-class devices below ~0.4 m, ToF
// cameras beyond their unambiguous range) that look valid but are not; everything downstream
// (tiles, integration, the other filters) should never see them.
#pragma once

#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/core/status.hpp"
#include "edgefuse/sensor/pinhole.hpp"

namespace edgefuse {

struct RangeMaskParams {
  //! Nearest kept z-depth in metres (inclusive). Default = PinholeIntrinsics' default (0.1 m, the
  //! near limit of the bin_rig_a ToF camera); normally taken from the sensor with from_sensor().
  float min_m = 0.1f;
  //! Farthest kept z-depth in metres (inclusive). Default = PinholeIntrinsics' default (10 m).
  float max_m = 10.0f;

  //! The sensor's own valid interval (intrinsics' min_range_m / max_range_m).
  //! \param intr sensor intrinsics
  static RangeMaskParams from_sensor(const PinholeIntrinsics& intr) {
    RangeMaskParams p;
    p.min_m = intr.min_range_m;
    p.max_m = intr.max_range_m;
    return p;
  }
  //! 0 <= min_m < max_m, both finite.
  bool valid() const { return min_m >= 0.0f && max_m > min_m && max_m < 1e30f; }
};

//! out = depth where min_m <= depth / depth_scale <= max_m, else 0. The bounds are converted once
//! to raw units by rounding to the nearest raw step (0.1 m at scale 5000 is raw 500 exactly, not
//! 501 as float rounding of 0.1f * 5000 would give with a ceiling), so the test per pixel is an
//! integer comparison. In place allowed (out.data == depth.data with the same stride).
//! \param depth raw z-depth, 0 = invalid
//! \param params range interval
//! \param depth_scale raw value / depth_scale = metres (> 0)
//! \param out masked depth, same size as depth
//! \return kInvalidArgument on bad params, empty views, size mismatch or partial overlap
Status range_mask(ImageView<const uint16_t> depth, const RangeMaskParams& params, float depth_scale,
                  ImageView<uint16_t> out);

}  // namespace edgefuse
