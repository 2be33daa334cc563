// A simulated linear axis (the robot moving the line scanner): position = start + speed * time.
#pragma once

#include "edgefuse/hal/position_source.hpp"

namespace edgefuse::hal {

class SimLinearAxis final : public PositionSource {
 public:
  //! \param t0_us time of start_m  \param start_m position at t0_us  \param speed_mps axis speed
  SimLinearAxis(uint64_t t0_us, double start_m, double speed_mps)
      : t0_us_(t0_us), start_m_(start_m), speed_mps_(speed_mps) {}
  HalStatus position_at(uint64_t stamp_us, double& position_m) override {
    position_m = start_m_ + speed_mps_ * (double(int64_t(stamp_us - t0_us_)) * 1e-6);
    return HalStatus::kOk;
  }
  //! \param t0_us new origin time (the axis restarts from start_m)
  void restart(uint64_t t0_us) { t0_us_ = t0_us; }

 private:
  uint64_t t0_us_;
  double start_m_;
  double speed_mps_;
};

}  // namespace edgefuse::hal
