// edgefuse localize: object poses (model-based, PPF voting + ICP + verification) or model-free
// segments on a rig set fused at its ground-truth poses, a single depth frame (fused into the
// space, so the free-space check works), or a PLY/PCD cloud.
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <vector>

#include "failure.hpp"
#include "args.hpp"
#include "edgefuse/hal/platform/config/board_defaults.hpp"
#include "commands.hpp"
#include "core_setup.hpp"
#include "edgefuse/io/dataset.hpp"
#include "edgefuse/io/pcd.hpp"
#include "edgefuse/io/ply.hpp"
#include "edgefuse/localize/localizer.hpp"
#include "edgefuse/pipeline/localization_job.hpp"
#include "edgefuse/pipeline/mapper.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "edgefuse/hal/platform/threads/pool_parallel_for.hpp"
#include "edgefuse/io/localize_io.hpp"
#include "edgefuse/io/trajectory.hpp"
#include "calib_store_io.hpp"
#include "edgefuse/hal/platform/config/calib_file_store.hpp"
#include "rig_fusion.hpp"

namespace edgefuse::cli {
namespace {

const char* kUsage =
    "usage: edgefuse localize INPUT --model FILE.ply [--model FILE ...] [--max N] [--out poses.txt]\n"
    "       edgefuse localize INPUT --segments [--max N] [--out labels.pcd]\n"
    "  options: [--sensor NAME | --sensors A,B,...] [--frames N] [--voxel M] [--volume N] [--threads N] [--no-walls] [--min-score S]\n"
    "           [--icp-iterations N] (per hypothesis, default 12)\n"
    "           [--max-incidence DEG] (model surface seen more obliquely is not expected in the scene, default 75)\n"
    "           [--no-rest-poses] (no second round of rest-pose hypotheses: parts on the floor on a stable face,\n"
    "           x, y and yaw voted from heights above the floor, on the surface the first round left unexplained)\n"
    "           [--scene-out FILE.ply] (the scene after bin removal, for inspection)\n"
    "           [--bin FILE.toml] (the bin's floor pose and inner size from configuration instead of detection;\n"
    "           [bin] pose = [tx, ty, tz, qx, qy, qz, qw] (T_world_bin, z up, origin at the inner floor's centre),\n"
    "           inner_size_m = [x, y])\n"
    "           [--config FILE.toml] (models and bin named in a runtime configuration: [localize] models = a PLY,\n"
    "           a folder of them or a list of files, [localize] bin = a --bin file; paths relative to the file)\n"
    "           [--seg-smooth DEG] [--seg-concave TOL] [--seg-radius M] [--seg-colour TOL]\n"
    "           [--seg-crease DEG (0: off)] [--seg-crease-radius M] [--seg-crease-concave C] [--seg-crease-pairs N]\n"
    "           [--seg-crease-share S] [--seg-keep-small] (region growing, its concave-crease cut and the merge of\n"
    "           small pieces into their neighbour, see localizer.hpp)\n"
    "  INPUT: a rig set or depth-sequence folder (fused at its ground-truth poses), a single-frame folder\n"
    "  (depth.png + camera.toml, fused as one frame), or a PLY/PCD cloud (organised clouds get normals from\n"
    "  their image neighbours, unorganised ones without normals by PCA; no free-space check on clouds).\n"
    "  --track: fuse a sequence at poses tracked by ICP against the fused model (as `edgefuse track`: pre-filters,\n"
    "  first pose from the set, push after 1 cm / 1 deg or with [--push-every-frame]) instead of its ground-truth poses.\n"
    "  --sensors A,B,..: fuse these sensors of a rig set (as `edgefuse fuse --sensors`: pre-filters, noise-model\n"
    "  trust, line scanners) into the one space that is localised in; the viewpoint is the first colour camera's;\n"
    "  with [--no-filter] [--no-trust] [--min-weight W] (as for `edgefuse fuse`); every fused crossing is kept\n"
    "  (no support rule: it was measured to cost the localiser).\n"
    "  --robot FILE --hand-eye FILE|calibrated [--store DIR]: the camera poses from the robot instead of the set's\n"
    "  ground truth: T_base_flange at each frame's stamp (FILE: TUM format `timestamp tx ty tz qx qy qz qw`,\n"
    "  flange-to-base, as `edgefuse handeye --robot` reads; nearest pose within 0.02 s, frames without one are\n"
    "  skipped) times the mounting T_flange_<sensor>, so the objects come out in the robot's base frame.\n"
    "  --hand-eye: a pose file (last line `[T_flange_<sensor>] tx ty tz qx qy qz qw`, as `edgefuse handeye --out`\n"
    "  appends it), a calibration store (its folder or a slot file), or `calibrated`: the store in --store DIR\n"
    "  (default edgefused-state, edgefused's calib.dir), composed as edgefused does: T_flange_rig (HANDEYE SAVE)\n"
    "  x T_rig_<sensor> (the stored pair, else the identity). Sequences and rig sets only (not with --sensors).\n"
    "  Poses: one line per object `id tx ty tz qx qy qz qw score model` (T_world_object; id = picking rank).\n"
    "  --check-truth (rig sets): also verifies every true object pose of objects.txt (at the truth and after ICP\n"
    "  from it) as a hypothesis would be, to show why a known object is missed.\n"
    "  Segments: a PCD with a `label` field per input point (organised inputs keep width x height; 0 = none).\n";

double cpu_ms(clockid_t clock = CLOCK_THREAD_CPUTIME_ID) {
  timespec ts;
  clock_gettime(clock, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

std::string pose_text(const Pose& T) {
  const Eigen::Quaternionf q = T.quaternion();
  char b[160];
  std::snprintf(b, sizeof(b), "%.6f %.6f %.6f %.7f %.7f %.7f %.7f", T.t.x(), T.t.y(), T.t.z(), q.x(), q.y(), q.z(), q.w());
  return b;
}

bool is_dir(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

bool ends_with(const std::string& s, const char* e) {
  const std::size_t n = std::strlen(e);
  return s.size() >= n && s.compare(s.size() - n, n, e) == 0;
}


// What the command line asks for.
struct LocalizeOptions {
  Args args;
  std::vector<std::string> model_files;
  std::string input;
  bool segments = false;
  int max_results = 0;
  int frames_max = 1 << 30;
  FuseSettings fuse;
  LocalizeParams params;
  BinGeometry bin;
  bool bin_from_config = false;
};

// The clocks of the pose list: from the end of the fusion (or cloud normals) to the results.
struct LocalizeClock {
  double cpu = 0, proc = 0;
  std::chrono::steady_clock::time_point wall;
  void start() {
    cpu = cpu_ms();
    proc = cpu_ms(CLOCK_PROCESS_CPUTIME_ID);
    wall = std::chrono::steady_clock::now();
  }
};

// --model may repeat: those pairs are collected first, the rest goes to Args.
bool parse_models(int argc, char** argv, LocalizeOptions& o, std::vector<char*>& rest, Failure& f) {
  for (int i = 0; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--model")) {
      if (i + 1 >= argc) return fail(f, std::string("option --model needs a value\n") + kUsage, 2);
      o.model_files.push_back(argv[++i]);
    } else {
      rest.push_back(argv[i]);
    }
  }
  return true;
}

bool parse_numbers(LocalizeOptions& o, const BoardCapacities& board, std::string& err) {
  const Args& a = o.args;
  LocalizeParams& p = o.params;
  FuseSettings& fs = o.fuse;
  return a.get_int("max", 1, board.objects_max, o.max_results, err) &&
         a.get_int("frames", 1, 1 << 30, o.frames_max, err) && a.get_float("voxel", 1e-4f, 1.0f, fs.voxel_m, err) &&
         a.get_int("volume", 8, board.volume_dim, fs.dim, err) && a.get_int("threads", 1, 64, fs.threads, err) &&
         a.get_float("min-score", 0.0f, 1.0f, p.min_score, err) &&
         a.get_float("seg-smooth", 0.0f, 90.0f, p.segment_smooth_deg, err) &&
         a.get_float("seg-concave", -1.0f, 1.0f, p.segment_concave_tol, err) &&
         a.get_float("seg-radius", 0.001f, 0.1f, p.segment_radius_m, err) &&
         a.get_int("seg-colour", 0, 765, p.segment_colour_tol, err) &&
         a.get_float("seg-crease", 0.0f, 90.0f, p.segment_crease_deg, err) &&
         a.get_float("seg-crease-radius", 0.001f, 0.1f, p.segment_crease_radius_m, err) &&
         a.get_float("seg-crease-concave", 0.0f, 1.5f, p.segment_crease_concave, err) &&
         a.get_int("seg-crease-pairs", 1, 10000, p.segment_crease_min_pairs, err) &&
         a.get_float("seg-crease-share", 0.0f, 1.0f, p.segment_crease_share, err) &&
         a.get_int("icp-iterations", 1, 100, p.icp_iterations, err) &&
         a.get_float("max-incidence", 1.0f, 90.0f, p.max_incidence_deg, err);
}

bool parse_options(int argc, char** argv, LocalizeOptions& o, Failure& f) {
  std::vector<char*> rest;
  if (!parse_models(argc, argv, o, rest, f)) return false;
  std::string err;
  if (!o.args.parse(int(rest.size()), rest.data(),
                    {"max", "out", "sensor", "sensors", "frames", "voxel", "volume", "threads", "min-score",
                     "scene-out", "min-weight", "icp-iterations", "max-incidence", "bin", "config", "seg-smooth",
                     "seg-concave", "seg-radius", "seg-colour", "seg-crease", "seg-crease-radius",
                     "seg-crease-concave", "seg-crease-pairs", "seg-crease-share", "robot", "hand-eye", "store"},
                    {"segments", "seg-keep-small", "no-walls", "no-filter", "no-trust", "check-truth", "track",
                     "push-every-frame", "no-rest-poses"},
                    err) ||
      o.args.positional().size() != 1)
    return fail(f, (err.empty() ? "expected one INPUT" : err) + "\n" + kUsage, 2);
  o.input = o.args.positional()[0];
  o.segments = o.args.has("segments");
  std::string config_bin;
  if (o.args.has("config")) {  // models (and the bin) named in a runtime configuration, as edgefused reads them
    std::vector<std::string> config_models;
    if (!io::read_localize_config(o.args.get("config"), config_models, config_bin, err))
      return fail(f, "--config: " + err, 2);
    if (!o.segments) o.model_files.insert(o.model_files.end(), config_models.begin(), config_models.end());
  }
  if (!o.segments && o.model_files.empty())
    return fail(f, std::string("give at least one --model FILE (or --segments)\n") + kUsage, 2);
  if (o.args.has("sensors") && o.args.has("sensor"))
    return fail(f, std::string("give --sensor or --sensors, not both\n") + kUsage, 2);
  if (o.args.has("robot") != o.args.has("hand-eye"))
    return fail(f, std::string("--robot FILE and --hand-eye FILE|calibrated go together\n") + kUsage, 2);
  if (o.args.has("robot") && (o.args.has("sensors") || !is_dir(o.input)))
    return fail(f, std::string("--robot: a depth sequence or rig set folder, not --sensors or a cloud\n") + kUsage, 2);
  if (o.args.has("robot") && o.args.has("check-truth"))
    return fail(f, std::string("--check-truth compares with objects.txt in the set's world frame, not with --robot\n") +
                       kUsage, 2);
  if (o.args.has("store") && o.args.get("hand-eye") != "calibrated")
    return fail(f, std::string("--store DIR goes with --hand-eye calibrated\n") + kUsage, 2);
  const BoardCapacities& board = build_board();
  hal::BoardDefaults defaults;
  if (!hal::read_board_defaults(board.name, defaults, err)) return fail(f, err);
  o.max_results = board.objects_max;
  o.fuse.voxel_m = defaults.voxel_m;
  o.fuse.trunc_m = defaults.trunc_m;
  o.fuse.max_weight = defaults.max_weight;
  o.fuse.threads = defaults.threads;
  o.fuse.dim = defaults.dim;
  if (o.args.has("seg-keep-small")) o.params.segment_merge_small = false;
  if (!parse_numbers(o, board, err)) return fail(f, err, 2);
  if (o.args.has("voxel")) o.fuse.trunc_m = 4.0f * o.fuse.voxel_m;
  if (o.fuse.dim % kBrickSide != 0) return fail(f, "--volume must be a multiple of " + std::to_string(kBrickSide), 2);
  o.params.detect_walls = !o.args.has("no-walls");
  o.params.rest_poses = !o.args.has("no-rest-poses");
  o.params.max_per_model = o.max_results;
  const std::string bin_file = o.args.has("bin") ? o.args.get("bin") : config_bin;  // the command line wins
  o.bin_from_config = !bin_file.empty();
  if (o.bin_from_config && !io::read_bin_toml(bin_file, o.bin, err)) return fail(f, "--bin: " + err, 2);
  return true;
}

bool load_models(const LocalizeOptions& o, Localizer& loc, Failure& f) {
  std::string err;
  for (const std::string& file : o.model_files) {
    int index = -1;
    if (!io::load_model(loc, file, o.params, index, err)) return fail(f, "model " + file + ": " + err);
    const ModelInfo& mi = loc.model(index);
    std::printf("model %d: %s, diameter %.1f mm, %u dense samples, %u PPF samples (step %.1f mm), %u table entries\n",
                index, mi.name, mi.diameter_m * 1e3, mi.dense_count, mi.ppf_count, mi.ppf_step_m * 1e3, mi.entry_count);
    std::printf("  %d resting faces (down, object frame):", mi.rest_count);
    for (int k = 0; k < mi.rest_count; ++k)
      std::printf(" (%.2f %.2f %.2f)", mi.rest_down[k].x(), mi.rest_down[k].y(), mi.rest_down[k].z());
    std::printf("\n");
  }
  return true;
}

// The scene the localiser works on, and where it came from.
struct Scene {
  CoreSetup core;
  io::PointCloud cloud;      // a cloud input (kept for organised label output)
  std::size_t surface = 0;   // fused surface points (in core.buffers.points)
  LocalizeClock clock;
};

// A rig set fused with several sensors (as `edgefuse fuse --sensors`): pre-filters, noise-model
// trust, line scanners; the viewpoint is the reference camera's mean position.
bool fuse_rig_scene(const LocalizeOptions& o, Localizer& loc, Scene& sc, Failure& f) {
  const Args& args = o.args;
  const BoardCapacities& board = build_board();
  std::string err;
  io::RigSet set;
  if (!is_dir(o.input) || !io::open_rig_set(o.input, set, err))
    return fail(f, "--sensors needs a rig set: " + (err.empty() ? o.input : err));
  RigSensors rs;
  bool usage = false;
  if (!open_rig_sensors(o.input, set, split_names(args.get("sensors")), board, rs, err, usage))
    return fail(f, err, usage ? 2 : 1);
  if (rs.ref < 0) return fail(f, "--sensors needs at least one pinhole camera (the viewpoint)", 2);
  // The cloud localised in keeps every fused crossing: the fusion rules of `fuse --sensors`
  // (per-frame jump limit, sub-unit fill, the set's support rule) were measured not to localise
  // better on bin_rig_a (3/6 objects either way, more false poses with the support rule), so
  // localisation maps with the noise weights alone.
  int min_weight = 0;
  if (!args.get_int("min-weight", 0, 255, min_weight, err)) return fail(f, err, 2);
  FuseSettings fs = o.fuse;
  CoreSetup& core = sc.core;
  ImageView<uint16_t> filter_scratch;
  if (!core.init(board, rs.cams[std::size_t(rs.ref)].seq.intr, err) ||
      !bind_rig_sensors(rs, core, true, filter_scratch, err) || !place_rig_volume(rs, fs, err) ||
      !core.make_volume(fs, err))
    return fail(f, o.input + ": " + err);
  RigMounting own_poses;
  own_poses.T_ref_cam.assign(rs.cams.size(), Pose());
  own_poses.mounted.assign(rs.cams.size(), 0);
  MapperParams mp;
  mp.prefilter = !args.has("no-filter");
  mp.noise_weights = !args.has("no-trust");
  mp.rules.jump_sigmas = 0.0f;
  mp.rules.sub_unit_fill_units = kWeightUnitsPerSample;
  PoolRunners threads;
  threads.start(fs.threads);
  Mapper mapper;
  if (!start_rig_mapper(rs, core, threads.runners(), filter_scratch, mp, mapper, err) ||
      !push_rig_frames(rs, mapper, core, own_poses, std::size_t(o.frames_max), false, err, true))
    return fail(f, err);
  threads.pool.stop();
  const io::DepthSequence& rseq = rs.cams[std::size_t(rs.ref)].seq;
  Vec3f view_sum = Vec3f::Zero();
  std::size_t nv = 0;
  for (std::size_t i = 0; i < std::min<std::size_t>(rseq.frames.size(), std::size_t(o.frames_max)); ++i)
    if (rseq.frames[i].has_pose) {
      view_sum += rseq.frames[i].T_world_cam.t;
      ++nv;
    }
  sc.clock.start();
  LocalizationRequest request;
  request.viewpoint_m = view_sum / float(std::max<std::size_t>(nv, 1));
  request.min_point_weight = uint8_t(min_weight);  // as `edgefuse fuse --min-weight`
  LocalizationReport report;
  const std::size_t cap = std::min<std::size_t>(board.points_max, board.scene_points_max);
  if (load_map_scene(core.volume, core.buffers.points, cap, request, loc, report) != Status::kOk)
    return fail(f, o.input + ": " + report.failed + ": " + to_string(report.status));
  if (min_weight > 0)
    std::printf("confidence filter (--min-weight %d): %zu of %zu surface points kept\n", min_weight,
                report.surface_points, report.surface_points + report.weak_points);
  sc.surface = report.surface_points;
  std::printf("fused %s of %s; surface %zu points%s\n", args.get("sensors").c_str(), o.input.c_str(),
              report.surface_points, report.truncated ? " (truncated at capacity)" : "");
  return true;
}

// --hand-eye FILE: the last `[T_flange_<sensor>] tx ty tz qx qy qz qw` line of a pose file.
bool read_mounting_file(const std::string& path, const std::string& sensor, Pose& T, std::string& err) {
  std::ifstream in(path);
  if (!in) {
    err = "--hand-eye " + path + ": cannot read it";
    return false;
  }
  std::string line, name, found_name;
  bool found = false;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    const std::size_t c = line.find_first_not_of(" \t\r");
    if (c == std::string::npos || line[c] == '#') continue;
    std::istringstream ls(line);
    std::vector<std::string> w;
    for (std::string x; ls >> x;) w.push_back(x);
    name.clear();
    if (!w.empty() && (std::isalpha(static_cast<unsigned char>(w[0][0])) || w[0][0] == '_')) {
      name = w[0];
      w.erase(w.begin());
    }
    double v[7];
    bool ok = w.size() == 7;
    for (std::size_t k = 0; ok && k < 7; ++k) {
      char* end = nullptr;
      v[k] = std::strtod(w[k].c_str(), &end);
      ok = end != w[k].c_str() && *end == '\0' && std::isfinite(v[k]);
    }
    const double qn = ok ? std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]) : 0.0;
    if (!ok || std::fabs(qn - 1.0) > 0.01) {
      err = "--hand-eye " + path + ":" + std::to_string(n) +
            ": expected `[T_flange_<sensor>] tx ty tz qx qy qz qw` (metres, unit quaternion)";
      return false;
    }
    T = Pose::from_tq(float(v[0]), float(v[1]), float(v[2]), float(v[3] / qn), float(v[4] / qn), float(v[5] / qn),
                      float(v[6] / qn));
    found = true;
    found_name = name;
  }
  if (!found) {
    err = "--hand-eye " + path + ": no pose line";
    return false;
  }
  if (!found_name.empty() && found_name != "T_flange_" + sensor) {
    err = "--hand-eye " + path + ": the mounting is " + found_name + ", the sequence's sensor is " + sensor;
    return false;
  }
  return true;
}

// --robot FILE --hand-eye ...: every frame's pose becomes T_base_flange(stamp) * T_flange_<sensor>;
// frames without a flange pose within 0.02 s are dropped (named in the count printed).
bool apply_robot_poses(const LocalizeOptions& o, io::DepthSequence& seq, Failure& f) {
  std::string err, what;
  const std::string spec = o.args.get("hand-eye");
  Pose T_flange_cam;
  std::string store_dir;
  if (spec == "calibrated") {
    store_dir = o.args.get("store", "edgefused-state");
  } else if (is_dir(spec)) {
    store_dir = spec;
  } else {
    const std::size_t slash = spec.find_last_of('/');
    const std::string parent = slash == std::string::npos ? "." : spec.substr(0, slash);
    hal::CalibFileStore probe(parent);
    if (spec == probe.slot_path(0) || spec == probe.slot_path(1) ||
        (slash == std::string::npos && (parent + "/" + spec == probe.slot_path(0) || parent + "/" + spec == probe.slot_path(1))))
      store_dir = parent;
  }
  if (!store_dir.empty()) {
    if (!load_flange_mounting(store_dir, seq.sensor_name, T_flange_cam, what, err)) return fail(f, "--hand-eye: " + err);
  } else {
    if (!read_mounting_file(spec, seq.sensor_name, T_flange_cam, err)) return fail(f, err);
    what = spec;
  }
  std::vector<io::StampedPose> flange;
  if (!io::read_tum_trajectory(o.args.get("robot"), flange, err)) return fail(f, "--robot: " + err);
  std::vector<io::FrameRef> kept;
  for (const io::FrameRef& fr : seq.frames) {
    const io::StampedPose* p = io::find_nearest(flange, fr.stamp_s, 0.02);
    if (p == nullptr) continue;
    io::FrameRef k = fr;
    k.has_pose = true;
    k.T_world_cam = p->T * T_flange_cam;
    kept.push_back(k);
  }
  const std::size_t dropped = seq.frames.size() - kept.size();
  seq.frames.swap(kept);
  if (seq.frames.empty())
    return fail(f, "--robot " + o.args.get("robot") + ": no flange pose within 0.02 s of a frame of " + seq.root);
  std::printf("poses: robot %s (T_base_flange) x T_flange_%s %s from %s; %zu frames, %zu without a flange pose "
              "skipped; poses in the robot's base frame\n",
              o.args.get("robot").c_str(), seq.sensor_name.c_str(), pose_text(T_flange_cam).c_str(), what.c_str(),
              seq.frames.size(), dropped);
  return true;
}

// A depth sequence (or a single frame) fused through the pipeline's Mapper: at its ground-truth
// poses as recorded (no pre-filters, no colour), or tracked (--track, as `edgefuse track`).
bool fuse_sequence_scene(const LocalizeOptions& o, Localizer& loc, Scene& sc, Failure& f) {
  const BoardCapacities& board = build_board();
  std::string err;
  io::DepthSequence seq;
  if (!io::open_depth_sequence(o.input, o.args.get("sensor"), seq, err)) return fail(f, err);
  if (o.args.has("robot") && !apply_robot_poses(o, seq, f)) return false;
  const std::size_t frame_count = std::min<std::size_t>(seq.frames.size(), std::size_t(o.frames_max));
  if (frame_count == 0) return fail(f, o.input + " has no frames");
  const bool single = seq.frames.size() == 1 && !seq.frames[0].has_pose;
  FuseSettings fs = o.fuse;
  if (single && !o.args.has("voxel")) {  // a camera-frame scene ~1 m away: 4 mm voxels span 1 m
    fs.voxel_m = 0.004f;
    fs.trunc_m = 0.016f;
  }
  const bool track = o.args.has("track") && !single;
  const bool tof = !seq.frames[0].amplitude_path.empty();
  CoreSetup& core = sc.core;
  CameraSlot cam;
  if (!core.init(board, seq.intr, err) ||
      !core.bind_camera(cam, 0, seq.intr, tof ? DepthSensorKind::kTimeOfFlight : DepthSensorKind::kStructuredLight,
                        true, false, err))
    return fail(f, o.input + ": " + err);
  if (track && board.sensors_max < 2)
    return fail(f, "--track: the board's buffers do not hold this sensor's frame pyramid");
  std::vector<uint16_t> depth, amplitude;
  if (!io::load_depth(seq.frames[0], seq.intr, depth, err)) return fail(f, err);
  const Pose first = single ? Pose::identity() : seq.frames[0].T_world_cam;
  if (!centre_on_view(seq.intr, depth, first, fs, seq.frames[0].depth_path, err) || !core.make_volume(fs, err))
    return fail(f, o.input + ": " + err);
  PoolRunners threads;
  threads.start(fs.threads);
  MapperParams mp;
  mp.poses = track ? PoseMode::kTracked : PoseMode::kKnown;
  mp.prefilter = track;
  mp.tracker.push.every_frame = o.args.has("push-every-frame");
  Mapper mapper;
  if (mapper.init(core.volume, threads.runners(), core.spare_image(seq.intr.width, seq.intr.height),
                  core.centre_scratch(seq.intr), mp) != Status::kOk)
    return fail(f, "--track: bad tracker parameters");
  mapper.new_map_in_place();
  int tracked_ok = 0, pushed = 0;
  for (std::size_t i = 0; i < frame_count; ++i) {
    const io::FrameRef& fr = seq.frames[i];
    if (!track && !single && !fr.has_pose) return fail(f, o.input + ": frame " + std::to_string(i) + " has no ground-truth pose");
    if (i > 0 && !io::load_depth(fr, seq.intr, depth, err)) return fail(f, err);
    amplitude.clear();
    if (track && !fr.amplitude_path.empty() && !io::load_amplitude(fr, seq.intr, amplitude, err)) return fail(f, err);
    SensorFrame frame;
    frame.depth = core.stage_frame(depth, nullptr).depth;
    if (!amplitude.empty()) frame.amplitude = ImageView<const uint16_t>(amplitude.data(), seq.intr.width, seq.intr.height);
    const Pose known = single ? Pose::identity() : fr.T_world_cam;
    ReferenceStep step;
    const Status s = mapper.map_reference(cam, frame, track ? nullptr : &known, first, step);
    if (s != Status::kOk)
      return fail(f, (track ? "--track: frame " : "frame ") + std::to_string(i) + " (" + fr.depth_path + "): " + to_string(s));
    tracked_ok += step.track.state == TrackState::kOk;
    pushed += step.integrated;
    if (track && fr.has_pose && i + 1 == frame_count)
      std::printf("tracked %zu frames (%d ok, %d pushed); last pose %.2f mm from the set's ground truth\n", frame_count,
                  tracked_ok, pushed, (step.T_world_cam.t - fr.T_world_cam.t).norm() * 1e3);
  }
  threads.pool.stop();
  sc.clock.start();  // the clock of the pose list starts after the last integrated frame
  LocalizationRequest request;
  request.viewpoint_m = mapper.mean_viewpoint();
  LocalizationReport report;
  const std::size_t cap = std::min<std::size_t>(board.points_max, board.scene_points_max);
  if (load_map_scene(core.volume, core.buffers.points, cap, request, loc, report) != Status::kOk)
    return fail(f, o.input + ": " + report.failed + ": " + to_string(report.status));
  sc.surface = report.surface_points;
  std::printf("fused %zu frames of %s (%s); surface %zu points%s\n", frame_count, o.input.c_str(),
              seq.sensor_name.c_str(), report.surface_points, report.truncated ? " (truncated at capacity)" : "");
  return true;
}

// A PLY/PCD cloud in its camera's frame: organised clouds get normals from their image neighbours,
// unorganised ones by PCA; no free-space check.
bool load_cloud_scene(const LocalizeOptions& o, Localizer& loc, Scene& sc, Failure& f) {
  std::string err;
  const std::string& input = o.input;
  // The readers' messages begin with the file's name (and line); only the extension test needs it added.
  if (!(ends_with(input, ".pcd")   ? io::read_pcd(input, sc.cloud, err)
        : ends_with(input, ".ply") ? io::read_ply(input, sc.cloud, err)
                                   : (err = input + ": expected a folder, .ply or .pcd", false)))
    return fail(f, err);
  std::vector<ScenePoint> pts;
  const double t_normals = cpu_ms();  // normals of a cloud are not part of the pose-list clock: own figure
  std::size_t beyond = 0;
  if (!io::cloud_scene_points(sc.cloud, pts, beyond, err)) return fail(f, input + ": " + err);
  if (beyond > 0)
    std::fprintf(stderr, "edgefuse localize: %s: %zu points lie beyond %.0f m of the origin (not a robot cell's "
                 "coordinates): ignored\n", input.c_str(), beyond, double(kLocalizeCoordMaxM));
  std::printf("normals_cpu_ms=%.1f (cloud normals and scene points, before the localisation clock starts)\n",
              cpu_ms() - t_normals);
  SceneContext ctx;
  ctx.viewpoint_m = Vec3f::Zero();  // a cloud is in its camera's frame
  sc.clock.start();
  const Status ss = loc.set_scene_points(pts.data(), pts.size(), ctx, nullptr, 0.005f);
  std::printf("cloud %s: %zu points (%dx%d), %zu with normals%s\n", input.c_str(), sc.cloud.size(), sc.cloud.width,
              sc.cloud.height, pts.size(), ss == Status::kOutputTruncated ? " (truncated at capacity)" : "");
  return true;
}

void print_bin(const Localizer& loc, bool from_config, std::size_t before) {
  const SceneContext& c = loc.context();
  std::printf("bin: %s, %d walls; %zu of %zu scene points left\n",
              from_config ? "from configuration" : c.has_floor ? "floor found" : "no floor", c.walls,
              loc.scene_count(), before);
  if (c.has_floor)
    std::printf("floor: up %.3f %.3f %.3f offset %.4f, centre %.3f %.3f %.3f, extent %.3f..%.3f along (%.2f %.2f %.2f), "
                "%.3f..%.3f along (%.2f %.2f %.2f)\n",
                c.up.x(), c.up.y(), c.up.z(), c.floor_offset, c.floor_centre_m.x(), c.floor_centre_m.y(),
                c.floor_centre_m.z(), c.floor_lo[0], c.floor_hi[0], c.floor_axis[0].x(), c.floor_axis[0].y(),
                c.floor_axis[0].z(), c.floor_lo[1], c.floor_hi[1], c.floor_axis[1].x(), c.floor_axis[1].y(),
                c.floor_axis[1].z());
}

// Diagnostics: the scene the matcher sees, after bin removal.
bool write_scene(const std::string& path, const Localizer& loc, std::string& err) {
  io::PointCloud sc;
  for (std::size_t i = 0; i < loc.scene_count(); ++i) {
    sc.points.push_back(loc.scene()[i].p);
    sc.normals.push_back(loc.scene()[i].n);
  }
  sc.width = int(sc.points.size());
  return write_cloud(path, sc, err);
}

void print_results(const Localizer& loc, std::size_t count, bool segments) {
  const LocalizedObject* r = loc.results();
  for (std::size_t i = 0; i < count; ++i) {
    const Eigen::Quaternionf q = r[i].T_world_object.quaternion();
    const Vec3f& t = r[i].T_world_object.t;
    std::printf("%zu %s t %.4f %.4f %.4f q %.5f %.5f %.5f %.5f score %.3f support %u residual %.2f mm free %.3f "
                "top %.1f mm grasp %.4f %.4f %.4f approach %.3f %.3f %.3f size %.1f %.1f %.1f mm\n",
                i + 1, segments ? "segment" : loc.model(r[i].model).name, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(),
                q.w(), r[i].score, r[i].support, r[i].residual_m * 1e3, r[i].free_space, r[i].top_m * 1e3,
                r[i].grasp_m.x(), r[i].grasp_m.y(), r[i].grasp_m.z(), r[i].approach.x(), r[i].approach.y(),
                r[i].approach.z(), r[i].size_m.x() * 1e3, r[i].size_m.y() * 1e3, r[i].size_m.z() * 1e3);
  }
}

// Diagnostics: the true poses of a rig set's objects.txt through the same verification, at the
// truth and after ICP from it, to show why a known object is missed.
bool check_truth(const LocalizeOptions& o, Localizer& loc, Failure& f) {
  std::string err;
  io::RigSet set;
  if (!is_dir(o.input) || !io::open_rig_set(o.input, set, err))
    return fail(f, "--check-truth needs a rig set: " + (err.empty() ? o.input : err));
  for (const io::ObjectPose& ob : set.objects) {
    const io::RigObject* ro = set.rig.find_object(ob.id);
    if (!ro) continue;
    const std::string base = ro->model.substr(ro->model.find_last_of('/') + 1);
    for (int m = 0; m < loc.model_count(); ++m) {
      if (base != loc.model(m).name) continue;
      LocalizedObject at, refined;
      loc.check_pose(m, ob.T_world_object, o.params, false, at);
      const bool ok = loc.check_pose(m, ob.T_world_object, o.params, true, refined);
      const Pose d = ob.T_world_object.inverse() * refined.T_world_object;
      const float ang = std::acos(std::min(1.0f, std::max(-1.0f, 0.5f * (d.R.trace() - 1.0f)))) * 57.29578f;
      std::printf("truth %d %s: at truth score %.3f support %u residual %.2f mm free %.3f; after ICP%s score %.3f "
                  "support %u free %.3f moved %.2f mm %.2f deg\n",
                  ob.id, base.c_str(), at.score, at.support, at.residual_m * 1e3, at.free_space, ok ? "" : " (failed)",
                  refined.score, refined.support, refined.free_space,
                  (refined.T_world_object.t - ob.T_world_object.t).norm() * 1e3, ang);
    }
  }
  return true;
}

bool write_outputs(const LocalizeOptions& o, const Localizer& loc, const Scene& sc, std::size_t count, Failure& f) {
  std::string err;
  if (o.segments) {
    const std::string out = o.args.get("out", "labels.pcd");
    if (!io::write_segment_labels(out, loc, sc.cloud, sc.surface, sc.core.buffers.points, err)) return fail(f, err);
    std::printf("labels -> %s\n", out.c_str());
  } else if (o.args.has("out")) {
    if (!io::write_pose_list(o.args.get("out"), loc, count, err)) return fail(f, err);
    std::printf("poses -> %s\n", o.args.get("out").c_str());
  }
  return true;
}

// Bin, poses or segments on the loaded scene, with the diagnostics the options ask for.
bool localize_scene(const LocalizeOptions& o, Localizer& loc, Scene& sc, Failure& f) {
  LocalizationRequest request;
  request.params = o.params;
  request.max_results = o.max_results;
  request.segments = o.segments;
  request.bin = o.bin_from_config ? &o.bin : nullptr;
  LocalizationReport report;
  remove_bin(request, loc, report);
  print_bin(loc, o.bin_from_config, report.scene_points);
  std::string err;
  if (o.args.has("scene-out") && !write_scene(o.args.get("scene-out"), loc, err)) return fail(f, err);
  const Status ls = find_objects(request, loc, report);
  const double ms_cpu = cpu_ms() - sc.clock.cpu;
  const double ms_proc = cpu_ms(CLOCK_PROCESS_CPUTIME_ID) - sc.clock.proc;
  const double ms_wall =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - sc.clock.wall).count();
  if (ls != Status::kOk) return fail(f, to_string(ls));
  print_results(loc, report.count, o.segments);
  std::printf("%s=%zu candidates=%zu localize_cpu_ms=%.1f localize_proc_cpu_ms=%.1f localize_wall_ms=%.1f\n",
              o.segments ? "segments" : "objects", report.count, loc.last_candidates(), ms_cpu, ms_proc, ms_wall);
  if (o.args.has("check-truth") && !o.segments && !check_truth(o, loc, f)) return false;
  return write_outputs(o, loc, sc, report.count, f);
}


}  // namespace

int cmd_localize(int argc, char** argv) {
  if (help_asked(argc, argv, kUsage)) return 0;
  LocalizeOptions o;
  Failure f;
  if (!parse_options(argc, argv, o, f)) return report("edgefuse localize", f);
  // Start-up: the static buffers and the models.
  const BoardCapacities& board = build_board();
  static Scene scene;  // the board's buffers are carved once, here
  if (carve_memory(board, static_arena(), static_arena_bytes(), scene.core.buffers) != Status::kOk)
    return report("edgefuse localize", Failure{"the static arena does not hold board " + std::string(board.name) + "'s memory map", 1});
  Localizer loc;
  if (loc.init(scene.core.buffers.localize) != Status::kOk)
    return report("edgefuse localize", Failure{"localisation buffers missing in board " + std::string(board.name) + "'s memory map", 1});
  if (!load_models(o, loc, f)) return report("edgefuse localize", f);
  // Hypothesis refinement / verification run over --threads workers (same results for any count).
  WorkerPool loc_pool;
  loc_pool.start(o.fuse.threads);
  loc.set_parallel(pool_parallel_for(loc_pool));
  const bool ok = o.args.has("sensors")  ? fuse_rig_scene(o, loc, scene, f)
                  : is_dir(o.input)      ? fuse_sequence_scene(o, loc, scene, f)
                                         : load_cloud_scene(o, loc, scene, f);
  if (!ok || !localize_scene(o, loc, scene, f)) return report("edgefuse localize", f);
  return 0;
}

}  // namespace edgefuse::cli
