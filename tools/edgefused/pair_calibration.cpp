// `calib fuse <from> <to>` in edgefused: the rigid-pair calibration of the paper (Fig. 6,
// src/fusion calibrate_pair, as `edgefuse calibrate` runs it offline) on the live map. The map is
// filled at the reference camera's poses, so `from` must be the reference; `to`'s newest frame,
// taken within the pairing window of the reference's last frame (the rig still, or both
// streaming), is registered to the map raycast at the guessed mounting. It runs on the main loop
// (no frame is integrated meanwhile) in a fraction of a second, without the heap.
#include <cmath>
#include <cstdio>
#include <cstring>

#include "edgefuse/board_config.hpp"
#include "edgefuse/fusion/calibrate_pair.hpp"
#include "fusion_pipeline.hpp"

namespace edgefuse::wire {

namespace {
// Filters' intermediate image for the calibration frame (static: no heap).
uint16_t g_calib_scratch[kBuildBoard.image_width_max * kBuildBoard.image_height_max];
}  // namespace

bool FusionPipeline::calibrate_pair(const char* from, const char* to, runtime::PairCalibrationReport& out,
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
  if (localizing_) {
    std::snprintf(reason, sizeof(reason), "a localisation is running");
    return false;
  }
  if (map_frames_ == 0 || !have_ref_pose_) {
    std::snprintf(reason, sizeof(reason), "the map is empty (scan start and let %.40s see the scene)", from);
    return false;
  }
  CameraStream& B = cams_[b];
  if (camera_running_) B.take_nearest(ref_stamp_us_);
  if (B.held == nullptr) {
    std::snprintf(reason, sizeof(reason), "no frame from %.40s yet (status shows its state)", to);
    return false;
  }
  const uint64_t s = B.held->stamp_us;
  const uint64_t dt_us = s > ref_stamp_us_ ? s - ref_stamp_us_ : ref_stamp_us_ - s;
  if (dt_us > kPairWindowUs) {
    std::snprintf(reason, sizeof(reason),
                  "%.40s's newest frame is %.0f ms from %.40s's last frame (both must stream; window %.0f ms)", to,
                  double(dt_us) * 1e-3, from, double(kPairWindowUs) * 1e-3);
    return false;
  }
  const hal::DepthFrame& frame = *B.held;
  if (!B.filter_held(ImageView<uint16_t>(g_calib_scratch, frame.width, frame.height)) ||
      build_pyramid<real_t>(ImageView<const uint16_t>(B.filtered.data, frame.width, frame.height), PyramidParams(),
                            B.pyramid) != Status::kOk) {
    std::snprintf(reason, sizeof(reason), "%.40s's frame could not be filtered", to);
    return false;
  }
  const Pose guess = B.has_mount ? B.T_ref_cam : Pose::identity();
  out.guess_source = B.has_mount ? B.mount_source : "identity";
  PairCalibrationParams params;
  PairCalibrationResult r;
  const Status st = ::edgefuse::calibrate_pair<real_t>(core_.volume, ref_pose_, guess, B.intr, B.pyramid, B.maps,
                                                       B.scratch, B.icp_ws, params, r);
  if (st != Status::kOk) {
    std::snprintf(reason, sizeof(reason), "calibration failed: %s", to_string(st));
    return false;
  }
  if (!r.accepted) {
    std::snprintf(reason, sizeof(reason), "refused: %.200s", r.reason);
    return false;
  }
  const Eigen::Quaternionf q = r.T_a_b.quaternion();
  const float tq[7] = {r.T_a_b.t.x(), r.T_a_b.t.y(), r.T_a_b.t.z(), q.x(), q.y(), q.z(), q.w()};
  std::memcpy(out.T_from_to.tq, tq, sizeof(tq));
  const float deg = 57.29578f;
  for (int k = 0; k < 3; ++k) {
    out.sigma_rot_deg[k] = deg * r.sigma(k);
    out.sigma_trans_mm[k] = 1e3f * r.sigma(3 + k);
  }
  out.rms_mm = 1e3f * r.rms_m;
  out.inlier_ratio = r.inlier_ratio;
  out.correspondences = r.correspondences;
  const Pose D = guess.inverse() * r.T_a_b;
  out.moved_mm = 1e3f * (r.T_a_b.t - guess.t).norm();
  out.moved_deg = deg * D.angle_rad();
  std::printf("calib fuse: T_%s_%s = %.4f %.4f %.4f %.5f %.5f %.5f %.5f (rms %.2f mm, %d correspondences, "
              "%.2f mm / %.3f deg from the guess: %s)\n",
              from, to, double(tq[0]), double(tq[1]), double(tq[2]), double(tq[3]), double(tq[4]), double(tq[5]),
              double(tq[6]), double(out.rms_mm), r.correspondences, double(out.moved_mm), double(out.moved_deg),
              out.guess_source);
  std::fflush(stdout);
  return true;
}

}  // namespace edgefuse::wire
