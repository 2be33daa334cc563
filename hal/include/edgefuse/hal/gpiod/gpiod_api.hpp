// The library boundary of the gpiod backend: the few libgpiod operations it needs, in terms that
// both libgpiod 1.6 (Debian bookworm: chip/line objects, gpiod_line_event_wait/read, timespec
// stamps, no debounce) and libgpiod 2 (request/settings objects, edge-event buffers, ns stamps,
// kernel debounce) can provide. gpiod_api_v1.cpp implements it with libgpiod 1.6,
// gpiod_api_v2.cpp with libgpiod 2.x; hal/CMakeLists.txt links the one matching the found
// library's major version, and no other file includes gpiod.h. A fake (fake_gpiod_api.hpp) lets
// the trigger logic be tested on any host.
#pragma once

#include <cstdint>

#include "edgefuse/hal/trigger.hpp"

namespace edgefuse::hal {

struct GpiodRawEvent {
  EdgeKind kind = EdgeKind::kRising;
  uint64_t stamp_ns = 0;  //!< kernel time stamp (CLOCK_MONOTONIC on Linux >= 5.7 for the v1 ABI)
};

class GpiodApi {
 public:
  using Line = void*;  //!< an opaque requested line (owns its chip)

  virtual ~GpiodApi() = default;
  //! Opens `chip` (name "gpiochip0", path, label or number) and requests edge events on `offset`.
  //! \param chip chip descriptor  \param offset line offset  \param edges which edges
  //! \param debounce_us kernel debounce if the library supports it (v2); v1 ignores it
  //! \param consumer label shown by gpioinfo
  //! \return the line, or null with errno set
  virtual Line request_events(const char* chip, unsigned offset, EdgeSelect edges, uint32_t debounce_us,
                              const char* consumer) = 0;
  //! Opens `chip` and requests `offset` as an output at `value`.
  //! \param chip chip descriptor  \param offset line offset  \param consumer label  \param value initial level
  virtual Line request_output(const char* chip, unsigned offset, const char* consumer, int value) = 0;
  //! Releases the line and closes its chip.
  //! \param line from request_*
  virtual void release(Line line) = 0;
  //! Waits for an event: 1 ready, 0 timeout, -1 error (errno: EINTR, ENODEV...).
  //! \param line the line  \param timeout_ms longest wait
  virtual int wait_event(Line line, uint32_t timeout_ms) = 0;
  //! Reads one pending event: 0 ok, -1 error (errno).
  //! \param line the line  \param event receives it
  virtual int read_event(Line line, GpiodRawEvent& event) = 0;
  //! Drives an output line: 0 ok, -1 error.
  //! \param line the line  \param value 0 or 1
  virtual int set_value(Line line, int value) = 0;
  //! True when the library debounces in the kernel (libgpiod 2 on Linux >= 5.10).
  virtual bool kernel_debounce() const = 0;
};

//! libgpiod as built (1.6 on bookworm); null when the build has no libgpiod.
GpiodApi* libgpiod_api();

}  // namespace edgefuse::hal
