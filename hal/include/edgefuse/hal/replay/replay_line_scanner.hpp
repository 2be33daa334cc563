// Replays a rig set's line-scanner recording (profiles.txt + groundtruth.txt) as a LineScanner.
// The axis position of a profile is its sensor position projected on the axis through the first
// and last recorded positions (the laser is moved linearly), 0 at the first profile.
#pragma once

#include "edgefuse/hal/clock.hpp"
#include "edgefuse/hal/line_scanner.hpp"
#include "edgefuse/io/rig.hpp"
#include "edgefuse/hal/replay/replay_depth_camera.hpp"

namespace edgefuse::hal {

class ReplayLineScanner final : public LineScanner {
 public:
  //! \param scan the opened recording (kept by reference)  \param rate pacing  \param clock time base
  //! \param speed kRecorded: playback speed (0.5: half the recorded rate)
  ReplayLineScanner(const io::LineScan& scan, ReplayRate rate, Clock& clock, double speed = 1.0);
  const char* name() const override { return scan_.sensor.name.c_str(); }
  LineScannerInfo info() const override;
  HalStatus start() override;
  void stop() override { running_ = false; }
  HalStatus next_profile(LineProfile& profile, uint32_t timeout_ms) override;

 private:
  const io::LineScan& scan_;
  ReplayRate rate_;
  Clock& clock_;
  double speed_;
  bool running_ = false;
  std::size_t index_ = 0;
  uint64_t start_us_ = 0;
  Vec3f origin_ = Vec3f::Zero(), axis_ = Vec3f::Zero();
  bool has_axis_ = false;
};

}  // namespace edgefuse::hal
