// Monotonic time for stamping and pacing. Every stamp in the HAL (stamp_us) is on this clock's
// time base (CLOCK_MONOTONIC on Linux, the same base as V4L2 buffer and gpiod event stamps), so
// stamps from different devices can be compared directly when pairing frames.
#pragma once

#include <cstdint>

namespace edgefuse::hal {

class Clock {
 public:
  virtual ~Clock() = default;
  //! Microseconds since an arbitrary fixed origin; never goes backwards.
  virtual uint64_t now_us() const = 0;
  //! Blocks the calling thread for about `duration_us` microseconds.
  //! \param duration_us time to wait
  virtual void sleep_us(uint64_t duration_us) = 0;
};

}  // namespace edgefuse::hal
