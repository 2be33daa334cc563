// Consumes a DeviceMonitor's events on its own thread, counts them, and wakes the worker of a
// device that arrived so it reopens at once instead of at its next presence poll.
#pragma once

#include <atomic>
#include <cstring>
#include <thread>

#include "edgefuse/hal/device_monitor.hpp"
#include "edgefuse/hal/acquisition/camera_worker.hpp"

namespace edgefuse::hal {

class HotplugWatcher {
 public:
  static constexpr int kMaxWorkers = 8;

  explicit HotplugWatcher(DeviceMonitor& monitor) : monitor_(monitor) {}
  ~HotplugWatcher() { stop(); }
  //! Adds a worker to wake (before start()).
  //! \param worker a camera worker
  bool add(CameraWorker& worker) {
    if (count_ == kMaxWorkers) return false;
    workers_[count_++] = &worker;
    return true;
  }
  bool start() {
    if (thread_.joinable() || monitor_.start() != HalStatus::kOk) return false;
    stop_ = false;
    thread_ = std::thread([this] {
      DeviceEvent e;
      while (!stop_) {
        if (monitor_.next_event(e, 100) != HalStatus::kOk) continue;
        (e.kind == DeviceEventKind::kArrived ? arrivals_ : departures_).fetch_add(1);
        for (int i = 0; i < count_; ++i)
          if (std::strncmp(workers_[i]->camera().name(), e.device, sizeof(e.device)) == 0) workers_[i]->wake();
      }
    });
    return true;
  }
  void stop() {
    if (!thread_.joinable()) return;
    stop_ = true;
    thread_.join();
    monitor_.stop();
  }
  uint32_t arrivals() const { return arrivals_; }
  uint32_t departures() const { return departures_; }

 private:
  DeviceMonitor& monitor_;
  CameraWorker* workers_[kMaxWorkers] = {};
  int count_ = 0;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<uint32_t> arrivals_{0}, departures_{0};
};

}  // namespace edgefuse::hal
