// Null backends (as AP_HAL's): every interface with a device that is never there. A board without
// a line scanner or a trigger line gets these, so the runtime needs no special cases.
#pragma once

#include <atomic>
#include <cstring>

#include "edgefuse/hal/clock.hpp"
#include "edgefuse/hal/depth_camera.hpp"
#include "edgefuse/hal/device_monitor.hpp"
#include "edgefuse/hal/line_scanner.hpp"
#include "edgefuse/hal/position_source.hpp"
#include "edgefuse/hal/trigger.hpp"

namespace edgefuse::hal {

//! A camera that is absent: start() fails with kNoDevice.
class NullDepthCamera final : public DepthCamera {
 public:
  const char* name() const override { return "null"; }
  int mode_count() const override { return 0; }
  bool mode(int, DepthMode&) const override { return false; }
  HalStatus start(int) override { return HalStatus::kNoDevice; }
  void stop() override {}
  PinholeIntrinsics intrinsics() const override { return PinholeIntrinsics{}; }
  HalStatus next_frame(DepthFrame&, uint32_t) override { return HalStatus::kNotStarted; }
};

class NullLineScanner final : public LineScanner {
 public:
  const char* name() const override { return "null"; }
  LineScannerInfo info() const override { return LineScannerInfo{}; }
  HalStatus start() override { return HalStatus::kNoDevice; }
  void stop() override {}
  HalStatus next_profile(LineProfile&, uint32_t) override { return HalStatus::kNotStarted; }
};

class NullTriggerInput final : public TriggerInput {
 public:
  HalStatus start(EdgeSelect, uint32_t) override { return HalStatus::kNoDevice; }
  void stop() override {}
  HalStatus wait_edge(TriggerEdge&, uint32_t) override { return HalStatus::kNotStarted; }
};

class NullTriggerOutput final : public TriggerOutput {
 public:
  HalStatus start() override { return HalStatus::kNoDevice; }
  void stop() override {}
  HalStatus set(bool) override { return HalStatus::kNotStarted; }
  HalStatus pulse(uint32_t) override { return HalStatus::kNotStarted; }
};

class NullPositionSource final : public PositionSource {
 public:
  HalStatus position_at(uint64_t, double&) override { return HalStatus::kNoDevice; }
};

//! No hot-plug information: every device counts as present, no events.
class NullDeviceMonitor final : public DeviceMonitor {
 public:
  HalStatus start() override { return HalStatus::kOk; }
  void stop() override {}
  HalStatus next_event(DeviceEvent&, uint32_t) override { return HalStatus::kTimeout; }
  bool present(const char*) override { return true; }
};

//! A clock that only moves when told (sleep_us advances it): deterministic tests of pacing.
class ManualClock final : public Clock {
 public:
  uint64_t now_us() const override { return now_.load(); }
  //! \param duration_us advances the clock instead of waiting
  void sleep_us(uint64_t duration_us) override { now_.fetch_add(duration_us); }
  //! \param t_us new time (must not go backwards)
  void set_us(uint64_t t_us) { now_.store(t_us); }

 private:
  std::atomic<uint64_t> now_{1000000};
};

}  // namespace edgefuse::hal
