#include "rig_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "edgefuse/fusion/pose_mean.hpp"
#include "edgefuse/tracking/pyramid.hpp"

namespace edgefuse::cli {

std::string pose_line(const Pose& T) {
  const Eigen::Quaternionf q = T.quaternion();
  char buf[200];
  std::snprintf(buf, sizeof(buf), "%.9f %.9f %.9f %.9f %.9f %.9f %.9f", T.t.x(), T.t.y(), T.t.z(), q.x(), q.y(), q.z(),
                q.w());
  return buf;
}

bool parse_guess(const std::string& text, Pose& T, std::string& err) {
  float v[6];
  std::stringstream ss(text);
  std::string item;
  int n = 0;
  while (std::getline(ss, item, ',')) {
    char* end = nullptr;
    const float x = std::strtof(item.c_str(), &end);
    if (n >= 6 || item.empty() || end == item.c_str() || *end != 0 || !std::isfinite(x)) {
      err = "--guess: expected tx,ty,tz,rx,ry,rz (metres, degrees), got '" + text + "'";
      return false;
    }
    v[n++] = x;
  }
  if (n != 6) {
    err = "--guess: expected 6 comma-separated numbers (tx,ty,tz in m, rx,ry,rz in degrees), got '" + text + "'";
    return false;
  }
  const Vec3f r = Vec3f(v[3], v[4], v[5]) * (3.14159265f / 180.0f);
  T = Pose();
  if (r.norm() > 0.0f) T.R = Eigen::AngleAxisf(r.norm(), r.normalized()).toRotationMatrix();
  T.t = Vec3f(v[0], v[1], v[2]);
  return true;
}

namespace {

// A's first n frames into the space through a Mapper: tracked against the space from A's first
// recorded pose (every tracked frame pushed), or at A's recorded poses; pose_a: each frame's pose.
bool fill_space_from_a(RigCamera& a, const PairCalibrationSetup& setup, std::size_t n, std::vector<Pose>& pose_a,
                       PairCalibrationRun& run, std::string& err) {
  if (!a.seq.frames[0].has_pose) {
    err = a.seq.root + ": the first frame needs a pose to start " + (setup.track_a ? "tracking" : "mapping") + " from";
    return false;
  }
  MapperParams mp;
  mp.poses = setup.track_a ? PoseMode::kTracked : PoseMode::kKnown;
  // Every tracked frame is pushed: the model B is registered to should be as complete and as
  // smooth as A's data allows (the 1 cm / 1 degree push policy keeps only ~6 of bin_rig_a's 20).
  mp.tracker.push.every_frame = true;
  Mapper mapper;
  if (mapper.init(*setup.volume, KernelRunners(), setup.filter_scratch, setup.centre, mp) != Status::kOk) {
    err = "bad tracker parameters";
    return false;
  }
  mapper.new_map_in_place();
  const Pose& start = a.seq.frames[0].T_world_cam;
  for (std::size_t i = 0; i < n; ++i) {
    const io::FrameRef& fr = a.seq.frames[i];
    if (!setup.track_a && !fr.has_pose) {
      err = a.seq.root + ": frame " + std::to_string(i) + " has no pose";
      return false;
    }
    SensorFrame frame;
    if (!a.load(i, false, frame, err)) return false;
    ReferenceStep step;
    if (mapper.map_reference(a.cam, frame, &fr.T_world_cam, start, step) != Status::kOk) {
      err = fr.depth_path + (setup.track_a ? ": tracking failed" : ": integration failed");
      return false;
    }
    pose_a[i] = step.T_world_cam;
    if (!setup.track_a) continue;
    run.a_tracked_ok += step.track.state == TrackState::kOk;
    if (fr.has_pose)
      run.a_pose_error_mm = std::max(run.a_pose_error_mm, 1e3f * (step.T_world_cam.t - fr.T_world_cam.t).norm());
  }
  return true;
}

void print_frame_result(int j, const PairCalibrationResult& r) {
  const Eigen::Quaternionf q = r.T_a_b.quaternion();
  std::printf("frame %d: %s  t %.2f %.2f %.2f mm  q %.5f %.5f %.5f %.5f  rms %.2f mm  inliers %.2f  %d dof "
              "(weakest %.1e)%s%s\n",
              j, r.accepted ? "accepted" : "refused ", 1e3f * r.T_a_b.t.x(), 1e3f * r.T_a_b.t.y(),
              1e3f * r.T_a_b.t.z(), q.x(), q.y(), q.z(), q.w(), 1e3f * r.rms_m, r.inlier_ratio, r.observable,
              r.weakest_ratio, r.accepted ? "" : ": ", r.reason);
}

// B's frames at A's instants registered to the space raycast at A's poses times the guess
// (calibrate_pair); each result into run.frames, the accepted ones averaged into run.
bool register_b_frames(const RigCamera& a, RigCamera& b, const PairCalibrationSetup& setup,
                       const std::vector<Pose>& pose_a, PairCalibrationRun& run, std::string& err) {
  PoseMean accepted;
  for (std::size_t i = 0; i < pose_a.size(); ++i) {
    const int j = frame_near(b.seq, a.seq.frames[i].stamp_s);
    if (j < 0) continue;
    SensorFrame frame;
    if (!b.load(std::size_t(j), false, frame, err)) return false;
    const ImageView<const uint16_t> depth(b.cam.filtered.data, b.seq.intr.width, b.seq.intr.height);
    if (b.cam.filter(frame, setup.filter_scratch) != Status::kOk ||
        build_pyramid<real_t>(depth, PyramidParams(), b.cam.pyramid) != Status::kOk) {
      err = b.seq.frames[std::size_t(j)].depth_path + ": filters or pyramid failed";
      return false;
    }
    PairCalibrationResult r;
    if (calibrate_pair<real_t>(*setup.volume, pose_a[i], setup.guess, b.seq.intr, b.cam.pyramid, b.cam.maps, b.cam.icp_ws,
                               setup.params, r) != Status::kOk) {
      err = "calibration failed on frame " + std::to_string(j);
      return false;
    }
    run.frames.push_back(r);
    run.frame_index.push_back(j);
    if (setup.verbose) print_frame_result(j, r);
    if (!r.accepted) {
      if (run.first_reason.empty()) run.first_reason = r.reason;
      continue;
    }
    accepted.add(r.T_a_b, r.sigma);
  }
  run.accepted = accepted.count();
  if (run.accepted == 0) return true;
  run.T_a_b = accepted.mean();
  run.sigma = accepted.mean_sigma();
  run.spread = accepted.spread();
  return true;
}

}  // namespace

bool run_pair_calibration(RigCamera& a, RigCamera& b, const PairCalibrationSetup& setup, PairCalibrationRun& run,
                          std::string& err) {
  run = PairCalibrationRun{};
  // Masks and jump edges, but no bilateral smoothing: it moves depth edges, and edges are what pin
  // the lateral directions (measured on bin_rig_a: 1.1 mm bias with it, 0.6 mm without).
  // (The slots' own settings are restored on return: fusion keeps the bilateral filter.)
  struct Restore {
    RigCamera& a;
    RigCamera& b;
    bool ba, bb;
    ~Restore() {
      a.cam.filters.bilateral_enabled = ba;
      b.cam.filters.bilateral_enabled = bb;
    }
  } restore{a, b, a.cam.filters.bilateral_enabled, b.cam.filters.bilateral_enabled};
  a.cam.filters.bilateral_enabled = false;
  b.cam.filters.bilateral_enabled = false;
  const std::size_t n = std::min<std::size_t>(std::size_t(setup.frames), a.seq.frames.size());
  std::vector<Pose> pose_a(n);
  return fill_space_from_a(a, setup, n, pose_a, run, err) && register_b_frames(a, b, setup, pose_a, run, err);
}

}  // namespace edgefuse::cli
