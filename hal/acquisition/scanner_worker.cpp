#include "edgefuse/hal/acquisition/scanner_worker.hpp"

#include <chrono>

namespace edgefuse::hal {

bool ScannerWorker::start(const ScannerWorkerConfig& config) {
  if (thread_.joinable()) return false;
  config_ = config;
  stop_ = false;
  thread_ = std::thread([this] { run(); });
  return true;
}

void ScannerWorker::stop() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

void ScannerWorker::wait_ms(uint32_t ms) {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait_for(lock, std::chrono::milliseconds(ms), [this] { return stop_.load(); });
}

void ScannerWorker::run() {
  uint32_t backoff_ms = config_.backoff_min_ms;
  uint64_t last_stamp_us = 0;
  bool have_seq = false;
  uint32_t last_seq = 0;
  set_state(DeviceState::kOpening);
  while (!stop_) {
    if (state() != DeviceState::kStreaming) {
      const HalStatus s = scanner_.start();
      if (s != HalStatus::kOk) {
        counters_.open_failures.fetch_add(1, std::memory_order_relaxed);
        set_state(DeviceState::kBackoff);
        wait_ms(backoff_ms);
        backoff_ms = backoff_ms * 2 > config_.backoff_max_ms ? config_.backoff_max_ms : backoff_ms * 2;
        continue;
      }
      counters_.opens.fetch_add(1, std::memory_order_relaxed);
      have_seq = false;
      set_state(DeviceState::kStreaming);
    }
    LineProfile& p = channel_.producer_frame();
    const HalStatus s = scanner_.next_profile(p, config_.profile_timeout_ms);
    if (s == HalStatus::kTimeout) {
      counters_.timeouts.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    if (s == HalStatus::kEndOfStream) {
      scanner_.stop();
      set_state(DeviceState::kEnded);
      while (!stop_) wait_ms(100);
      break;
    }
    if (s != HalStatus::kOk) {
      (s == HalStatus::kNoDevice ? counters_.disconnects : counters_.io_errors).fetch_add(1, std::memory_order_relaxed);
      scanner_.stop();
      set_state(DeviceState::kBackoff);
      wait_ms(backoff_ms);
      backoff_ms = backoff_ms * 2 > config_.backoff_max_ms ? config_.backoff_max_ms : backoff_ms * 2;
      continue;
    }
    counters_.frames.fetch_add(1, std::memory_order_relaxed);
    if (have_seq && p.sequence > last_seq + 1)
      counters_.device_gaps.fetch_add(p.sequence - last_seq - 1, std::memory_order_relaxed);
    have_seq = true;
    last_seq = p.sequence;
    FrameReject r = FrameReject::kNone;
    if (p.beams != scanner_.info().beams || p.beams > p.capacity_beams) {
      r = FrameReject::kSize;
    } else if (p.stamp_us <= last_stamp_us) {
      r = FrameReject::kStamp;
    }
    // A profile without returns is kept: it says that the fan saw nothing in range there.
    if (r != FrameReject::kNone) {
      counters_.rejected[size_t(r)].fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    backoff_ms = config_.backoff_min_ms;
    last_stamp_us = p.stamp_us;
    channel_.publish();
  }
  scanner_.stop();
  set_state(DeviceState::kStopped);
}

}  // namespace edgefuse::hal
