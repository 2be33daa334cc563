// A simulated linear axis (the robot moving the line scanner): position = start + speed * time,
// optionally back and forth over a travel (a continuous scan of the bin).
#pragma once

#include <cmath>
#include <cstdint>

#include "edgefuse/hal/position_source.hpp"

namespace edgefuse::hal {

class SimLinearAxis final : public PositionSource {
 public:
  //! \param t0_us time of start_m  \param start_m position at t0_us  \param speed_mps axis speed
  //! \param travel_m > 0: the axis goes back and forth over [start_m, start_m + travel_m]
  SimLinearAxis(uint64_t t0_us, double start_m, double speed_mps, double travel_m = 0)
      : t0_us_(t0_us), start_m_(start_m), speed_mps_(speed_mps), travel_m_(travel_m) {}
  HalStatus position_at(uint64_t stamp_us, double& position_m) override {
    double d = speed_mps_ * (double(int64_t(stamp_us - t0_us_)) * 1e-6);
    if (travel_m_ > 0) {
      d = std::fmod(std::fabs(d), 2.0 * travel_m_);
      if (d > travel_m_) d = 2.0 * travel_m_ - d;
    }
    position_m = start_m_ + d;
    return HalStatus::kOk;
  }
  //! \param t0_us new origin time (the axis restarts from start_m)
  void restart(uint64_t t0_us) { t0_us_ = t0_us; }

 private:
  uint64_t t0_us_;
  double start_m_;
  double speed_mps_;
  double travel_m_;
};

}  // namespace edgefuse::hal
