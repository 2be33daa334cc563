// Replays a recorded depth sequence (TUM folder, per-frame folder or a rig set's sensor; see
// io::open_depth_sequence and ../shared/docs/FORMATS.md) as a DepthCamera: at the recorded rate
// on the HAL clock or as fast as possible. Stamps keep the recording's spacing (start time + the
// frame's offset in the recording), so paired replays of a rig's sensors pair as they were
// recorded. The recording's ground-truth poses are offered as simulator truth (TruthSource).
// Host-side: decoding the PNGs allocates inside libpng (the decode buffers are kept).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "edgefuse/hal/clock.hpp"
#include "edgefuse/hal/depth_camera.hpp"
#include "edgefuse/hal/replay/replay_epoch.hpp"
#include "edgefuse/hal/truth_source.hpp"
#include "edgefuse/io/dataset.hpp"

namespace edgefuse::hal {

enum class ReplayRate : uint8_t { kRecorded, kFastest };

class ReplayDepthCamera final : public DepthCamera, public TruthSource {
 public:
  //! \param seq the opened sequence (kept by reference)  \param rate pacing  \param clock time base
  //! \param loop start again after the last frame (else kEndOfStream)
  //! \param speed kRecorded: playback speed (0.5: slow motion at half the recorded rate, stamps
  //! spaced accordingly)
  ReplayDepthCamera(const io::DepthSequence& seq, ReplayRate rate, Clock& clock, bool loop = false,
                    double speed = 1.0);

  //! Plays on a time base shared with the recording's other replayed devices (before start()).
  //! \param epoch the shared time base (outlives this camera)
  void share_epoch(ReplayEpoch& epoch);

  const char* name() const override { return seq_.sensor_name.c_str(); }
  int mode_count() const override { return 1; }
  bool mode(int index, DepthMode& mode) const override;
  HalStatus start(int mode_index) override;
  void stop() override;
  PinholeIntrinsics intrinsics() const override { return seq_.intr; }
  HalStatus next_frame(DepthFrame& frame, uint32_t timeout_ms) override;

  //! Why the last next_frame failed with kBadFrame (names the file).
  const std::string& last_error() const { return error_; }
  //! Ground-truth pose of the frame delivered last. \return false before a frame or without truth
  //! \param T_world_cam receives the recording's camera-to-world pose
  bool last_pose(Pose& T_world_cam) const {
    if (!delivered_ || !seq_.frames[last_index()].has_pose) return false;
    T_world_cam = seq_.frames[last_index()].T_world_cam;
    return true;
  }
  //! Ground-truth pose of the frame with device sequence number `sequence` (frame.sequence counts
  //! the recording's frames, loops included, so a frame the caller holds still finds its truth when
  //! a device thread has delivered newer ones). \return false without truth
  //! \param sequence the frame's sequence number  \param T_world_cam receives the camera-to-world pose
  bool pose_of(uint32_t sequence, Pose& T_world_cam) const override {
    if (seq_.frames.empty()) return false;
    const io::FrameRef& f = seq_.frames[sequence % seq_.frames.size()];
    if (!f.has_pose) return false;
    T_world_cam = f.T_world_cam;
    return true;
  }
  //! The robot's flange pose at frame `sequence`: a rig set's rig frame is its reference
  //! sensor's, so the frame's ground truth (pose_of). \return false without truth
  bool flange_pose_of(uint32_t sequence, Pose& T_world_flange) const override {
    return pose_of(sequence, T_world_flange);
  }
  //! A recording knows no mounting (a rig set's extrinsics.txt is read from the set). \return false
  bool mounting(Pose&) const override { return false; }
  //! True when at least one frame of the recording has a ground-truth pose.
  bool has_truth() const {
    for (const io::FrameRef& f : seq_.frames)
      if (f.has_pose) return true;
    return false;
  }
  //! Index in the sequence of the frame delivered last.
  std::size_t last_index() const { return index_ == 0 ? 0 : index_ - 1; }

 private:
  void seek(uint64_t now_us);

  const io::DepthSequence& seq_;
  ReplayRate rate_;
  Clock& clock_;
  bool loop_;
  double speed_;
  bool running_ = false;
  bool delivered_ = false;  // a frame was delivered (last_index() names it)
  std::size_t index_ = 0;
  uint32_t sequence_ = 0;
  ReplayEpoch* epoch_ = nullptr;
  uint64_t start_us_ = 0;        // the time base's start (the clock's time at recording time first_s_)
  double first_s_ = 0;           // recording time played at start_us_
  double period_s_ = 0;          // the recording's frame period
  double loop_s_ = 0;            // recording time from one loop's start to the next's
  uint64_t loop_offset_us_ = 0;
  std::vector<uint16_t> depth_, amplitude_;
  std::vector<Rgb8> colour_;
  std::string error_;
};

}  // namespace edgefuse::hal
