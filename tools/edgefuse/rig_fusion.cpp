#include "rig_fusion.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "edgefuse/fusion/pose_mean.hpp"
#include "edgefuse/tracking/tracker.hpp"
#include "edgefuse/tsdf/integrate.hpp"
#include "edgefuse/tsdf/integrate_profile.hpp"
#include "edgefuse/tsdf/raycast.hpp"
#include "edgefuse/pipeline/kernels.hpp"

namespace edgefuse::cli {

bool PinholeSlot::bind(CoreBuffers& b, const BoardCapacities& board, int slot_index, std::string& err) {
  const PinholeIntrinsics& intr = seq.intr;
  if (slot_index >= board.sensors_max) {
    err = "board " + std::string(board.name) + " has buffers for " + std::to_string(board.sensors_max) + " sensors";
    return false;
  }
  if (intr.width > board.image_width_max || intr.height > board.image_height_max) {
    err = "sensor " + seq.sensor_name + ": a " + std::to_string(intr.width) + "x" + std::to_string(intr.height) +
          " image exceeds board " + board.name + "'s largest image";
    return false;
  }
  slot = slot_index;
  const std::size_t off = std::size_t(slot) * b.pixels_per_sensor;
  const int w = intr.width, h = intr.height;
  ray_norms = ImageView<real_t>(reinterpret_cast<real_t*>(b.ray_norms) + off, w, h);
  if (build_ray_norms<real_t>(intr, ray_norms) != Status::kOk) {
    err = seq.root + ": sensor " + seq.sensor_name + ": bad intrinsics";
    return false;
  }
  scratch = b.scratch(slot);
  maps = b.raycast_maps(slot, w, h, board.colour);
  depth = ImageView<uint16_t>(b.depth_frames + off, w, h);
  colour = ImageView<Rgb8>(b.colour_frames + off, w, h);
  tof = !seq.frames.empty() && !seq.frames[0].amplitude_path.empty();
  filters = DepthFilterChain<real_t>::defaults_for(intr, tof ? DepthSensorKind::kTimeOfFlight
                                                             : DepthSensorKind::kStructuredLight);
  if (filters.prepare(intr) != Status::kOk) {
    err = seq.root + ": sensor " + seq.sensor_name + ": the depth filters refuse its intrinsics";
    return false;
  }
  noise = tof ? NoiseModel::time_of_flight() : NoiseModel::structured_light();
  trust = ImageView<uint8_t>(b.trust_maps + off, w, h);
  return true;
}

bool PinholeSlot::stage(std::size_t i, bool filter, bool with_colour, float sigma_ref_m,
                        ImageView<uint16_t> filter_scratch, DepthFrame& frame, std::string& err) {
  const io::FrameRef& f = seq.frames[i];
  const PinholeIntrinsics& intr = seq.intr;
  if (!io::load_depth(f, intr, load_depth, err)) return false;
  std::copy(load_depth.begin(), load_depth.end(), depth.data);
  ImageView<const uint16_t> amp;
  if (tof && !f.amplitude_path.empty()) {
    if (!io::load_amplitude(f, intr, load_amplitude, err)) return false;
    amp = ImageView<const uint16_t>(load_amplitude.data(), intr.width, intr.height);
  }
  if (filter) {
    const ImageView<uint16_t> fs(filter_scratch.data, intr.width, intr.height);
    if (filters.run(depth, amp, fs, depth) != Status::kOk) {
      err = f.depth_path + ": depth filters failed";
      return false;
    }
  }
  frame = DepthFrame{};
  frame.depth = depth;
  frame.sub_unit_fill_units = sub_unit_fill_units;
  if (with_colour && !f.colour_path.empty()) {
    if (!io::load_colour(f, intr, load_colour, err)) return false;
    std::copy(load_colour.begin(), load_colour.end(), colour.data);
    frame.colour = colour;
  }
  if (sigma_ref_m > 0.0f) {
    // The frame's median noise (of the pixels the gate keeps): the jump rule and the set's rules.
    float sigma_m = 0.0f;
    if (build_trust_map(noise, sigma_ref_m, depth, intr.depth_scale, amp, trust, sigma_max_m, &sigma_m) !=
        Status::kOk) {
      err = f.depth_path + ": trust map failed";
      return false;
    }
    frame.trust = trust;
    for (int v = 0; v < intr.height; ++v)
      for (int u = 0; u < intr.width; ++u) {
        if (depth.at(u, v) == 0) continue;
        ++counts.staged_pixels;
        if (trust.at(u, v) != 0) continue;
        ++counts.gated_pixels;
        depth.at(u, v) = 0;  // a gated pixel carves no free space either
      }
    counts.sigma.add(sigma_m);
    if (jump_sigmas > 0.0f) {
      frame.jump_m = noise_jump_m(sigma_m, jump_sigmas);
      counts.jump_m_sum += frame.jump_m;
      ++counts.jump_frames;
    }
  }
  return true;
}

std::vector<float> median_sigmas(const std::vector<PinholeSlot>& cams) {
  std::vector<float> sigma;
  for (const PinholeSlot& c : cams) sigma.push_back(c.median_sigma());
  return sigma;
}

int frame_near(const io::DepthSequence& seq, double stamp_s) {
  int best = -1;
  double best_dt = 0.02;
  for (std::size_t i = 0; i < seq.frames.size(); ++i) {
    const double dt = std::fabs(seq.frames[i].stamp_s - stamp_s);
    if (dt <= best_dt) {
      best_dt = dt;
      best = int(i);
    }
  }
  return best;
}

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

// A's first n frames into the space: at A's ground truth, or (track_a) tracked against the space
// from A's first ground-truth pose; pose_a: the pose each frame was fused at.
bool fill_space_from_a(PinholeSlot& a, TsdfVolume& volume, ImageView<uint16_t> filter_scratch, std::size_t n,
                       const TrackingBuffers* track_a, std::vector<Pose>& pose_a, PairCalibrationRun& run,
                       std::string& err) {
  Tracker tracker;
  if (track_a != nullptr) {
    if (!a.seq.frames[0].has_pose) {
      err = a.seq.root + ": the first frame needs a pose to start tracking from";
      return false;
    }
    // Every tracked frame is pushed: the model B is registered to should be as complete and as
    // smooth as A's data allows (the 1 cm / 1 degree push policy keeps only ~6 of bin_rig_a's 20).
    TrackerParams tp;
    tp.push.every_frame = true;
    if (tracker.start(a.seq.frames[0].T_world_cam, tp) != Status::kOk) {
      err = "bad tracker parameters";
      return false;
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    DepthFrame f;
    if (!a.stage(i, true, false, 0.0f, filter_scratch, f, err)) return false;
    bool push = true;
    if (track_a != nullptr) {
      TrackResult r;
      Status s = i > 0 ? raycast<real_t>(volume, a.seq.intr, tracker.raycast_pose(), a.maps) : Status::kOk;
      if (s == Status::kOk) s = build_pyramid<real_t>(f.depth, PyramidParams(), *track_a->pyramid);
      if (s == Status::kOk) s = tracker.track<real_t>(*track_a->pyramid, a.maps, a.seq.intr, track_a->ws, r);
      if (s != Status::kOk) {
        err = a.seq.frames[i].depth_path + ": tracking failed";
        return false;
      }
      pose_a[i] = r.T_world_cam;
      push = r.push;
      run.a_tracked_ok += r.state == TrackState::kOk;
      if (a.seq.frames[i].has_pose)
        run.a_pose_error_mm = std::max(run.a_pose_error_mm, 1e3f * (r.T_world_cam.t - a.seq.frames[i].T_world_cam.t).norm());
    } else {
      if (!a.seq.frames[i].has_pose) {
        err = a.seq.root + ": frame " + std::to_string(i) + " has no pose";
        return false;
      }
      pose_a[i] = a.seq.frames[i].T_world_cam;
    }
    if (push && integrate<real_t>(volume, a.seq.intr, a.ray_norms, f, pose_a[i], a.scratch) != Status::kOk) {
      err = a.seq.frames[i].depth_path + ": integration failed";
      return false;
    }
  }
  return true;
}

// B's frames at A's instants registered to the space raycast at A's poses times the guess
// (calibrate_pair); each result into run.frames, the accepted ones averaged into run.
bool register_b_frames(const PinholeSlot& a, PinholeSlot& b, TsdfVolume& volume, FramePyramid<real_t>& pyramid,
                       const IcpWorkspace<real_t>& ws, ImageView<uint16_t> filter_scratch,
                       const std::vector<Pose>& pose_a, const Pose& guess, const PairCalibrationParams& params,
                       PairCalibrationRun& run, std::string& err, bool verbose) {
  PoseMean accepted;
  for (std::size_t i = 0; i < pose_a.size(); ++i) {
    const int j = frame_near(b.seq, a.seq.frames[i].stamp_s);
    if (j < 0) continue;
    DepthFrame f;
    if (!b.stage(std::size_t(j), true, false, 0.0f, filter_scratch, f, err)) return false;
    if (build_pyramid<real_t>(f.depth, PyramidParams(), pyramid) != Status::kOk) {
      err = b.seq.frames[std::size_t(j)].depth_path + ": pyramid failed";
      return false;
    }
    PairCalibrationResult r;
    if (calibrate_pair<real_t>(volume, pose_a[i], guess, b.seq.intr, pyramid, b.maps, ws,
                               params, r) != Status::kOk) {
      err = "calibration failed on frame " + std::to_string(j);
      return false;
    }
    run.frames.push_back(r);
    run.frame_index.push_back(j);
    if (verbose) {
      const Eigen::Quaternionf q = r.T_a_b.quaternion();
      std::printf("frame %d: %s  t %.2f %.2f %.2f mm  q %.5f %.5f %.5f %.5f  rms %.2f mm  inliers %.2f  %d dof "
                  "(weakest %.1e)%s%s\n",
                  j, r.accepted ? "accepted" : "refused ", 1e3f * r.T_a_b.t.x(), 1e3f * r.T_a_b.t.y(),
                  1e3f * r.T_a_b.t.z(), q.x(), q.y(), q.z(), q.w(), 1e3f * r.rms_m, r.inlier_ratio, r.observable,
                  r.weakest_ratio, r.accepted ? "" : ": ", r.reason);
    }
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

bool run_pair_calibration(PinholeSlot& a, PinholeSlot& b, TsdfVolume& volume, FramePyramid<real_t>& pyramid,
                          const IcpWorkspace<real_t>& ws, ImageView<uint16_t> filter_scratch, int frames,
                          const Pose& guess, const PairCalibrationParams& params, PairCalibrationRun& run,
                          std::string& err, bool verbose, const TrackingBuffers* track_a) {
  run = PairCalibrationRun{};
  // Masks and jump edges, but no bilateral smoothing: it moves depth edges, and edges are what pin
  // the lateral directions (measured on bin_rig_a: 1.1 mm bias with it, 0.6 mm without).
  // (The slots' own settings are restored on return: fusion keeps the bilateral filter.)
  struct Restore {
    PinholeSlot& a;
    PinholeSlot& b;
    bool ba, bb;
    ~Restore() {
      a.filters.bilateral_enabled = ba;
      b.filters.bilateral_enabled = bb;
    }
  } restore{a, b, a.filters.bilateral_enabled, b.filters.bilateral_enabled};
  a.filters.bilateral_enabled = false;
  b.filters.bilateral_enabled = false;
  const std::size_t n = std::min<std::size_t>(std::size_t(frames), a.seq.frames.size());
  std::vector<Pose> pose_a(n);
  return fill_space_from_a(a, volume, filter_scratch, n, track_a, pose_a, run, err) &&
         register_b_frames(a, b, volume, pyramid, ws, filter_scratch, pose_a, guess, params, run, err, verbose);
}

// --- multi-sensor fusion of a rig set

std::vector<std::string> split_names(const std::string& s) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : s) {
    if (c == ',') {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  return out;
}

bool open_rig_sensors(const std::string& folder, const io::RigSet& set, const std::vector<std::string>& names,
                      const BoardCapacities& board, RigSensors& rs, std::string& err, bool& usage) {
  usage = true;
  if (int(names.size()) > board.sensors_max) {
    err = "--sensors lists " + std::to_string(names.size()) + " sensors; board " + board.name + " has " +
          std::to_string(board.sensors_max) + " slots";
    return false;
  }
  rs = RigSensors();
  rs.cams.reserve(names.size());
  rs.listed = int(names.size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    const io::RigSensor* s = set.rig.find_sensor(names[i]);
    if (s == nullptr) {
      err = folder + "/rig.toml has no sensor '" + names[i] + "' (--sensors)";
      return false;
    }
    for (std::size_t k = 0; k < i; ++k)
      if (names[k] == names[i]) {
        err = "--sensors names '" + names[i] + "' twice";
        return false;
      }
    usage = false;
    if (s->kind == io::SensorKind::kPinhole) {
      rs.cams.emplace_back();
      if (!io::open_depth_sequence(folder, names[i], rs.cams.back().seq, err)) return false;
      rs.cams.back().slot = int(i);
    } else {
      rs.scans.emplace_back();
      if (!io::open_line_scan(set.rig, names[i], rs.scans.back(), err)) return false;
      rs.scan_slot.push_back(int(i));
    }
    usage = true;
  }
  usage = false;
  for (std::size_t i = 0; i < rs.cams.size() && rs.ref < 0; ++i)
    if (rs.cams[i].seq.colour_registered) rs.ref = int(i);
  if (rs.ref < 0 && !rs.cams.empty()) rs.ref = 0;
  return true;
}

bool bind_rig_sensors(RigSensors& rs, CoreSetup& core, const BoardCapacities& board,
                      ImageView<uint16_t>& filter_scratch, std::string& err) {
  for (PinholeSlot& c : rs.cams)
    if (!c.bind(core.buffers, board, c.slot, err)) return false;
  int spare = board.sensors_max - 1;
  for (const PinholeSlot& c : rs.cams)
    if (c.slot == spare) spare = -1;
  if (spare < 0) {
    if (rs.listed >= board.sensors_max) {
      err = "no spare frame buffer for the filters; list fewer sensors";
      return false;
    }
    spare = rs.listed;
  }
  filter_scratch = ImageView<uint16_t>(core.buffers.depth_frames + std::size_t(spare) * core.buffers.pixels_per_sensor,
                                       board.image_width_max, board.image_height_max);
  return true;
}

bool place_rig_volume(RigSensors& rs, FuseSettings& settings, std::string& err) {
  if (rs.ref >= 0) {
    PinholeSlot& r = rs.cams[std::size_t(rs.ref)];
    if (!io::load_depth(r.seq.frames[0], r.seq.intr, r.load_depth, err)) return false;
    if (!r.seq.frames[0].has_pose) {
      err = r.seq.root + ": the first frame has no pose";
      return false;
    }
    return centre_on_view(r.seq.intr, r.load_depth, r.seq.frames[0].T_world_cam, settings, r.seq.frames[0].depth_path,
                          err);
  }
  std::vector<float> c[3];
  const io::LineScan& s = rs.scans[0];
  for (std::size_t p = 0; p < s.profiles.size(); p += 4)
    for (int i = 0; i < s.profiles.beams; i += 8)
      if (s.has_pose[p] && s.profiles.profile(p)[i] > 0.0f) {
        const Vec3f w = s.T_world_sensor[p] * (s.profiles.profile(p)[i] * s.sensor.line.beam_direction(i));
        for (int a = 0; a < 3; ++a) c[a].push_back(w(a));
      }
  if (c[0].empty()) {
    err = s.sensor.name + ": the line scanner has no returns to centre the volume on (give --origin)";
    return false;
  }
  for (int a = 0; a < 3; ++a) {
    std::nth_element(c[a].begin(), c[a].begin() + std::ptrdiff_t(c[a].size() / 2), c[a].end());
    settings.origin_m(a) = c[a][c[a].size() / 2] - 0.5f * float(settings.dim) * settings.voxel_m;
  }
  return true;
}

bool plan_sub_unit_fill(RigSensors& rs, bool filter, float sigma_ref_m, ImageView<uint16_t> filter_scratch, int& fill,
                        std::string& err) {
  fill = kWeightUnitsPerSample;
  if (!(sigma_ref_m > 0.0f)) return true;
  std::vector<float> sigma;
  for (PinholeSlot& cam : rs.cams) {
    if (cam.seq.frames.empty()) {
      sigma.push_back(0.0f);
      continue;
    }
    // The counts are left as they were (the slot's buffers are restaged by the push).
    const PinholeSlot::StageCounts before = cam.counts;
    DepthFrame f;
    if (!cam.stage(0, filter, false, sigma_ref_m, filter_scratch, f, err)) return false;
    sigma.push_back(cam.median_sigma());
    cam.counts = before;
  }
  fill = default_sub_unit_fill(sigma.data(), int(sigma.size()), sigma_ref_m);
  for (PinholeSlot& cam : rs.cams) cam.sub_unit_fill_units = fill;
  return true;
}

bool push_rig_frames(RigSensors& rs, CoreSetup& core, const RowRunner* runner, const std::vector<Pose>& mount,
                     const std::vector<char>& mounted, std::size_t frames_max, bool filter, bool colour_ref,
                     float sigma_ref_m, ImageView<uint16_t> filter_scratch, std::string& err, bool verbose,
                     const LaserPushOptions& laser) {
  for (std::size_t c = 0; c < rs.cams.size(); ++c) {
    PinholeSlot& cam = rs.cams[c];
    const std::size_t n = std::min<std::size_t>(cam.seq.frames.size(), frames_max);
    const bool colour = colour_ref && int(c) == rs.ref && cam.seq.colour_registered && core.volume.has_colour();
    std::size_t pushed = 0;
    for (std::size_t i = 0; i < n; ++i) {
      Pose T;
      if (mounted[c]) {
        const io::DepthSequence& rseq = rs.cams[std::size_t(rs.ref)].seq;
        const int j = frame_near(rseq, cam.seq.frames[i].stamp_s);
        if (j < 0 || !rseq.frames[std::size_t(j)].has_pose) continue;
        T = rseq.frames[std::size_t(j)].T_world_cam * mount[c];
      } else {
        if (!cam.seq.frames[i].has_pose) {
          err = cam.seq.frames[i].depth_path + " has no ground-truth pose";
          return false;
        }
        T = cam.seq.frames[i].T_world_cam;
      }
      DepthFrame f;
      if (!cam.stage(i, filter, colour, sigma_ref_m, filter_scratch, f, err)) return false;
      const Status s = integrate_frame<real_t>(runner, core.volume, cam.seq.intr, cam.ray_norms, f, T, cam.scratch);
      if (s != Status::kOk) {
        err = cam.seq.frames[i].depth_path + ": " + to_string(s);
        return false;
      }
      ++pushed;
    }
    if (verbose) {
      char gate[96] = "";
      if (cam.sigma_max_m > 0.0f && cam.counts.staged_pixels > 0)
        std::snprintf(gate, sizeof(gate), ", noise gate %.1f mm dropped %.1f %% of its pixels", 1e3f * cam.sigma_max_m,
                      100.0 * double(cam.counts.gated_pixels) / double(cam.counts.staged_pixels));
      char jump[96] = "";
      if (cam.counts.jump_frames > 0)
        std::snprintf(jump, sizeof(jump), ", depth jump %.1f mm", 1e3 * std::max(double(core.volume.params().trunc_m),
                                                                                   cam.counts.jump_m_sum / double(cam.counts.jump_frames)));
      std::printf("%s: %zu frames pushed (%s%s%s%s%s)\n", cam.seq.sensor_name.c_str(), pushed,
                  cam.tof ? "ToF" : "structured light", filter ? ", pre-filtered" : "", colour ? ", colour" : "", gate,
                  jump);
    }
  }
  for (std::size_t k = 0; k < rs.scans.size(); ++k) {
    const io::LineScan& scan = rs.scans[k];
    void* tan = reinterpret_cast<real_t*>(core.buffers.ray_norms) + std::size_t(rs.scan_slot[k]) * core.buffers.pixels_per_sensor;
    // Inverse-variance trust, not capped at 1: where the 20 um scanner measured it must dominate the
    // cameras (capped at 1 it holds ~1/6 of the voxel: fused 0.061 mm median on its strip against
    // 0.008 mm for the laser alone).
    const float trust =
        sigma_ref_m > 0 ? NoiseModel::constant(20e-6f).trust(sigma_ref_m, 0.0f, 0.0f, kProfileTrustMax) : 1.0f;
    LaserPushStats st;
    if (!push_line_scan(core.volume, scan, tan, int(core.buffers.pixels_per_sensor), trust, laser, st, err)) return false;
    if (verbose) {
      std::printf("%s: %d profiles pushed (line scanner, %d beams)\n", scan.sensor.name.c_str(), st.profiles,
                  scan.sensor.line.beams);
      if (laser.register_patches) {
        const Pose& c = st.last_correction;
        std::printf("%s: registered %d of %d patches of %d profiles against the space (mean rms %.3f mm); carried "
                    "correction %.3f mm, %.4f deg; largest change between patches %.3f mm\n",
                    scan.sensor.name.c_str(), st.accepted, st.patches, laser.patch_profiles, 1e3f * st.mean_rms_m,
                    1e3f * c.t.norm(), 57.29578f * c.angle_rad(), st.max_step_mm);
      }
      // How far the registration moved the scanner from its recorded poses (0 without it).
      for (std::size_t p = 0; p < scan.profiles.size(); ++p)
        if (scan.has_pose[p] && st.profiles > 0) {
          const Pose D = scan.T_world_sensor[p].inverse() * st.first_pose_used;
          std::printf("%s: first profile's pose as integrated is %.3f mm, %.4f deg from the recorded pose "
                      "(t %.3f %.3f %.3f mm in its frame)\n",
                      scan.sensor.name.c_str(), 1e3f * D.t.norm(), 57.29578f * D.angle_rad(), 1e3f * D.t.x(),
                      1e3f * D.t.y(), 1e3f * D.t.z());
          break;
        }
    }
  }
  return true;
}

int support_weight(const TsdfVolume& vol, const Vec3f& p) {
  const Vec3f g = (p - vol.origin_m()) / vol.voxel_m() - Vec3f::Constant(0.5f);
  int best = 0;
  for (int c = 0; c < 8; ++c) {
    const int x = int(std::floor(g.x())) + (c & 1), y = int(std::floor(g.y())) + ((c >> 1) & 1),
              z = int(std::floor(g.z())) + ((c >> 2) & 1);
    if (x < 0 || y < 0 || z < 0 || x >= vol.dim() || y >= vol.dim() || z >= vol.dim()) continue;
    best = std::max(best, int(vol.weight()[vol.index(x, y, z)]));
  }
  return best;
}

}  // namespace edgefuse::cli
