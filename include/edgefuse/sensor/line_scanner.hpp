// 2D laser line scanner moved linearly by the robot (paper eq. 6-8).
//
// A profile is `beams` ranges over a fan in the sensor's x'z' plane: beam i has the angle
// theta_i = -fov/2 + i fov / (beams - 1) and the direction (sin theta_i, 0, cos theta_i); range
// r_i (metres along the beam, 0 = no return) puts the point at r_i (sin theta_i, 0, cos theta_i)
// in the sensor frame, T_world_sensor r_i dir_i in the world (eq. 7 with the robot's pose of that
// profile). Back-projection (eq. 8): a point p' in the sensor frame belongs to the profile when it
// lies in the scan plane (|p'.y| within a band), its beam is theta = atan(p'.x / p'.z).
//
// Tables: the kernels never call atan: tan(theta_i) is increasing, so the beam of a point is found
// by bisection on tan_theta[] with p'.x / p'.z (same comparisons in float and Q16.16), and ranges
// are interpolated linearly in tan between the two neighbouring beams (the beams are < 0.1 deg
// apart; the error of interpolating in tan instead of the angle is below 1e-6 of the range).
#pragma once

#include <cmath>
#include <cstdint>

#include "edgefuse/core/status.hpp"
#include "edgefuse/math/real.hpp"

namespace edgefuse {

//! The line scanner's range noise (constant, 20 um): its trust against the cameras.
inline constexpr float kLineScannerSigmaM = 20e-6f;

struct LineScannerModel {
  int beams = 0;             //!< ranges per profile (>= 2)
  float fov_deg = 0;         //!< fan width (0 < fov < 180: the fan looks forward, z' > 0)
  float min_range_m = 0;     //!< nearest valid range
  float max_range_m = 0;     //!< farthest valid range

  Status validate() const {
    if (beams < 2 || !(fov_deg > 0.0f) || !(fov_deg < 180.0f) || !(min_range_m >= 0.0f) ||
        !(max_range_m > min_range_m))
      return Status::kInvalidArgument;
    return Status::kOk;
  }
  float beam_angle_rad(int i) const {
    const float fov = fov_deg * 3.14159265358979323846f / 180.0f;
    return -0.5f * fov + float(i) * fov / float(beams - 1);
  }
};

//! tan(theta_i) per beam, in caller (static) storage of the kernel scalar.
template <class Real>
struct LineScannerTables {
  Real* tan_theta = nullptr;  //!< beams entries
  int capacity = 0;           //!< entries available

  //! Fills the table for a scanner.
  //! \param model the scanner (validated)
  Status build(const LineScannerModel& model) {
    if (model.validate() != Status::kOk) return Status::kInvalidArgument;
    if (tan_theta == nullptr || capacity < model.beams) return Status::kCapacityExceeded;
    for (int i = 0; i < model.beams; ++i) tan_theta[i] = real_from<Real>(std::tan(model.beam_angle_rad(i)));
    return Status::kOk;
  }
};

}  // namespace edgefuse
