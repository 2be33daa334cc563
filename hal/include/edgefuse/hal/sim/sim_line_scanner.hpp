// Simulated 2D laser line scanner (bin_rig_a's laser): one profile per trigger edge, the sensor
// carried along an axis by a PositionSource. Ranges: exact, + 20 um gaussian noise, quantised to
// 12 um; no return outside the range limits, beyond 80 deg incidence, and with the solid's
// laser_loss probability (the dark can loses 70%).
#pragma once

#include "edgefuse/hal/line_scanner.hpp"
#include "edgefuse/hal/position_source.hpp"
#include "edgefuse/hal/trigger.hpp"
#include "edgefuse/hal/sim/sim_random.hpp"
#include "edgefuse/hal/sim/sim_scene.hpp"

namespace edgefuse::hal {

struct SimLineScannerConfig {
  const char* name = "laser";
  LineScannerInfo info{640, 20.0f, 0.05f, 0.265f};
  Pose T_world_axis0;                        //!< sensor pose at axis position 0
  Vec3f axis_world = Vec3f(0, 1, 0);         //!< unit direction the axis moves the sensor
  uint32_t debounce_us = 0;                  //!< trigger debounce
  uint64_t seed = 3;
};

//! bin_rig_a's laser: looking straight down from 0.22 m at x = 0.03 m, moving along world +y
//! from y = -0.1495 m (axis position 0).
SimLineScannerConfig sim_laser_config();

class SimLineScanner final : public LineScanner {
 public:
  //! \param config sensor and mounting  \param scene what it sees  \param trigger fires profiles
  //! \param axis position of the carrying axis at each edge
  SimLineScanner(const SimLineScannerConfig& config, const SimScene& scene, TriggerInput& trigger,
                 PositionSource& axis)
      : config_(config), scene_(scene), trigger_(trigger), axis_(axis), rng_(config.seed) {}

  const char* name() const override { return config_.name; }
  LineScannerInfo info() const override { return config_.info; }
  HalStatus start() override;
  void stop() override;
  HalStatus next_profile(LineProfile& profile, uint32_t timeout_ms) override;

  //! Sensor-to-world pose at an axis position (ground truth).
  //! \param position_m axis position
  Pose pose_at(double position_m) const;

 private:
  SimLineScannerConfig config_;
  const SimScene& scene_;
  TriggerInput& trigger_;
  PositionSource& axis_;
  SimRandom rng_;
  bool running_ = false;
  uint32_t sequence_ = 0;
};

}  // namespace edgefuse::hal
