// Sanity checks on every frame before processing sees it: the size the mode promised, a stamp
// later than the previous frame's, and at least one valid depth pixel. A frame that fails is not
// published; its reason is counted.
#pragma once

#include "edgefuse/hal/depth_camera.hpp"
#include "edgefuse/hal/acquisition/acquisition_counters.hpp"

namespace edgefuse::hal {

class FrameChecks {
 public:
  //! \param mode the running mode (expected size)
  void reset(const DepthMode& mode) {
    mode_ = mode;
    have_seq_ = false;
  }
  //! Checks `frame`; returns the sequence gap before it in `gap` (rejected or not) and, on
  //! success, remembers its stamp.
  //! \param frame the frame  \param gap receives frames missing before it (device sequence)
  FrameReject check(const DepthFrame& frame, uint32_t& gap);

 private:
  DepthMode mode_;
  uint64_t last_stamp_us_ = 0;  // kept across reopen: the HAL clock never goes back
  bool have_seq_ = false;
  uint32_t last_seq_ = 0;
};

}  // namespace edgefuse::hal
