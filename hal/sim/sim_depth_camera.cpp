#include "edgefuse/hal/sim/sim_depth_camera.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace edgefuse::hal {

SimDepthCameraConfig sim_xtion_config() {
  SimDepthCameraConfig c;
  c.name = "xtion";
  c.model = SimDepthModel::kStructuredLight;
  c.intr.width = 320;
  c.intr.height = 240;
  c.intr.fx = c.intr.fy = 288.6f;
  c.intr.cx = 159.5f;
  c.intr.cy = 119.5f;
  c.intr.depth_scale = 5000;
  c.intr.min_range_m = 0.4f;
  c.intr.max_range_m = 3.5f;
  c.seed = 1;
  return c;
}

SimDepthCameraConfig sim_tof_config() {
  SimDepthCameraConfig c;
  c.name = "tof";
  c.model = SimDepthModel::kTof;
  c.intr.width = 160;
  c.intr.height = 120;
  c.intr.fx = 80.0f;
  c.intr.fy = 88.95f;
  c.intr.cx = 79.5f;
  c.intr.cy = 59.5f;
  c.intr.depth_scale = 5000;
  c.intr.min_range_m = 0.1f;
  c.intr.max_range_m = 1.5f;
  // extrinsics.txt: tof in the xtion frame (3.42 deg about (-0.449, -0.627, 0.637)).
  const float angle = 3.42f * 3.14159265f / 180.0f;
  const Vec3f axis = Vec3f(-0.449f, -0.627f, 0.637f).normalized();
  c.T_rig_cam.R = Eigen::AngleAxisf(angle, axis).toRotationMatrix();
  c.T_rig_cam.t = Vec3f(0.0573f, 0.0073f, -0.0006f);
  c.seed = 2;
  return c;
}

Pose sim_rig_pose(double t_s, float radius_m, float period_s) {
  const double phase = period_s > 0 ? 2.0 * 3.14159265358979 * t_s / period_s : 0.0;
  Pose p;
  // Looking straight down: x' = x, y' = -y, z' = -z.
  p.R << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  p.t = Vec3f(radius_m * float(std::cos(phase)), radius_m * float(std::sin(phase)), 0.70f);
  return p;
}

SimDepthCamera::SimDepthCamera(const SimDepthCameraConfig& config, const SimScene& scene, Clock& clock)
    : config_(config), scene_(scene), clock_(clock), rng_(config.seed), intr_(config.intr) {}

int SimDepthCamera::mode_count() const { return config_.model == SimDepthModel::kStructuredLight ? 2 : 1; }

bool SimDepthCamera::mode(int index, DepthMode& m) const {
  if (index < 0 || index >= mode_count()) return false;
  const int scale = index == 1 ? 2 : 1;
  m.width = config_.intr.width * scale;
  m.height = config_.intr.height * scale;
  m.fps = config_.fps;
  m.depth_scale = config_.intr.depth_scale;
  m.colour = config_.model == SimDepthModel::kStructuredLight;
  m.amplitude = config_.model == SimDepthModel::kTof;
  return true;
}

HalStatus SimDepthCamera::start(int mode_index) {
  if (!mode(mode_index, mode_) || mode_.width > kMaxWidth || config_.fps <= 0)
    return HalStatus::kInvalidArgument;
  const float s = float(mode_.width) / float(config_.intr.width);
  intr_ = config_.intr;
  intr_.width = mode_.width;
  intr_.height = mode_.height;
  intr_.fx *= s;
  intr_.fy *= s;
  intr_.cx = (config_.intr.cx + 0.5f) * s - 0.5f;
  intr_.cy = (config_.intr.cy + 0.5f) * s - 0.5f;
  running_ = true;
  start_us_ = clock_.now_us() + config_.start_offset_us;
  sequence_ = 0;
  last_stamp_us_ = 0;
  return HalStatus::kOk;
}

void SimDepthCamera::stop() { running_ = false; }

Pose SimDepthCamera::pose_of(uint32_t sequence) const {
  // Frame `sequence` is stamped start_us_ + sequence periods; with a rig epoch its pose is the
  // rig's at that clock time (start_us_ includes start_offset_us), the same for every camera.
  const double since_epoch_s =
      rig_epoch_us_ != 0 && start_us_ != 0 ? (double(start_us_) - double(rig_epoch_us_)) * 1e-6 : 0.0;
  const double t_s = since_epoch_s + double(sequence) / double(config_.fps > 0 ? config_.fps : 30);
  const Pose T_world_rig = config_.rig_path != nullptr ? config_.rig_path->at(t_s)
                                                      : sim_rig_pose(t_s, config_.rig_radius_m, config_.rig_period_s);
  return T_world_rig * config_.T_rig_cam;
}

HalStatus SimDepthCamera::next_frame(DepthFrame& frame, uint32_t timeout_ms) {
  if (!running_) return HalStatus::kNotStarted;
  if (!frame.fits(mode_.width, mode_.height)) return HalStatus::kInvalidArgument;
  const uint64_t period_us = 1000000u / uint64_t(config_.fps);
  uint64_t stamp_us = start_us_ + uint64_t(sequence_) * period_us;
  if (config_.paced) {
    // Read too late (or rendering slower than the rate): like a real camera, the frames nobody
    // took are gone; the next one is the current period's (a sequence gap).
    const uint64_t now = clock_.now_us();
    if (now > stamp_us + period_us) {
      sequence_ = uint32_t((now - start_us_) / period_us);
      stamp_us = start_us_ + uint64_t(sequence_) * period_us;
    }
    if (stamp_us > now) {
      const uint64_t wait_us = stamp_us - now;
      if (wait_us > uint64_t(timeout_ms) * 1000u) {
        clock_.sleep_us(uint64_t(timeout_ms) * 1000u);
        return HalStatus::kTimeout;
      }
      clock_.sleep_us(wait_us);
    }
  }
  if (stamp_us <= last_stamp_us_) stamp_us = last_stamp_us_ + 1;
  render(pose_of(sequence_), frame);
  frame.stamp_us = stamp_us;
  frame.sequence = sequence_;
  last_stamp_us_ = stamp_us;
  ++sequence_;
  return HalStatus::kOk;
}

void SimDepthCamera::render(const Pose& T_world_cam, DepthFrame& frame) {
  frame.width = mode_.width;
  frame.height = mode_.height;
  frame.depth_scale = intr_.depth_scale;
  frame.has_colour = mode_.colour && frame.colour != nullptr;
  frame.has_amplitude = mode_.amplitude && frame.amplitude != nullptr;
  if (config_.model == SimDepthModel::kStructuredLight)
    render_structured_light(T_world_cam, frame);
  else
    render_tof(T_world_cam, frame);
}

namespace {

uint16_t to_raw(float z_m, float scale) {
  const float r = std::round(z_m * scale);
  return r <= 0 ? 0 : (r >= 65535.0f ? 0 : uint16_t(r));
}

}  // namespace

void SimDepthCamera::render_structured_light(const Pose& T, DepthFrame& f) {
  const float cos_max = std::cos(75.0f * 3.14159265f / 180.0f);
  const Vec3f projector_world = T * Vec3f(0.075f, 0, 0);
  for (int v = 0; v < f.height; ++v) {
    for (int u = 0; u < f.width; ++u) {
      const std::size_t i = std::size_t(v) * std::size_t(f.width) + std::size_t(u);
      f.depth[i] = 0;
      if (f.has_colour) f.colour[i] = Rgb8{0, 0, 0};
      const Vec3f ray_cam = intr_.ray(float(u), float(v));
      const float norm = ray_cam.norm();
      const Vec3f dir = T.R * (ray_cam / norm);
      SimHit hit;
      if (!scene_.intersect(T.t, dir, hit)) continue;
      const float cos_inc = std::fabs(hit.normal_world.dot(dir));
      const Vec3f p = T.t + hit.t * dir;
      if (f.has_colour) {
        const Rgb8 c = scene_.solid(hit.solid).colour;
        const float k = 0.25f + 0.75f * cos_inc;
        f.colour[i] = Rgb8{uint8_t(c.r * k), uint8_t(c.g * k), uint8_t(c.b * k)};
      }
      if (cos_inc < cos_max) continue;
      float z = hit.t / norm;
      if (z < intr_.min_range_m || z > intr_.max_range_m) continue;
      // Projector shadow: the point must be visible from the projector (1 mm tolerance).
      const Vec3f to_p = p - projector_world;
      const float dist = to_p.norm();
      SimHit occ;
      if (scene_.intersect(projector_world, to_p / dist, occ) && occ.t < dist - 0.001f) continue;
      z += (0.0012f + 0.0019f * (z - 0.4f) * (z - 0.4f)) * rng_.gaussian();
      const float q = 0.0028f;
      z = 1.0f / (std::round((1.0f / z) / q) * q);
      f.depth[i] = to_raw(z, f.depth_scale);
    }
  }
}

void SimDepthCamera::render_tof(const Pose& T, DepthFrame& f) {
  const int w = f.width, h = f.height;
  const float s = f.depth_scale;
  // Pass 1: clean z-depth and amplitude (normalised amplitude a_n = amplitude / 20000).
  uint16_t* amp = f.has_amplitude ? f.amplitude : nullptr;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const std::size_t i = std::size_t(v) * std::size_t(w) + std::size_t(u);
      f.depth[i] = 0;
      if (amp) amp[i] = 0;
      const Vec3f ray_cam = intr_.ray(float(u), float(v));
      const float norm = ray_cam.norm();
      const Vec3f dir = T.R * (ray_cam / norm);
      SimHit hit;
      if (!scene_.intersect(T.t, dir, hit)) continue;
      const float z = hit.t / norm;
      const float cos_inc = std::fabs(hit.normal_world.dot(dir));
      const float a_n = scene_.solid(hit.solid).reflectivity * cos_inc * (0.5f / hit.t) * (0.5f / hit.t);
      f.depth[i] = to_raw(z, s);
      if (amp) {
        const float a = 20000.0f * a_n * (1.0f + 0.02f * rng_.gaussian());
        amp[i] = uint16_t(std::clamp(a, 0.0f, 65535.0f));
      }
    }
  }
  // Pass 2: flying pixels, noise and the validity rules, in place with two clean rows kept.
  const float jump_raw = 0.03f * s;
  for (int v = 0; v < h; ++v) {
    uint16_t* row = f.depth + std::size_t(v) * std::size_t(w);
    std::memcpy(row_cur_, row, std::size_t(w) * sizeof(uint16_t));
    const uint16_t* below = v + 1 < h ? row + w : nullptr;
    for (int u = 0; u < w; ++u) {
      const float zc = row_cur_[u];
      if (zc == 0) continue;
      float z = zc / s;
      // Largest jump to a 4-neighbour that also hits something (clean values).
      float best_jump = 0, other = 0;
      const float nb[4] = {u > 0 ? float(row_cur_[u - 1]) : 0.0f, u + 1 < w ? float(row_cur_[u + 1]) : 0.0f,
                           v > 0 ? float(row_prev_[u]) : 0.0f, below ? float(below[u]) : 0.0f};
      for (float n : nb) {
        if (n == 0) continue;
        const float j = std::fabs(n - zc);
        if (j > best_jump) { best_jump = j; other = n; }
      }
      if (best_jump > jump_raw && rng_.uniform() < 0.5f) {
        const float a = rng_.uniform();
        const float fg = std::min(zc, other) / s, bg = std::max(zc, other) / s;
        z = a * fg + (1.0f - a) * bg;
      }
      const std::size_t i = std::size_t(v) * std::size_t(w) + std::size_t(u);
      // Without an amplitude buffer the a_n threshold and noise cannot be applied per pixel.
      const float a_n = amp ? float(amp[i]) / 20000.0f : 1.0f;
      if (a_n < 0.02f) {
        row[u] = 0;
        continue;
      }
      z += std::min(0.005f * z / std::sqrt(a_n), 0.02f) * rng_.gaussian();
      row[u] = (z < intr_.min_range_m || z > intr_.max_range_m) ? uint16_t(0) : to_raw(z, s);
    }
    std::memcpy(row_prev_, row_cur_, std::size_t(w) * sizeof(uint16_t));
  }
}

}  // namespace edgefuse::hal
