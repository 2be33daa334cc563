// DeviceMonitor over libusb: the board's sensors, listed by VID:PID in board/<name>/hal.toml,
// are enumerated at start (present ones are reported as arrivals) and then followed: a libusb
// hot-plug callback triggers a re-enumeration whose differences are reported (where the platform
// has no hot-plug support, each next_event() re-enumerates). Fixed tables, no allocation after start().
#pragma once

#include <atomic>
#include <cstdint>

#include "edgefuse/hal/clock.hpp"
#include "edgefuse/hal/device_monitor.hpp"
#include "edgefuse/hal/libusb/usb_api.hpp"

namespace edgefuse::hal {

struct UsbWatch {
  char name[32] = {};       //!< the board's device name
  uint16_t vendor_id = 0;   //!< VID
  uint16_t product_id = 0;  //!< PID
};

class UsbDeviceMonitor final : public DeviceMonitor {
 public:
  static constexpr int kMaxWatched = 8;
  static constexpr int kMaxBusDevices = 128;
  static constexpr int kEvents = 32;

  //! \param api libusb (or a fake)  \param clock event stamps
  UsbDeviceMonitor(UsbApi& api, Clock& clock) : api_(api), clock_(clock) {}
  ~UsbDeviceMonitor() override { stop(); }
  //! Watches a device (before start()).
  //! \param name board device name  \param vendor_id VID  \param product_id PID
  bool watch(const char* name, uint16_t vendor_id, uint16_t product_id);

  HalStatus start() override;
  void stop() override;
  //! Called from one thread (the runtime's HotplugWatcher); present() from any.
  HalStatus next_event(DeviceEvent& event, uint32_t timeout_ms) override;
  bool present(const char* device) override;
  bool hotplug() const { return hotplug_; }
  const char* last_error() const { return error_; }

 private:
  static void on_hotplug(void* self, const UsbId& id, bool arrived);
  void note(const UsbId& id, bool arrived);
  void rescan();
  bool pop(DeviceEvent& event);

  UsbApi& api_;
  Clock& clock_;
  UsbWatch watched_[kMaxWatched];
  std::atomic<int> count_[kMaxWatched] = {};  // connected devices matching each watch
  int watched_count_ = 0;
  bool started_ = false;
  bool hotplug_ = false;
  bool changed_ = false;  // set by the hot-plug callback (same thread, inside handle_events)
  DeviceEvent events_[kEvents];
  int head_ = 0, queued_ = 0;
  UsbId bus_[kMaxBusDevices];
  char error_[128] = {};
};

}  // namespace edgefuse::hal
