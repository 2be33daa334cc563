#include "edgefuse/hal/sim/sim_device_monitor.hpp"

#include <chrono>

namespace edgefuse::hal {

int SimDeviceMonitor::find_or_add(const char* device) {
  for (int i = 0; i < device_count_; ++i)
    if (std::strncmp(names_[i], device, sizeof(names_[i])) == 0) return i;
  if (device_count_ == kDevices) return -1;
  std::strncpy(names_[device_count_], device, sizeof(names_[0]) - 1);
  return device_count_++;
}

bool SimDeviceMonitor::present(const char* device) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (int i = 0; i < device_count_; ++i)
    if (std::strncmp(names_[i], device, sizeof(names_[i])) == 0) return !absent_[i];
  return true;  // devices never unplugged are present
}

void SimDeviceMonitor::set_present(const char* device, bool plugged) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const int i = find_or_add(device);
    if (i < 0 || absent_[i] == !plugged) return;
    absent_[i] = !plugged;
    if (count_ == kEvents) {  // oldest event lost; present() still tells the truth
      head_ = (head_ + 1) % kEvents;
      --count_;
    }
    DeviceEvent& e = events_[(head_ + count_) % kEvents];
    e = DeviceEvent{};
    e.kind = plugged ? DeviceEventKind::kArrived : DeviceEventKind::kDeparted;
    std::strncpy(e.device, device, sizeof(e.device) - 1);
    e.stamp_us = clock_.now_us();
    ++count_;
  }
  cv_.notify_all();
}

HalStatus SimDeviceMonitor::next_event(DeviceEvent& event, uint32_t timeout_ms) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!cv_.wait_for(lock, std::chrono::milliseconds(timeout_ms), [this] { return count_ > 0; }))
    return HalStatus::kTimeout;
  event = events_[head_];
  head_ = (head_ + 1) % kEvents;
  --count_;
  return HalStatus::kOk;
}

}  // namespace edgefuse::hal
