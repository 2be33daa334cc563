// The axis position along which a line scanner is moved (paper eq. 6-8): an encoder or the
// robot's reported position, looked up at an edge's time stamp.
#pragma once

#include <cstdint>

#include "edgefuse/hal/hal_status.hpp"

namespace edgefuse::hal {

class PositionSource {
 public:
  virtual ~PositionSource() = default;
  //! Position along the axis at time stamp_us (interpolated between samples).
  //! \param stamp_us HAL clock time  \param position_m receives the position in metres
  virtual HalStatus position_at(uint64_t stamp_us, double& position_m) = 0;
};

}  // namespace edgefuse::hal
