#include "edgefuse/hal/replay/replay_depth_camera.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace edgefuse::hal {

ReplayDepthCamera::ReplayDepthCamera(const io::DepthSequence& seq, ReplayRate rate, Clock& clock, bool loop,
                                     double speed)
    : seq_(seq), rate_(rate), clock_(clock), loop_(loop), speed_(speed > 0 ? speed : 1.0) {}

bool ReplayDepthCamera::mode(int index, DepthMode& m) const {
  if (index != 0) return false;
  m.width = seq_.intr.width;
  m.height = seq_.intr.height;
  m.fps = 0;
  if (seq_.frames.size() > 1) {
    const double span = seq_.frames.back().stamp_s - seq_.frames.front().stamp_s;
    if (span > 0) m.fps = int(std::lround(double(seq_.frames.size() - 1) / span));
  }
  m.depth_scale = seq_.intr.depth_scale;
  m.colour = seq_.colour_registered && !seq_.frames.empty() && !seq_.frames[0].colour_path.empty();
  m.amplitude = !seq_.frames.empty() && !seq_.frames[0].amplitude_path.empty();
  return true;
}

void ReplayDepthCamera::share_epoch(ReplayEpoch& epoch) {
  epoch_ = &epoch;
  if (!seq_.frames.empty()) epoch.include(seq_.frames.front().stamp_s, seq_.frames.back().stamp_s);
}

HalStatus ReplayDepthCamera::start(int mode_index) {
  if (mode_index != 0) return HalStatus::kInvalidArgument;
  if (seq_.frames.empty()) return HalStatus::kNoDevice;
  const std::size_t n = std::size_t(seq_.intr.width) * std::size_t(seq_.intr.height);
  depth_.reserve(n);  // decode buffers: allocated here, reused by every frame
  amplitude_.reserve(n);
  colour_.reserve(n);
  const uint64_t now = clock_.now_us();
  // One nominal frame period after the last frame, the recording starts again.
  const double first = epoch_ ? epoch_->first_stamp_s() : seq_.frames.front().stamp_s;
  const double last = epoch_ ? epoch_->last_stamp_s() : seq_.frames.back().stamp_s;
  const double own_span = seq_.frames.back().stamp_s - seq_.frames.front().stamp_s;
  const double period = seq_.frames.size() > 1 ? own_span / double(seq_.frames.size() - 1) : 0.033;
  first_s_ = first;
  period_s_ = period;
  loop_s_ = (last - first) + period;
  start_us_ = epoch_ ? epoch_->join(now) : now;
  running_ = true;
  seek(now);
  return HalStatus::kOk;
}

void ReplayDepthCamera::stop() {
  if (running_ && epoch_) epoch_->leave();
  running_ = false;
}

// Starts at the recording's present point: its first frame when the time base starts now, else
// (joining other devices' running replay) the frame due now, loops counted.
void ReplayDepthCamera::seek(uint64_t now_us) {
  index_ = 0;
  loop_offset_us_ = 0;
  sequence_ = 0;
  if (now_us <= start_us_) return;
  double played_s = double(now_us - start_us_) * 1e-6 * speed_;
  uint64_t loops = 0;
  if (loop_ && loop_s_ > 0) {
    loops = uint64_t(played_s / loop_s_);
    played_s -= double(loops) * loop_s_;
  }
  // A frame less than a period overdue is the one a live camera would be delivering now.
  const double t = first_s_ + played_s - period_s_;
  while (index_ < seq_.frames.size() && seq_.frames[index_].stamp_s < t) ++index_;
  loop_offset_us_ = uint64_t(std::llround(double(loops) * loop_s_ / speed_ * 1e6));
  sequence_ = uint32_t(loops * seq_.frames.size() + index_);
}

HalStatus ReplayDepthCamera::next_frame(DepthFrame& frame, uint32_t timeout_ms) {
  if (!running_) return HalStatus::kNotStarted;
  if (!frame.fits(seq_.intr.width, seq_.intr.height)) return HalStatus::kInvalidArgument;
  if (index_ >= seq_.frames.size()) {
    if (!loop_) return HalStatus::kEndOfStream;
    loop_offset_us_ += uint64_t(std::llround(loop_s_ / speed_ * 1e6));
    index_ = 0;
  }
  const io::FrameRef& ref = seq_.frames[index_];
  const double offset_s = ref.stamp_s - first_s_;
  const uint64_t stamp_us = start_us_ + loop_offset_us_ + uint64_t(std::llround(offset_s / speed_ * 1e6));
  if (rate_ == ReplayRate::kRecorded) {
    const uint64_t now = clock_.now_us();
    if (stamp_us > now) {
      const uint64_t wait_us = stamp_us - now;
      if (wait_us > uint64_t(timeout_ms) * 1000u) {
        clock_.sleep_us(uint64_t(timeout_ms) * 1000u);
        return HalStatus::kTimeout;
      }
      clock_.sleep_us(wait_us);
    }
  }
  ++index_;
  // Numbered by position in the recording: a frame that fails to load leaves a gap (counted by the
  // acquisition checks) and pose_of(sequence) stays exact.
  const uint32_t sequence = sequence_++;
  const std::size_t n = std::size_t(seq_.intr.width) * std::size_t(seq_.intr.height);
  if (!io::load_depth(ref, seq_.intr, depth_, error_)) return HalStatus::kBadFrame;
  std::memcpy(frame.depth, depth_.data(), n * sizeof(uint16_t));
  frame.has_colour = false;
  if (frame.colour && seq_.colour_registered && !ref.colour_path.empty()) {
    if (!io::load_colour(ref, seq_.intr, colour_, error_)) return HalStatus::kBadFrame;
    std::memcpy(static_cast<void*>(frame.colour), colour_.data(), n * sizeof(Rgb8));
    frame.has_colour = true;
  }
  frame.has_amplitude = false;
  if (frame.amplitude && !ref.amplitude_path.empty()) {
    if (!io::load_amplitude(ref, seq_.intr, amplitude_, error_)) return HalStatus::kBadFrame;
    std::memcpy(frame.amplitude, amplitude_.data(), n * sizeof(uint16_t));
    frame.has_amplitude = true;
  }
  frame.width = seq_.intr.width;
  frame.height = seq_.intr.height;
  frame.depth_scale = seq_.intr.depth_scale;
  frame.stamp_us = stamp_us;
  frame.sequence = sequence;
  delivered_ = true;
  return HalStatus::kOk;
}

}  // namespace edgefuse::hal
