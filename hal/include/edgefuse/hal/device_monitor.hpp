// Hot-plug: arrivals and departures of the board's devices (libusb hot-plug, or simulated). The
// acquisition runtime waits for an arrival before reopening a camera that vanished.
#pragma once

#include <cstdint>

#include "edgefuse/hal/hal_status.hpp"

namespace edgefuse::hal {

enum class DeviceEventKind : uint8_t { kArrived, kDeparted };

struct DeviceEvent {
  DeviceEventKind kind = DeviceEventKind::kArrived;
  char device[32] = {};    //!< the board's device name (e.g. "xtion"), NUL-terminated
  uint16_t vendor_id = 0;  //!< USB VID (0 when not a USB device)
  uint16_t product_id = 0; //!< USB PID
  uint64_t stamp_us = 0;   //!< when the event was seen
};

class DeviceMonitor {
 public:
  virtual ~DeviceMonitor() = default;
  virtual HalStatus start() = 0;
  virtual void stop() = 0;
  //! Waits up to timeout_ms for the next arrival or departure.
  //! \param event receives the event  \param timeout_ms longest wait
  virtual HalStatus next_event(DeviceEvent& event, uint32_t timeout_ms) = 0;
  //! Whether the named device is present now.
  //! \param device the board's device name
  virtual bool present(const char* device) = 0;
};

}  // namespace edgefuse::hal
