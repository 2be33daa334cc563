// Simulated hot-plug: tests and the console unplug and replug named devices; the runtime sees
// the same arrivals and departures a libusb hot-plug monitor reports.
#pragma once

#include <condition_variable>
#include <cstring>
#include <mutex>

#include "edgefuse/hal/clock.hpp"
#include "edgefuse/hal/device_monitor.hpp"

namespace edgefuse::hal {

class SimDeviceMonitor final : public DeviceMonitor {
 public:
  static constexpr int kDevices = 8;
  static constexpr int kEvents = 16;

  explicit SimDeviceMonitor(Clock& clock) : clock_(clock) {}
  HalStatus start() override { return HalStatus::kOk; }
  void stop() override {}
  HalStatus next_event(DeviceEvent& event, uint32_t timeout_ms) override;
  bool present(const char* device) override;
  //! Plugs (true) or unplugs (false) a device and queues the event.
  //! \param device the board's device name  \param plugged new state
  void set_present(const char* device, bool plugged);

 private:
  int find_or_add(const char* device);

  Clock& clock_;
  std::mutex mutex_;
  std::condition_variable cv_;
  char names_[kDevices][32] = {};
  bool absent_[kDevices] = {};
  int device_count_ = 0;
  DeviceEvent events_[kEvents];
  int head_ = 0, count_ = 0;
};

}  // namespace edgefuse::hal
