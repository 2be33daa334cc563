#include "edgefuse/hal/sim/sim_line_scanner.hpp"

#include <cmath>

namespace edgefuse::hal {

SimLineScannerConfig sim_laser_config() {
  SimLineScannerConfig c;
  c.T_world_axis0.R << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  c.T_world_axis0.t = Vec3f(0.03f, -0.1495f, 0.22f);
  return c;
}

HalStatus SimLineScanner::start() {
  if (config_.info.beams < 2) return HalStatus::kInvalidArgument;
  const HalStatus s = trigger_.start(EdgeSelect::kRising, config_.debounce_us);
  if (s != HalStatus::kOk) return s;
  running_ = true;
  sequence_ = 0;
  return HalStatus::kOk;
}

void SimLineScanner::stop() {
  trigger_.stop();
  running_ = false;
}

Pose SimLineScanner::pose_at(double position_m) const {
  Pose p = config_.T_world_axis0;
  p.t += float(position_m) * config_.axis_world;
  return p;
}

HalStatus SimLineScanner::next_profile(LineProfile& profile, uint32_t timeout_ms) {
  if (!running_) return HalStatus::kNotStarted;
  const LineScannerInfo& in = config_.info;
  if (profile.ranges_m == nullptr || profile.capacity_beams < in.beams) return HalStatus::kInvalidArgument;
  TriggerEdge edge;
  const HalStatus s = trigger_.wait_edge(edge, timeout_ms);
  if (s != HalStatus::kOk) return s;
  double pos = 0;
  profile.has_position = axis_.position_at(edge.stamp_us, pos) == HalStatus::kOk;
  profile.axis_position_m = pos;
  profile.stamp_us = edge.stamp_us;
  profile.sequence = sequence_++;
  profile.beams = in.beams;
  const Pose T = pose_at(profile.has_position ? pos : 0.0);
  const float fov = in.fov_deg * 3.14159265f / 180.0f;
  const float cos_max = std::cos(80.0f * 3.14159265f / 180.0f);
  for (int i = 0; i < in.beams; ++i) {
    const float a = -0.5f * fov + float(i) * fov / float(in.beams - 1);
    const Vec3f dir = T.R * Vec3f(std::sin(a), 0.0f, std::cos(a));
    float r = 0;
    SimHit hit;
    if (scene_.intersect(T.t, dir, hit) && std::fabs(hit.normal_world.dot(dir)) >= cos_max &&
        !(scene_.solid(hit.solid).laser_loss > 0 && rng_.uniform() < scene_.solid(hit.solid).laser_loss)) {
      r = hit.t + 20e-6f * rng_.gaussian();
      r = std::round(r / 12e-6f) * 12e-6f;
      if (r < in.min_range_m || r > in.max_range_m) r = 0;
    }
    profile.ranges_m[i] = r;
  }
  return HalStatus::kOk;
}

}  // namespace edgefuse::hal
