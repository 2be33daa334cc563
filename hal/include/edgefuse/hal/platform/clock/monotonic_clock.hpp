// The HAL clock on Linux: CLOCK_MONOTONIC, the base of V4L2 buffer stamps and gpiod event stamps.
#pragma once

#include <time.h>

#include <cerrno>

#include "edgefuse/hal/clock.hpp"

namespace edgefuse::hal {

class MonotonicClock final : public Clock {
 public:
  uint64_t now_us() const override {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return uint64_t(ts.tv_sec) * 1000000u + uint64_t(ts.tv_nsec) / 1000u;
  }
  //! \param duration_us time to wait (restarted after signals)
  void sleep_us(uint64_t duration_us) override {
    timespec ts{};
    ts.tv_sec = time_t(duration_us / 1000000u);
    ts.tv_nsec = long(duration_us % 1000000u) * 1000;
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
    }
  }
};

//! The process-wide monotonic clock (one static backend object, as AP_HAL).
inline MonotonicClock& monotonic_clock() {
  static MonotonicClock clock;
  return clock;
}

}  // namespace edgefuse::hal
