// Fault injection around any DepthCamera (tests, and the console's fault commands on the sim
// board): stall, dropped frames, garbage frames and unplug/replug, each armed from another thread.
#pragma once

#include <atomic>
#include <cstdint>

#include "edgefuse/hal/clock.hpp"
#include "edgefuse/hal/depth_camera.hpp"
#include "edgefuse/hal/sim/sim_device_monitor.hpp"

namespace edgefuse::hal {

enum class GarbageKind : uint8_t {
  kNone,
  kWrongSize,    //!< the frame reports another size than the mode's
  kAllInvalid,   //!< every depth pixel is 0
  kStampBack,    //!< the stamp goes back in time
};

class FaultCamera final : public DepthCamera {
 public:
  //! \param inner the camera to wrap  \param clock time base (stall timing)
  //! \param monitor receives unplug/replug events (may be null)
  FaultCamera(DepthCamera& inner, Clock& clock, SimDeviceMonitor* monitor = nullptr)
      : inner_(inner), clock_(clock), monitor_(monitor) {}

  const char* name() const override { return inner_.name(); }
  int mode_count() const override { return inner_.mode_count(); }
  bool mode(int index, DepthMode& m) const override { return inner_.mode(index, m); }
  HalStatus start(int mode_index) override;
  void stop() override { inner_.stop(); }
  PinholeIntrinsics intrinsics() const override { return inner_.intrinsics(); }
  HalStatus next_frame(DepthFrame& frame, uint32_t timeout_ms) override;

  //! No frames for duration_ms (next_frame times out; a reopen does not help).
  //! \param duration_ms stall length
  void inject_stall(uint32_t duration_ms) { stall_until_us_ = clock_.now_us() + uint64_t(duration_ms) * 1000u; }
  //! The next `frames` frames are lost inside the device (a sequence gap).
  //! \param frames how many
  void inject_drop(int frames) { drop_ += frames; }
  //! The next frame is garbage of this kind.
  //! \param kind what is wrong with it
  void inject_garbage(GarbageKind kind) { garbage_ = uint8_t(kind); }
  //! Unplugs (or replugs) the device: kNoDevice until replugged.
  //! \param plugged new state
  void set_plugged(bool plugged);
  //! Frames a start() after a replug: the device's counter restarts, as a real camera's does.
  uint32_t starts() const { return starts_; }

 private:
  DepthCamera& inner_;
  Clock& clock_;
  SimDeviceMonitor* monitor_;
  std::atomic<uint64_t> stall_until_us_{0};
  std::atomic<int> drop_{0};
  std::atomic<uint8_t> garbage_{0};
  std::atomic<bool> unplugged_{false};
  std::atomic<uint32_t> starts_{0};
};

}  // namespace edgefuse::hal
