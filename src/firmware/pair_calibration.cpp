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
char g_reason[256];  // the refusal handed back through `why` (static text)

// The command's result: the mean of the estimates, their 1-sigma, what the last fit said.
void fill_report(const PoseMean& mean, const PairCalibrationResult& last, const Pose& guess,
                 runtime::PairCalibrationReport& out) {
  const Pose T_a_b = mean.mean();
  const Vec6f spread = mean.spread(), own = mean.mean_sigma();
  const float root_n = std::sqrt(float(mean.count()));
  out.frames = mean.count();
  const Eigen::Quaternionf q = T_a_b.quaternion();
  const float tq[7] = {T_a_b.t.x(), T_a_b.t.y(), T_a_b.t.z(), q.x(), q.y(), q.z(), q.w()};
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
  out.rms_mm = 1e3f * last.rms_m;
  out.inlier_ratio = last.inlier_ratio;
  out.correspondences = last.correspondences;
  const Pose D = guess.inverse() * T_a_b;
  out.moved_mm = 1e3f * (T_a_b.t - guess.t).norm();
  out.moved_deg = deg * D.angle_rad();
}

void print_report(const char* from, const char* to, const runtime::PairCalibrationReport& out) {
  const float* tq = out.T_from_to.tq;
  std::printf("calib fuse: T_%s_%s = %.4f %.4f %.4f %.5f %.5f %.5f %.5f (rms %.2f mm, %d correspondences, "
              "%.2f mm / %.3f deg from the guess: %s; mean of %d frames)\n",
              from, to, double(tq[0]), double(tq[1]), double(tq[2]), double(tq[3]), double(tq[4]), double(tq[5]),
              double(tq[6]), double(out.rms_mm), out.correspondences, double(out.moved_mm), double(out.moved_deg),
              out.guess_source, out.frames);
  std::fflush(stdout);
}
}  // namespace

//! One `calib fuse` command while it collects estimates.
struct PairRun {
  const char* from = "";
  const char* to = "";
  int b = -1;                    //!< `to`'s camera
  Pose guess;                    //!< the mounting each fit starts from
  PairCalibrationParams params;
  PoseMean mean;                 //!< the accepted estimates
  PairCalibrationResult last;    //!< the last accepted fit
  int attempts = 0;              //!< reference frames tried
  uint64_t used_stamp_us = 0;    //!< the reference frame last tried
};

bool DevicePipeline::calibrate_pair(const char* from, const char* to, runtime::PairCalibrationReport& out,
                                    const char** why) {
  *why = g_reason;
  g_reason[0] = '\0';
  PairRun run;
  run.from = from;
  run.to = to;
  if (!check_pair(run)) return false;
  const CameraStream& B = cams_[run.b];
  run.guess = B.has_mount ? B.T_ref_cam : Pose::identity();
  out.guess_source = B.has_mount ? B.mount_source : "identity";
  g_reason[0] = '\0';
  collect_pair_estimates(run);
  if (run.mean.count() == 0) {
    if (g_reason[0] == '\0') std::snprintf(g_reason, sizeof(g_reason), "no frame of %.40s paired with %.40s", to, from);
    return false;
  }
  fill_report(run.mean, run.last, run.guess, out);
  print_report(from, to, out);
  return true;
}

// `from` must be the reference camera (the map is built at its poses), `to` another camera, and
// the map must hold something to register to.
bool DevicePipeline::check_pair(PairRun& run) {
  int a = -1;
  for (int i = 0; i < camera_count_; ++i) {
    if (cams_[i].name == run.from) a = i;
    if (cams_[i].name == run.to) run.b = i;
  }
  const char* scanner = devices_.scanner() != nullptr ? devices_.scanner()->name() : "";
  for (const char* n : {run.from, run.to}) {
    if ((n == run.from ? a : run.b) >= 0) continue;
    if (std::strcmp(n, scanner) == 0)
      std::snprintf(g_reason, sizeof(g_reason), "'%.40s' is a line scanner: only depth cameras are calibrated as a pair", n);
    else
      std::snprintf(g_reason, sizeof(g_reason), "no camera '%.40s' on this rig (status lists them)", n);
    return false;
  }
  const CameraStream& ref = cams_[order_[0]];
  if (a == run.b) {
    std::snprintf(g_reason, sizeof(g_reason), "from and to name the same sensor");
  } else if (a != order_[0]) {
    std::snprintf(g_reason, sizeof(g_reason), "the map is built at %.40s's poses: <from> must be %.40s",
                  ref.name.c_str(), ref.name.c_str());
  } else if (localization_.busy()) {
    std::snprintf(g_reason, sizeof(g_reason), "a localisation is running");
  } else if (mapper_.map_frames() == 0 || !mapper_.reference().has_pose()) {
    std::snprintf(g_reason, sizeof(g_reason), "the map is empty (scan start and let %.40s see the scene)", run.from);
  } else {
    return true;
  }
  return false;
}

// Estimates from consecutive reference frames until kCalibFrames are accepted, 2 x kCalibFrames
// were tried, or no next reference frame comes; the frames that arrive meanwhile are mapped as usual.
void DevicePipeline::collect_pair_estimates(PairRun& run) {
  const CameraStream& ref = cams_[order_[0]];
  hal::Clock& clock = hal::monotonic_clock();
  uint64_t last_used_us = 0, waiting_since_us = clock.now_us();
  while (run.mean.count() < kCalibFrames && run.attempts < 2 * kCalibFrames) {
    if (mapper_.reference().stamp_us() != run.used_stamp_us && try_pair_estimate(run)) continue;
    // The next reference frame (mapped as usual); stop when none comes.
    const uint64_t now_us = clock.now_us();
    if (run.used_stamp_us == mapper_.reference().stamp_us() && last_used_us != run.used_stamp_us) {
      last_used_us = run.used_stamp_us;
      waiting_since_us = now_us;  // counted from the end of the last estimate (slow under qemu)
    }
    if (!mapping_ || !camera_running_ || ref.counters.device_state() != hal::DeviceState::kStreaming ||
        now_us - waiting_since_us > kCalibFrameWaitUs)
      break;  // no next frame coming (a recording at its end, a stalled camera): average what there is
    clock.sleep_us(2000);
    step(clock.now_us());
  }
}

// `to`'s frame nearest the reference's last frame, when within the pairing window: one fit of it
// (an accepted estimate, or the reason it was not). False when no frame could be tried.
bool DevicePipeline::try_pair_estimate(PairRun& run) {
  CameraStream& B = cams_[run.b];
  const uint64_t ref_us = mapper_.reference().stamp_us();
  const bool first = run.mean.count() == 0 && run.attempts == 0;  // only the first wait says why
  if (camera_running_) B.take_nearest(ref_us);
  if (B.held == nullptr) {
    if (first) std::snprintf(g_reason, sizeof(g_reason), "no frame from %.40s yet (status shows its state)", run.to);
    return false;
  }
  const uint64_t s = B.held->stamp_us;
  const uint64_t dt_us = s > ref_us ? s - ref_us : ref_us - s;
  if (dt_us > kPairWindowUs) {
    if (first)
      std::snprintf(g_reason, sizeof(g_reason),
                    "%.40s's newest frame is %.0f ms from %.40s's last frame (both must stream; window %.0f ms)",
                    run.to, double(dt_us) * 1e-3, run.from, double(kPairWindowUs) * 1e-3);
    return false;
  }
  run.used_stamp_us = ref_us;
  ++run.attempts;
  const hal::DepthFrame& frame = *B.held;
  if (B.slot.filter(B.held_frame(), ImageView<uint16_t>(g_calib_scratch, frame.width, frame.height)) != Status::kOk ||
      build_pyramid<real_t>(ImageView<const uint16_t>(B.slot.filtered.data, frame.width, frame.height),
                            PyramidParams(), B.slot.pyramid) != Status::kOk) {
    std::snprintf(g_reason, sizeof(g_reason), "%.40s's frame could not be filtered", run.to);
    return true;
  }
  PairCalibrationResult r;
  const Status st = ::edgefuse::calibrate_pair<real_t>(volume_, reference_pose_at(s), run.guess, B.slot.intr,
                                                       B.slot.pyramid, B.slot.maps, B.slot.icp_ws, run.params, r);
  if (st != Status::kOk) {
    std::snprintf(g_reason, sizeof(g_reason), "calibration failed: %s", to_string(st));
  } else if (!r.accepted) {
    std::snprintf(g_reason, sizeof(g_reason), "refused: %.200s", r.reason);
  } else {
    run.mean.add(r.T_a_b, r.sigma);
    run.last = r;
  }
  return true;
}

}  // namespace edgefuse::firmware
