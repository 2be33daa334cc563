// The time base shared by the replayed cameras of one recording (a rig set's depth sensors). Recording
// time t plays at  start_us + (t - first_stamp_s) / speed  on every camera, so their frames keep the
// recorded offsets between sensors whichever acquisition thread starts its camera first. The first
// camera to start (none running) fixes start_us; a camera that starts while others run (reopened
// after a stall) joins the running time base and resumes at the recording's present point, as a
// live sensor would.
#pragma once

#include <cstdint>
#include <limits>
#include <mutex>

namespace edgefuse::hal {

class ReplayEpoch {
 public:
  //! Widens the shared span by one camera's recording (call for each before any starts).
  //! \param first_stamp_s its first stamp  \param last_stamp_s its last stamp (recording seconds)
  void include(double first_stamp_s, double last_stamp_s) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (first_stamp_s < first_stamp_s_) first_stamp_s_ = first_stamp_s;
    if (last_stamp_s > last_stamp_s_) last_stamp_s_ = last_stamp_s;
  }
  //! A camera starts. \param now_us the HAL clock's time \return the time base's start (now_us
  //! when no other camera runs)
  uint64_t join(uint64_t now_us) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (running_++ == 0) start_us_ = now_us;
    return start_us_;
  }
  //! A camera stops (after join).
  void leave() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (running_ > 0) --running_;
  }
  //! Recording seconds of the earliest first frame of all cameras.
  double first_stamp_s() const { return first_stamp_s_; }
  //! Recording seconds of the latest last frame of all cameras.
  double last_stamp_s() const { return last_stamp_s_; }

 private:
  std::mutex mutex_;
  uint64_t start_us_ = 0;
  int running_ = 0;
  double first_stamp_s_ = std::numeric_limits<double>::infinity();
  double last_stamp_s_ = -std::numeric_limits<double>::infinity();
};

}  // namespace edgefuse::hal
