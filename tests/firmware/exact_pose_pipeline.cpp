#include "exact_pose_pipeline.hpp"

#include <cstring>

namespace edgefuse_test {

// Three parts lying in a bin about 0.7 m below the rig (world frame = robot base).
const SimObject kSimObjects[3] = {
    {"bracket", {0.412f, -0.105f, 0.031f, 0.0f, 0.0f, 0.2588190f, 0.9659258f}, 0.93f},
    {"cylinder", {0.475f, 0.020f, 0.045f, 0.7071068f, 0.0f, 0.0f, 0.7071068f}, 0.88f},
    {"box", {0.390f, 0.110f, 0.025f, 0.0f, 0.0f, 0.0f, 1.0f}, 0.61f},
};

namespace {
constexpr uint64_t kFramePeriodUs = 33333;   // 30 Hz
constexpr uint64_t kMovingUs = 2000000;      // the rig moves for 2 s after scan start
constexpr uint64_t kLocalizeUs = 100000;     // 0.1 s of "localisation"
}  // namespace

const char* ExactPosePipeline::device_name(int i) const {
  static const char* const k[] = {"xtion", "tof", "laser"};
  return i >= 0 && i < 3 ? k[i] : "?";
}

bool ExactPosePipeline::start_mapping(const char**) {
  mapping_ = true;
  mapping_since_us_ = now_us_;
  last_frame_us_ = now_us_;
  return true;
}

void ExactPosePipeline::step(uint64_t now_us) {
  now_us_ = now_us;
  if (!mapping_) {
    stats_.fps = 0;
    stats_.tracking = runtime::TrackingState::kOff;
    stats_.still_since_us = 0;
    return;
  }
  while (now_us - last_frame_us_ >= kFramePeriodUs) {
    last_frame_us_ += kFramePeriodUs;
    ++stats_.frames;
    ++map_frames_;
    capture_us_ = last_frame_us_;
  }
  stats_.fps = 30.0f;
  stats_.tracking = runtime::TrackingState::kOk;
  stats_.still_since_us = now_us - mapping_since_us_ >= kMovingUs ? mapping_since_us_ + kMovingUs : 0;
}

bool ExactPosePipeline::start_localization(uint64_t now_us, const char** why) {
  if (map_frames_ == 0) {
    *why = "the map is empty";
    return false;
  }
  localizing_ = true;
  localize_done_us_ = now_us + kLocalizeUs;
  return true;
}

bool ExactPosePipeline::poll_localization(runtime::LocalizationOutcome& out) {
  if (!localizing_ || now_us_ < localize_done_us_) return false;
  localizing_ = false;
  out = runtime::LocalizationOutcome();
  out.stamp_us = capture_us_;
  for (int i = 0; i < 3; ++i) {
    const float* p = kSimObjects[i].tq;
    runtime::ObjectResult o;
    o.id = uint32_t(i + 1);
    o.T_world_object = Pose::from_tq(p[0], p[1], p[2], p[3], p[4], p[5], p[6]);
    o.score = kSimObjects[i].score;
    o.grasp_m = o.T_world_object.t;  // grasp from above: the object's origin, approached along -z of the world
    out.add(o);
  }
  return true;
}

bool ExactPosePipeline::calibrate_pair(const char*, const char*, runtime::PairCalibrationReport&, const char** why) {
  *why = "rigid-pair calibration needs sensor data: pipeline.source = fusion";
  return false;
}

}  // namespace edgefuse_test
