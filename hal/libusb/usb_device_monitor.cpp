#include "edgefuse/hal/libusb/usb_device_monitor.hpp"

#include <cstdio>
#include <cstring>

namespace edgefuse::hal {

bool UsbDeviceMonitor::watch(const char* name, uint16_t vendor_id, uint16_t product_id) {
  if (started_ || watched_count_ == kMaxWatched || name == nullptr || std::strlen(name) >= sizeof(UsbWatch::name))
    return false;
  UsbWatch& w = watched_[watched_count_++];
  std::strncpy(w.name, name, sizeof(w.name) - 1);
  w.vendor_id = vendor_id;
  w.product_id = product_id;
  return true;
}

void UsbDeviceMonitor::on_hotplug(void* self, const UsbId&, bool) {
  // Only a wake-up: the bus is re-enumerated and compared, so a device seen by both the start-up
  // scan and a callback, or two identical sensors, are counted right.
  static_cast<UsbDeviceMonitor*>(self)->changed_ = true;
}

void UsbDeviceMonitor::note(const UsbId& id, bool arrived) {
  for (int i = 0; i < watched_count_; ++i) {
    const UsbWatch& w = watched_[i];
    if (w.vendor_id != id.vendor_id || w.product_id != id.product_id) continue;
    if (!arrived && count_[i].load() == 0) continue;  // a departure we never saw arrive
    count_[i].fetch_add(arrived ? 1 : -1);
    if (queued_ == kEvents) {  // the oldest event is lost; present() still tells the truth
      head_ = (head_ + 1) % kEvents;
      --queued_;
    }
    DeviceEvent& e = events_[(head_ + queued_) % kEvents];
    e = DeviceEvent{};
    e.kind = arrived ? DeviceEventKind::kArrived : DeviceEventKind::kDeparted;
    std::memcpy(e.device, w.name, sizeof(e.device));
    e.vendor_id = id.vendor_id;
    e.product_id = id.product_id;
    e.stamp_us = clock_.now_us();
    ++queued_;
  }
}

void UsbDeviceMonitor::rescan() {
  const int n = api_.enumerate(bus_, kMaxBusDevices);
  if (n < 0) return;
  for (int i = 0; i < watched_count_; ++i) {
    int now = 0;
    for (int k = 0; k < n; ++k)
      now += bus_[k].vendor_id == watched_[i].vendor_id && bus_[k].product_id == watched_[i].product_id;
    const UsbId id{watched_[i].vendor_id, watched_[i].product_id, 0, 0};
    while (count_[i].load() < now) note(id, true);
    while (count_[i].load() > now) note(id, false);
  }
}

HalStatus UsbDeviceMonitor::start() {
  if (started_) return HalStatus::kOk;
  const int r = api_.init();
  if (r != 0) {
    std::snprintf(error_, sizeof(error_), "libusb init: %s", api_.error_name(r));
    return HalStatus::kIoError;
  }
  started_ = true;
  hotplug_ = api_.has_hotplug() && api_.register_hotplug(&UsbDeviceMonitor::on_hotplug, this) == 0;
  // Present devices become arrivals (hot-plug is registered first, so none is missed in between).
  rescan();
  return HalStatus::kOk;
}

void UsbDeviceMonitor::stop() {
  if (!started_) return;
  api_.exit();
  started_ = false;
}

bool UsbDeviceMonitor::pop(DeviceEvent& event) {
  if (queued_ == 0) return false;
  event = events_[head_];
  head_ = (head_ + 1) % kEvents;
  --queued_;
  return true;
}

HalStatus UsbDeviceMonitor::next_event(DeviceEvent& event, uint32_t timeout_ms) {
  if (!started_) return HalStatus::kNotStarted;
  if (pop(event)) return HalStatus::kOk;
  if (hotplug_) {
    changed_ = false;
    const int r = api_.handle_events(timeout_ms);
    if (r != 0) {
      std::snprintf(error_, sizeof(error_), "libusb events: %s", api_.error_name(r));
      return HalStatus::kIoError;
    }
    if (changed_) rescan();
  } else {
    clock_.sleep_us(uint64_t(timeout_ms) * 1000u);  // polling fallback: one scan per call
    rescan();
  }
  return pop(event) ? HalStatus::kOk : HalStatus::kTimeout;
}

bool UsbDeviceMonitor::present(const char* device) {
  for (int i = 0; i < watched_count_; ++i)
    if (std::strncmp(watched_[i].name, device, sizeof(watched_[i].name)) == 0) return count_[i].load() > 0;
  return true;  // not a USB device of the board: not ours to judge
}

}  // namespace edgefuse::hal
