// One thread per depth camera: streams frames into a FrameChannel, checks them, and survives
// faults without help from processing:
//   - no frame for stall_ms (timeouts) -> stop, back off, start again (reopen), back-off doubling
//     from backoff_min_ms to backoff_max_ms until a frame arrives;
//   - kNoDevice (unplugged) -> wait until the DeviceMonitor reports the device present, reopen;
//   - a bad frame (size, stamp, all invalid, driver) -> not published, reason counted;
//   - end of a recording -> state kEnded.
// Processing sees only frames or their absence (state() != kStreaming): it pauses tracking and
// keeps the space. The thread is created at start-up; the loop allocates nothing.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>

#include "edgefuse/hal/clock.hpp"
#include "edgefuse/hal/depth_camera.hpp"
#include "edgefuse/hal/device_monitor.hpp"
#include "edgefuse/hal/acquisition/acquisition_counters.hpp"
#include "edgefuse/hal/acquisition/frame_channel.hpp"
#include "edgefuse/hal/acquisition/frame_checks.hpp"

namespace edgefuse::hal {

struct CameraWorkerConfig {
  int mode_index = 0;             //!< mode to start
  uint32_t frame_timeout_ms = 200;  //!< one next_frame wait
  uint32_t stall_ms = 1000;       //!< no frame for this long: reopen
  uint32_t backoff_min_ms = 50;   //!< first wait before a reopen
  uint32_t backoff_max_ms = 2000; //!< longest wait between reopen attempts
  uint32_t replug_poll_ms = 100;  //!< how often an unplugged device's presence is checked
};

class CameraWorker {
 public:
  //! \param camera the device  \param channel frames go here (initialised)  \param counters tallies
  //! \param clock HAL clock  \param monitor hot-plug (null: a vanished device is retried with back-off)
  CameraWorker(DepthCamera& camera, FrameChannel& channel, AcquisitionCounters& counters, Clock& clock,
               DeviceMonitor* monitor = nullptr)
      : camera_(camera), channel_(channel), counters_(counters), clock_(clock), monitor_(monitor) {}
  ~CameraWorker() { stop(); }
  CameraWorker(const CameraWorker&) = delete;
  CameraWorker& operator=(const CameraWorker&) = delete;

  //! Starts the thread (start-up: creates it).
  //! \param config timing and mode
  bool start(const CameraWorkerConfig& config);
  //! Stops the thread and the camera.
  void stop();
  //! Wakes the thread early (e.g. the DeviceMonitor reported an arrival).
  void wake();
  DeviceState state() const { return counters_.device_state(); }
  DepthCamera& camera() { return camera_; }

 private:
  void run();
  //! Sleeps up to ms, returns early on stop() or wake().
  void wait_ms(uint32_t ms);
  void set_state(DeviceState s) { counters_.state.store(uint8_t(s)); }
  void enter_backoff();

  DepthCamera& camera_;
  FrameChannel& channel_;
  AcquisitionCounters& counters_;
  Clock& clock_;
  DeviceMonitor* monitor_;
  CameraWorkerConfig config_;
  FrameChecks checks_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::condition_variable cv_;
  bool woken_ = false;
  uint32_t backoff_ms_ = 0;
};

}  // namespace edgefuse::hal
