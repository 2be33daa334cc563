// `calib fuse <from> <to>` in edgefused: the rigid-pair calibration of the paper (Fig. 6,
// src/fusion calibrate_pair, as `edgefuse calibrate` runs it offline) on the live map. The map is
// filled at the reference camera's poses, so `from` must be the reference; `to`'s newest frame,
// taken within the pairing window of the reference's last frame (the rig still, or both
// streaming), is registered to the map raycast at the guessed mounting from the reference's pose
// at that frame's stamp (reference_pose_at). One frame's estimate scatters by 2-3 mm per axis /
// 0.2 deg (the ToF's noise; `edgefuse calibrate --frames 10` on bin_rig_a: spread 1.8 / 1.6 /
// 0.3 mm; on the live sim rig 1.5-4.5 mm, single frames up to 7 mm off), so the command averages
// kCalibFrames estimates from consecutive reference frames; the frames that arrive meanwhile are
// mapped as usual (step()). It runs on the main loop without the heap and stops early when the
// reference camera stops delivering.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "edgefuse/board_config.hpp"
#include "edgefuse/fusion/calibrate_pair.hpp"
#include "edgefuse/fusion/pose_mean.hpp"
#include "edgefuse/hal/platform/clock/monotonic_clock.hpp"
#include "device_pipeline.hpp"

namespace edgefuse::firmware {

namespace {
// Filters' intermediate image for the calibration frame (static: no heap).
uint16_t g_calib_scratch[kBuildBoard.image_width_max * kBuildBoard.image_height_max];
// Estimates averaged per command (the scatter of the mean falls as 1/sqrt of it: 10 frames, a
// third of a second at 30 fps, keep the mean within ~1 mm per axis; 5 left it 5-6 mm off in about
// one command of twenty on the sim rig), and the longest wait for the reference camera's next frame
// before averaging what there is.
constexpr int kCalibFrames = 10;
constexpr uint64_t kCalibFrameWaitUs = 1000000;
}  // namespace

bool DevicePipeline::calibrate_pair(const char* from, const char* to, runtime::PairCalibrationReport& out,
                                    const char** why) {
  static char reason[256];
  *why = reason;
  int a = -1, b = -1;
  for (int i = 0; i < camera_count_; ++i) {
    if (cams_[i].name == from) a = i;
    if (cams_[i].name == to) b = i;
  }
  const char* scanner = devices_.scanner() != nullptr ? devices_.scanner()->name() : "";
  for (const char* n : {from, to}) {
    if ((n == from ? a : b) >= 0) continue;
    if (std::strcmp(n, scanner) == 0)
      std::snprintf(reason, sizeof(reason), "'%.40s' is a line scanner: only depth cameras are calibrated as a pair", n);
    else
      std::snprintf(reason, sizeof(reason), "no camera '%.40s' on this rig (status lists them)", n);
    return false;
  }
  const CameraStream& ref = cams_[order_[0]];
  if (a == b) {
    std::snprintf(reason, sizeof(reason), "from and to name the same sensor");
    return false;
  }
  if (a != order_[0]) {
    std::snprintf(reason, sizeof(reason), "the map is built at %.40s's poses: <from> must be %.40s", ref.name.c_str(),
                  ref.name.c_str());
    return false;
  }
  if (localization_.busy()) {
    std::snprintf(reason, sizeof(reason), "a localisation is running");
    return false;
  }
  if (mapper_.map_frames() == 0 || !mapper_.reference().has_pose()) {
    std::snprintf(reason, sizeof(reason), "the map is empty (scan start and let %.40s see the scene)", from);
    return false;
  }
  CameraStream& B = cams_[b];
  const Pose guess = B.has_mount ? B.T_ref_cam : Pose::identity();
  out.guess_source = B.has_mount ? B.mount_source : "identity";
  PairCalibrationParams params;
  PairCalibrationResult r, last;
  PoseMean mean;
  hal::Clock& clock = hal::monotonic_clock();
  uint64_t used_stamp_us = 0, last_used_us = 0, waiting_since_us = clock.now_us();
  reason[0] = '\0';
  for (int attempts = 0; mean.count() < kCalibFrames && attempts < 2 * kCalibFrames;) {
    if (mapper_.reference().stamp_us() != used_stamp_us) {
      if (camera_running_) B.take_nearest(mapper_.reference().stamp_us());
      if (B.held == nullptr) {
        if (mean.count() == 0 && attempts == 0)
          std::snprintf(reason, sizeof(reason), "no frame from %.40s yet (status shows its state)", to);
      } else {
        const uint64_t s = B.held->stamp_us;
        const uint64_t dt_us = s > mapper_.reference().stamp_us() ? s - mapper_.reference().stamp_us() : mapper_.reference().stamp_us() - s;
        if (dt_us <= kPairWindowUs) {
          used_stamp_us = mapper_.reference().stamp_us();
          ++attempts;
          const hal::DepthFrame& frame = *B.held;
          if (B.slot.filter(B.held_frame(), ImageView<uint16_t>(g_calib_scratch, frame.width, frame.height)) !=
                  Status::kOk ||
              build_pyramid<real_t>(ImageView<const uint16_t>(B.slot.filtered.data, frame.width, frame.height),
                                    PyramidParams(), B.slot.pyramid) != Status::kOk) {
            std::snprintf(reason, sizeof(reason), "%.40s's frame could not be filtered", to);
            continue;
          }
          const Status st = ::edgefuse::calibrate_pair<real_t>(volume_, reference_pose_at(s), guess, B.slot.intr,
                                                               B.slot.pyramid, B.slot.maps, B.slot.icp_ws, params, r);
          if (st != Status::kOk) {
            std::snprintf(reason, sizeof(reason), "calibration failed: %s", to_string(st));
          } else if (!r.accepted) {
            std::snprintf(reason, sizeof(reason), "refused: %.200s", r.reason);
          } else {
            mean.add(r.T_a_b, r.sigma);
            last = r;
          }
          continue;
        } else if (mean.count() == 0 && attempts == 0) {
          std::snprintf(reason, sizeof(reason),
                        "%.40s's newest frame is %.0f ms from %.40s's last frame (both must stream; window %.0f ms)",
                        to, double(dt_us) * 1e-3, from, double(kPairWindowUs) * 1e-3);
        }
      }
    }
    // The next reference frame (mapped as usual); stop when none comes.
    const uint64_t now_us = clock.now_us();
    if (used_stamp_us == mapper_.reference().stamp_us() && last_used_us != used_stamp_us) {
      last_used_us = used_stamp_us;
      waiting_since_us = now_us;  // counted from the end of the last estimate (slow under qemu)
    }
    if (!mapping_ || !camera_running_ || ref.counters.device_state() != hal::DeviceState::kStreaming ||
        now_us - waiting_since_us > kCalibFrameWaitUs)
      break;  // no next frame coming (a recording at its end, a stalled camera): average what there is
    clock.sleep_us(2000);
    step(clock.now_us());
  }
  if (mean.count() == 0) {
    if (reason[0] == '\0') std::snprintf(reason, sizeof(reason), "no frame of %.40s paired with %.40s", to, from);
    return false;
  }
  r = last;
  r.T_a_b = mean.mean();
  const Vec6f spread = mean.spread(), own = mean.mean_sigma();
  const float root_n = std::sqrt(float(mean.count()));
  out.frames = mean.count();
  const Eigen::Quaternionf q = r.T_a_b.quaternion();
  const float tq[7] = {r.T_a_b.t.x(), r.T_a_b.t.y(), r.T_a_b.t.z(), q.x(), q.y(), q.z(), q.w()};
  std::memcpy(out.T_from_to.tq, tq, sizeof(tq));
  const float deg = 57.29578f;
  // The mean's 1-sigma: the scatter over frames (or each fit's covariance when that is larger,
  // e.g. with one frame) over sqrt(frames).
  for (int k = 0; k < 3; ++k) {
    out.sigma_rot_deg[k] = deg * std::max(spread(k), own(k)) / root_n;
    out.sigma_trans_mm[k] = 1e3f * std::max(spread(3 + k), own(3 + k)) / root_n;
    out.spread_rot_deg[k] = deg * spread(k);
    out.spread_trans_mm[k] = 1e3f * spread(3 + k);
  }
  out.rms_mm = 1e3f * r.rms_m;
  out.inlier_ratio = r.inlier_ratio;
  out.correspondences = r.correspondences;
  const Pose D = guess.inverse() * r.T_a_b;
  out.moved_mm = 1e3f * (r.T_a_b.t - guess.t).norm();
  out.moved_deg = deg * D.angle_rad();
  std::printf("calib fuse: T_%s_%s = %.4f %.4f %.4f %.5f %.5f %.5f %.5f (rms %.2f mm, %d correspondences, "
              "%.2f mm / %.3f deg from the guess: %s; mean of %d frames)\n",
              from, to, double(tq[0]), double(tq[1]), double(tq[2]), double(tq[3]), double(tq[4]), double(tq[5]),
              double(tq[6]), double(out.rms_mm), r.correspondences, double(out.moved_mm), double(out.moved_deg),
              out.guess_source, out.frames);
  std::fflush(stdout);
  return true;
}

}  // namespace edgefuse::firmware
