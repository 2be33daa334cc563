// A 2D laser line scanner: one profile per trigger edge, stamped with the edge's kernel time and
// the axis position at that time. Beam i lies at theta_i = -fov/2 + i * fov / (beams - 1) in the
// sensor's x'z' plane (as io::LineScannerParams).
#pragma once

#include <cstdint>

#include "edgefuse/hal/hal_status.hpp"

namespace edgefuse::hal {

struct LineProfile {
  float* ranges_m = nullptr;   //!< caller storage, capacity_beams entries; 0 = no return
  int capacity_beams = 0;      //!< size of ranges_m
  int beams = 0;               //!< filled: beams of this profile
  uint64_t stamp_us = 0;       //!< the trigger edge's kernel time stamp
  uint32_t sequence = 0;       //!< profile counter
  bool has_position = false;   //!< axis_position_m is known
  double axis_position_m = 0;  //!< position of the axis at stamp_us
};

struct LineScannerInfo {
  int beams = 0;            //!< beams per profile
  float fov_deg = 0;        //!< fan angle
  float min_range_m = 0;    //!< nearest valid range
  float max_range_m = 0;    //!< farthest valid range
};

class LineScanner {
 public:
  virtual ~LineScanner() = default;
  virtual const char* name() const = 0;
  virtual LineScannerInfo info() const = 0;
  virtual HalStatus start() = 0;
  virtual void stop() = 0;
  //! Waits up to timeout_ms for the next triggered profile.
  //! \param profile caller storage (capacity_beams >= info().beams)  \param timeout_ms longest wait
  virtual HalStatus next_profile(LineProfile& profile, uint32_t timeout_ms) = 0;
};

}  // namespace edgefuse::hal
