// The library boundary of the libusb backend: context, enumeration and hot-plug, in the few calls
// the monitor needs, so a fake (fake_usb_api.hpp) can drive it on any host. libusb_api.cpp is the
// only file that includes libusb.h.
#pragma once

#include <cstdint>

namespace edgefuse::hal {

struct UsbId {
  uint16_t vendor_id = 0;
  uint16_t product_id = 0;
  uint8_t bus = 0;
  uint8_t address = 0;
};

class UsbApi {
 public:
  //! Hot-plug callback: arrived (true) or left (false).
  using HotplugFn = void (*)(void* user, const UsbId& id, bool arrived);

  virtual ~UsbApi() = default;
  //! Creates the context: 0 ok, else a negative libusb error.
  virtual int init() = 0;
  virtual void exit() = 0;
  //! Lists the connected devices into `ids` (up to `capacity`); returns the count or a negative error.
  //! \param ids output  \param capacity size of ids
  virtual int enumerate(UsbId* ids, int capacity) = 0;
  //! Whether the platform reports hot-plug events.
  virtual bool has_hotplug() = 0;
  //! Registers `fn` for every arrival and departure: 0 ok.
  //! \param fn callback  \param user its argument
  virtual int register_hotplug(HotplugFn fn, void* user) = 0;
  //! Processes pending events for up to timeout_ms (callbacks run inside): 0 ok.
  //! \param timeout_ms longest wait
  virtual int handle_events(uint32_t timeout_ms) = 0;
  //! Text of a libusb error code.
  //! \param code negative libusb error
  virtual const char* error_name(int code) = 0;
};

//! The real libusb 1.0.
UsbApi& libusb_api();

}  // namespace edgefuse::hal
