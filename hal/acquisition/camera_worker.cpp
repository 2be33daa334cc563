#include "edgefuse/hal/acquisition/camera_worker.hpp"

#include <chrono>

namespace edgefuse::hal {

bool CameraWorker::start(const CameraWorkerConfig& config) {
  if (thread_.joinable()) return false;
  config_ = config;
  stop_ = false;
  backoff_ms_ = config.backoff_min_ms;
  thread_ = std::thread([this] { run(); });
  return true;
}

void CameraWorker::stop() {
  if (!thread_.joinable()) return;
  stop_ = true;
  wake();
  thread_.join();
}

void CameraWorker::wake() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    woken_ = true;
  }
  cv_.notify_all();
}

void CameraWorker::wait_ms(uint32_t ms) {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait_for(lock, std::chrono::milliseconds(ms), [this] { return woken_ || stop_.load(); });
  woken_ = false;
}

void CameraWorker::enter_backoff() {
  camera_.stop();
  set_state(DeviceState::kBackoff);
  wait_ms(backoff_ms_);
  backoff_ms_ = backoff_ms_ * 2 > config_.backoff_max_ms ? config_.backoff_max_ms : backoff_ms_ * 2;
  set_state(DeviceState::kOpening);
}

void CameraWorker::run() {
  set_state(DeviceState::kOpening);
  uint64_t last_frame_us = clock_.now_us();
  bool was_unplugged = false;
  while (!stop_) {
    const DeviceState st = state();
    if (st == DeviceState::kUnplugged) {
      if (monitor_ != nullptr && !monitor_->present(camera_.name())) {
        wait_ms(config_.replug_poll_ms);
        continue;
      }
      set_state(DeviceState::kOpening);
      continue;
    }
    if (st == DeviceState::kOpening) {
      if (monitor_ != nullptr && !monitor_->present(camera_.name())) {
        set_state(DeviceState::kUnplugged);
        was_unplugged = true;
        continue;
      }
      const HalStatus s = camera_.start(config_.mode_index);
      if (s != HalStatus::kOk) {
        counters_.open_failures.fetch_add(1, std::memory_order_relaxed);
        if (s == HalStatus::kNoDevice) was_unplugged = true;
        if (s == HalStatus::kNoDevice && monitor_ != nullptr && !monitor_->present(camera_.name())) {
          camera_.stop();
          set_state(DeviceState::kUnplugged);
        } else {
          enter_backoff();  // includes "present but will not open": no busy retry loop
        }
        continue;
      }
      if (was_unplugged) counters_.reconnects.fetch_add(1, std::memory_order_relaxed);
      was_unplugged = false;
      counters_.opens.fetch_add(1, std::memory_order_relaxed);
      DepthMode mode;
      camera_.mode(config_.mode_index, mode);
      checks_.reset(mode);
      last_frame_us = clock_.now_us();
      set_state(DeviceState::kStreaming);
      continue;
    }
    if (st == DeviceState::kEnded) {
      wait_ms(config_.replug_poll_ms);
      continue;
    }
    // Streaming.
    DepthFrame& frame = channel_.producer_frame();
    const HalStatus s = camera_.next_frame(frame, config_.frame_timeout_ms);
    switch (s) {
      case HalStatus::kOk: {
        counters_.frames.fetch_add(1, std::memory_order_relaxed);
        last_frame_us = clock_.now_us();
        uint32_t gap = 0;
        const FrameReject r = checks_.check(frame, gap);
        counters_.device_gaps.fetch_add(gap, std::memory_order_relaxed);
        if (r != FrameReject::kNone) {
          counters_.rejected[size_t(r)].fetch_add(1, std::memory_order_relaxed);
          break;
        }
        backoff_ms_ = config_.backoff_min_ms;  // healthy again: the next fault starts from the minimum
        channel_.publish();
        break;
      }
      case HalStatus::kTimeout:
        counters_.timeouts.fetch_add(1, std::memory_order_relaxed);
        if (clock_.now_us() - last_frame_us >= uint64_t(config_.stall_ms) * 1000u) {
          counters_.stalls.fetch_add(1, std::memory_order_relaxed);
          enter_backoff();
          last_frame_us = clock_.now_us();
        }
        break;
      case HalStatus::kNoDevice:
        counters_.disconnects.fetch_add(1, std::memory_order_relaxed);
        camera_.stop();
        was_unplugged = true;
        if (monitor_ != nullptr)
          set_state(DeviceState::kUnplugged);
        else
          enter_backoff();
        break;
      case HalStatus::kBadFrame:
        counters_.rejected[size_t(FrameReject::kDriver)].fetch_add(1, std::memory_order_relaxed);
        break;
      case HalStatus::kEndOfStream:
        camera_.stop();
        set_state(DeviceState::kEnded);
        break;
      default:
        counters_.io_errors.fetch_add(1, std::memory_order_relaxed);
        enter_backoff();
        break;
    }
  }
  camera_.stop();
  set_state(DeviceState::kStopped);
}

}  // namespace edgefuse::hal
