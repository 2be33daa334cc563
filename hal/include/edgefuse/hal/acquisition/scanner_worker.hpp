// One thread per line scanner: profiles (one per trigger edge) into a ProfileChannel, checked
// (beam count, monotonic stamp; a profile without returns is valid data: nothing in range). A pause in triggering is normal (the axis
// stands still), so timeouts are counted but do not reopen the device; a vanished or failing
// scanner is reopened with back-off. Processing drains every profile (none may be skipped: each
// is one slice of the scan), so the channel's pool should cover a processing hiccup.
#pragma once

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "edgefuse/hal/line_scanner.hpp"
#include "edgefuse/hal/acquisition/acquisition_counters.hpp"
#include "edgefuse/hal/acquisition/frame_channel.hpp"

namespace edgefuse::hal {

struct ScannerWorkerConfig {
  uint32_t profile_timeout_ms = 200;  //!< one next_profile wait
  uint32_t backoff_min_ms = 50;       //!< first wait before a reopen
  uint32_t backoff_max_ms = 2000;     //!< longest wait between reopen attempts
};

class ScannerWorker {
 public:
  //! \param scanner the device  \param channel profiles go here (initialised)  \param counters tallies
  ScannerWorker(LineScanner& scanner, ProfileChannel& channel, AcquisitionCounters& counters)
      : scanner_(scanner), channel_(channel), counters_(counters) {}
  ~ScannerWorker() { stop(); }
  ScannerWorker(const ScannerWorker&) = delete;
  ScannerWorker& operator=(const ScannerWorker&) = delete;

  //! Starts the thread (start-up: creates it).
  //! \param config timing
  bool start(const ScannerWorkerConfig& config);
  void stop();
  DeviceState state() const { return counters_.device_state(); }

 private:
  void run();
  void wait_ms(uint32_t ms);
  void set_state(DeviceState s) { counters_.state.store(uint8_t(s)); }

  LineScanner& scanner_;
  ProfileChannel& channel_;
  AcquisitionCounters& counters_;
  ScannerWorkerConfig config_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::condition_variable cv_;
};

}  // namespace edgefuse::hal
