#include "rig_fusion.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "edgefuse/fusion/fusion_rules.hpp"

namespace edgefuse::cli {

bool RigCamera::bind(const CoreSetup& core, bool bilateral_tof, std::string& err) {
  tof = !seq.frames.empty() && !seq.frames[0].amplitude_path.empty();
  const DepthSensorKind kind = tof ? DepthSensorKind::kTimeOfFlight : DepthSensorKind::kStructuredLight;
  if (core.bind_camera(cam, slot, seq.intr, kind, bilateral_tof || !tof, build_board().colour, err)) return true;
  err = seq.root + ": sensor " + seq.sensor_name + ": " + err;
  return false;
}

bool RigCamera::load(std::size_t i, bool with_colour, SensorFrame& frame, std::string& err) {
  const io::FrameRef& f = seq.frames[i];
  const int w = seq.intr.width, h = seq.intr.height;
  frame = SensorFrame();
  if (!io::load_depth(f, seq.intr, load_depth, err)) return false;
  frame.depth = ImageView<const uint16_t>(load_depth.data(), w, h);
  if (tof && !f.amplitude_path.empty()) {
    if (!io::load_amplitude(f, seq.intr, load_amplitude, err)) return false;
    frame.amplitude = ImageView<const uint16_t>(load_amplitude.data(), w, h);
  }
  if (with_colour && !f.colour_path.empty()) {
    if (!io::load_colour(f, seq.intr, load_colour, err)) return false;
    frame.colour = ImageView<const Rgb8>(load_colour.data(), w, h);
  }
  frame.stamp_us = uint64_t(std::llround(f.stamp_s * 1e6));
  return true;
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

bool bind_rig_sensors(RigSensors& rs, CoreSetup& core, bool bilateral_tof, ImageView<uint16_t>& filter_scratch,
                      std::string& err) {
  const BoardCapacities& board = build_board();
  for (RigCamera& c : rs.cams)
    if (!c.bind(core, bilateral_tof, err)) return false;
  int spare = board.sensors_max - 1;
  for (const RigCamera& c : rs.cams)
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
    RigCamera& r = rs.cams[std::size_t(rs.ref)];
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

bool start_rig_mapper(RigSensors& rs, CoreSetup& core, const KernelRunners& runners, ImageView<uint16_t> filter_scratch,
                      const MapperParams& params, Mapper& mapper, std::string& err) {
  PinholeIntrinsics centre_intr;  // a scanner-only set: the volume is placed, never centred by a view
  centre_intr.width = centre_intr.height = 8;
  if (rs.ref >= 0) centre_intr = rs.cams[std::size_t(rs.ref)].seq.intr;
  if (mapper.init(core.volume, runners, filter_scratch, core.centre_scratch(centre_intr), params) != Status::kOk) {
    err = "the mapper refuses its parameters";
    return false;
  }
  CameraSlot* fused[Mapper::kFusedMax];
  int count = 0;
  for (RigCamera& c : rs.cams)
    if (count < Mapper::kFusedMax) fused[count++] = &c.cam;
  mapper.set_fused_cameras(fused, count);
  mapper.new_map_in_place();
  return true;
}

bool plan_sub_unit_fill(RigSensors& rs, Mapper& mapper, int& fill, std::string& err) {
  std::vector<float> sigma;
  for (RigCamera& c : rs.cams) {
    float s = 0.0f;
    SensorFrame frame;
    if (!c.seq.frames.empty()) {
      if (!c.load(0, false, frame, err)) return false;
      const Status st = mapper.measure_noise(c.cam, frame, s);
      if (st != Status::kOk) {
        err = c.seq.frames[0].depth_path + ": " + to_string(st);
        return false;
      }
    }
    sigma.push_back(s);
  }
  fill = default_sub_unit_fill(sigma.data(), int(sigma.size()), 0.5f * mapper.volume().voxel_m());
  mapper.set_sub_unit_fill(fill);
  return true;
}

namespace {

// Camera c's pose for its frame i: its own recorded pose, or the reference's recorded pose of the
// same instant times its mounting; false (no error) when the mounted camera has no such instant.
bool rig_pose(const RigSensors& rs, const RigMounting& mounting, std::size_t c, std::size_t i, Pose& T,
              std::string& err) {
  const RigCamera& cam = rs.cams[c];
  if (mounting.mounted[c]) {
    const io::DepthSequence& rseq = rs.cams[std::size_t(rs.ref)].seq;
    const int j = frame_near(rseq, cam.seq.frames[i].stamp_s);
    if (j < 0 || !rseq.frames[std::size_t(j)].has_pose) return false;
    T = rseq.frames[std::size_t(j)].T_world_cam * mounting.T_ref_cam[c];
    return true;
  }
  if (!cam.seq.frames[i].has_pose) {
    err = cam.seq.frames[i].depth_path + " has no ground-truth pose";
    return false;
  }
  T = cam.seq.frames[i].T_world_cam;
  return true;
}

void print_camera_push(const RigCamera& cam, const Mapper& mapper, std::size_t pushed, bool colour) {
  const CameraSlot::MapCounts& n = cam.cam.counts;
  const float gate_m = mapper.params().rules.noise_gate_m;
  char gate[96] = "";
  if (mapper.params().noise_weights && gate_m > 0.0f && n.pixels > 0)
    std::snprintf(gate, sizeof(gate), ", noise gate %.1f mm dropped %.1f %% of its pixels", 1e3f * gate_m,
                  100.0 * double(n.gated_pixels) / double(n.pixels));
  char jump[96] = "";
  if (n.jump_frames > 0)
    std::snprintf(jump, sizeof(jump), ", depth jump %.1f mm",
                  1e3 * std::max(double(mapper.volume().params().trunc_m), n.jump_m_sum / double(n.jump_frames)));
  std::printf("%s: %zu frames pushed (%s%s%s%s%s)\n", cam.seq.sensor_name.c_str(), pushed,
              cam.tof ? "ToF" : "structured light", mapper.params().prefilter ? ", pre-filtered" : "",
              colour ? ", colour" : "", gate, jump);
}

bool push_camera(RigSensors& rs, Mapper& mapper, const RigMounting& mounting, std::size_t c, std::size_t frames_max,
                 bool colour_ref, std::string& err, bool verbose) {
  RigCamera& cam = rs.cams[c];
  const std::size_t n = std::min<std::size_t>(cam.seq.frames.size(), frames_max);
  const bool colour = colour_ref && int(c) == rs.ref && cam.seq.colour_registered && mapper.volume().has_colour();
  std::size_t pushed = 0;
  for (std::size_t i = 0; i < n; ++i) {
    Pose T;
    if (!rig_pose(rs, mounting, c, i, T, err)) {
      if (!err.empty()) return false;
      continue;
    }
    SensorFrame frame;
    if (!cam.load(i, colour, frame, err)) return false;
    const Status s = mapper.map_at(cam.cam, frame, T);
    if (s != Status::kOk) {
      err = cam.seq.frames[i].depth_path + ": " + to_string(s);
      return false;
    }
    ++pushed;
  }
  if (verbose) print_camera_push(cam, mapper, pushed, colour);
  return true;
}

void print_scan_push(const io::LineScan& scan, const LaserPushOptions& laser, const LaserPushStats& st) {
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

}  // namespace

bool push_rig_frames(RigSensors& rs, Mapper& mapper, CoreSetup& core, const RigMounting& mounting,
                     std::size_t frames_max, bool colour_ref, std::string& err, bool verbose,
                     const LaserPushOptions& laser) {
  for (std::size_t c = 0; c < rs.cams.size(); ++c)
    if (!push_camera(rs, mapper, mounting, c, frames_max, colour_ref, err, verbose)) return false;
  for (std::size_t k = 0; k < rs.scans.size(); ++k) {
    const io::LineScan& scan = rs.scans[k];
    void* tan = reinterpret_cast<real_t*>(core.buffers.ray_norms) + std::size_t(rs.scan_slot[k]) * core.buffers.pixels_per_sensor;
    LaserPushStats st;
    if (!push_line_scan(mapper, scan, tan, int(core.buffers.pixels_per_sensor), laser, st, err)) return false;
    if (verbose) print_scan_push(scan, laser, st);
  }
  return true;
}

}  // namespace edgefuse::cli
